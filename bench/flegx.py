"""FLEGX countermovement jump (seed 002): wall time per run for each link model, with and
without compilation.

Model: ``proleg.robots.flegx_jump(configuration=4, link_case=2, link_model=...)`` with the
default motion law (stand 0.15 s, squat 0.8 s, hold 0.1 s, push 0.3 s, 0.6 s after the push:
1.95 s simulated), outputs every 1 ms, generalized-α at rtol 1e-5, atol 1e-6.

Columns: ``first [s]`` is the whole first ``flegx_jump`` call (build, assemble, compile,
simulate, metrics); ``sim [s]`` the ``simulate`` call alone inside it; ``rerun [s]`` a second
``simulate`` of the same assembled system (compiled: the run itself); ``steps``; and the
jump metrics. Each link model runs in its own fresh process (so ``first`` includes that
model's compilation; the persistent XLA cache may shorten it: ``--no-cache`` turns it off).

    python bench/flegx.py                 # rigid, prbm, cb: table + bench/results/flegx.md/.json
    python bench/flegx.py --models cb
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent

_CHILD = r"""
import json, time, warnings
t0 = time.perf_counter()
import proleg as pl
from proleg.robots import flegx_jump
j = flegx_jump(link_model=%r, dt_output=1e-3)
first = time.perf_counter() - t0
t1 = time.perf_counter()
r = pl.simulate(j.system, t_end=j.law.t_end, dt_output=1e-3, integrator=pl.GeneralizedAlpha(rtol=1e-5, atol=1e-6), progress=False)
rerun = time.perf_counter() - t1
m = j.metrics
print(json.dumps({"model": %r, "first [s]": first, "sim [s]": j.wall_s, "rerun [s]": rerun, "steps": r.stats["steps"],
                  "jump [mm]": m["jump_height"] * 1e3, "max stress [MPa]": m["max_stress"] / 1e6,
                  "tip [mm]": m["tip_displacement"] * 1e3}))
"""


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--models", nargs="+", default=["rigid", "prbm", "cb"])
    ap.add_argument("--no-cache", action="store_true", help="PROLEG_CACHE_DIR='' (compile every time)")
    a = ap.parse_args(argv)
    env = dict(os.environ)
    env["PYTHONPATH"] = str(HERE.parent / "src") + os.pathsep + env.get("PYTHONPATH", "")
    if a.no_cache:
        env["PROLEG_CACHE_DIR"] = ""
    rows = []
    for lm in a.models:
        t0 = time.perf_counter()
        p = subprocess.run([sys.executable, "-c", _CHILD % (lm, lm)], env=env, capture_output=True, text=True)
        if p.returncode:
            print(p.stderr[-3000:], file=sys.stderr)
            raise SystemExit(p.returncode)
        row = json.loads(p.stdout.strip().splitlines()[-1])
        row["process [s]"] = time.perf_counter() - t0
        rows.append(row)
        print(" | ".join(f"{k}: {v:.4g}" if isinstance(v, float) else f"{k}: {v}" for k, v in row.items()), flush=True)
    import platform

    cols = list(rows[0])
    md = ["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    md += ["| " + " | ".join(f"{r[c]:.4g}" if isinstance(r[c], float) else str(r[c]) for c in cols) + " |" for r in rows]
    out = HERE / "results"
    out.mkdir(exist_ok=True)
    note = f"\n\nmachine: {platform.node()} {platform.processor() or platform.machine()}, {os.cpu_count()} CPUs; {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}\n"
    (out / "flegx.md").write_text("\n".join(md) + note)
    (out / "flegx.json").write_text(json.dumps(rows, indent=1))
    print("\n".join(md) + note)


if __name__ == "__main__":
    main()
