"""The papers' models with no integrator named, this checkout against another: same answers, not slower.

Issue 29 made ``integrator="auto"`` the default and moved every method onto one protocol. Its
target for the scenarios: "HAL drop, HyQ drop, Scout II and FLEGX scenarios: the same answers
within their tolerances, and not slower". This script runs each model in a fresh Python
process per checkout, interleaved (``--src DIR``: another checkout's ``src/``, e.g. a worktree
of e754ddf, the commit before the protocol), so both see the same machine load:

``hal_drop``   ``robots.hyq_leg()`` (rigid joints, drop actuators), 0.3 s of its 5 cm drop
``hal_bush``   ``robots.hyq_leg(joints="bushings8")``, 0.3 s
``hyq_drop``   ``robots.hyq()``: the whole HyQ, 0.3 s of its 10 cm drop
``scout2``     ``robots.scout2("I", per="physical")`` from standing, 0.5 s (``per`` named: its
               default changed after e754ddf, from "physical" to "virtual")
``flegx``      ``robots.flegx(4)``, rigid links, 0.3 s of its jump

Each child assembles, simulates once (compile), then ``--repeat`` more times; the table shows
the fastest warm wall time and its process CPU time, the steps, the integrator that ran, and
the final state's largest difference from the other checkout's (``Δq end``; 0 = bitwise).
Cold compiles (proleg's persistent cache off in the children).
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys

sys.path.insert(0, os.path.dirname(__file__))
from common import add_output_args, child_result, emit, log  # noqa: E402

MODELS = {
    "hal_drop": ("pl.robots.hyq_leg()", 0.3, 1e-3),
    "hal_bush": ("pl.robots.hyq_leg(joints='bushings8')", 0.3, 1e-3),
    "hyq_drop": ("pl.robots.hyq()", 0.3, 1e-3),
    "scout2": ("pl.robots.scout2('I', per='physical')", 0.5, 1e-3),
    "flegx": ("pl.robots.flegx(4)", 0.3, 1e-3),
}

CHILD = r"""
import json, time
import numpy as np
import proleg as pl
system = pl.assemble({expr})
r = pl.simulate(system, t_end={t_end!r}, dt_output={dt!r}, progress=False, throw=False)
walls, cpus = [], []
for _ in range({repeat}):
    t, c = time.perf_counter(), time.process_time()
    r = pl.simulate(system, t_end={t_end!r}, dt_output={dt!r}, progress=False, throw=False)
    walls.append(time.perf_counter() - t); cpus.append(time.process_time() - c)
i = int(np.argmin(walls))
print("RESULT " + json.dumps(dict(wall=walls[i], cpu=cpus[i], steps=int(r.stats["steps"]),
      integrator=str(r.stats.get("integrator", "GeneralizedAlpha (default)")),
      q_end=np.asarray(r.q[-1]).tolist(), status=getattr(r.status, "name", str(r.status)))))
"""


def child(src, expr, t_end, dt, repeat):
    env = dict(os.environ, PROLEG_CACHE_DIR="")
    if src:
        env["PYTHONPATH"] = src
    return child_result(CHILD.format(expr=expr, t_end=t_end, dt=dt, repeat=repeat), env, f"{src or 'this checkout'}, {expr}")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--models", nargs="+", choices=list(MODELS), default=list(MODELS))
    ap.add_argument("--src", required=True, help="the other checkout's src/ directory (e.g. a worktree of e754ddf)")
    ap.add_argument("--rounds", type=int, default=3, help="fresh-process pairs per model (median of their fastest)")
    add_output_args(ap, "scenario_speed")
    ap.set_defaults(repeat=3)
    args = ap.parse_args(argv)
    here = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "src")
    rows = []
    for name in args.models:
        expr, t_end, dt = MODELS[name]
        res = {"this": [], "other": []}
        for k in range(args.rounds):
            for who, src in (("this", here), ("other", args.src)):
                log(f"{name} ({who}) {k + 1}/{args.rounds} ...")
                res[who].append(child(src, expr, t_end, dt, args.repeat))
        import numpy as np

        dq = float(np.max(np.abs(np.asarray(res["this"][-1]["q_end"]) - np.asarray(res["other"][-1]["q_end"]))))
        w_this = statistics.median(r["wall"] for r in res["this"])
        w_other = statistics.median(r["wall"] for r in res["other"])
        c_this = statistics.median(r["cpu"] for r in res["this"])
        c_other = statistics.median(r["cpu"] for r in res["other"])
        rows.append({
            "model": name, "t_end [s]": t_end,
            "integrator (this)": res["this"][-1]["integrator"], "steps (this / other)": f"{res['this'][-1]['steps']} / {res['other'][-1]['steps']}",
            "wall this [s]": w_this, "wall other [s]": w_other, "wall ratio": w_this / w_other,
            "CPU this [s]": c_this, "CPU other [s]": c_other, "CPU ratio": c_this / c_other,
            "Δq end": dq, "status": res["this"][-1]["status"],
        })
    cols = list(rows[0])
    notes = [
        "wall/CPU: median over rounds of each fresh process's fastest warm simulate (ratio < 1: this checkout faster)",
        "Δq end: max |q(t_end)| difference between the checkouts' last runs (the same model and method: expect round-off only)",
    ]
    emit(args, "Scenario models with no integrator named: this checkout against " + args.src, rows, cols,
         meta={"rounds": args.rounds, "repeat": args.repeat}, notes=notes)


if __name__ == "__main__":
    main()
