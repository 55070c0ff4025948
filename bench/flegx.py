"""FLEGX countermovement jump (seed 002): wall time per run for each link model, with and
without compilation.

Model: ``proleg.papers.flegx_jump(configuration=4, link_case=2, link_model=...)`` with the
default motion law (stand 0.15 s, squat 0.8 s, hold 0.1 s, push 0.3 s, 0.6 s after the push:
1.95 s simulated), outputs every 1 ms, generalized-α at rtol 1e-5, atol 1e-6.

Columns: ``first [s]`` is the whole first ``flegx_jump`` call (build, assemble, compile,
simulate, metrics); ``sim [s]`` the ``simulate`` call alone inside it; ``rerun [s]`` a second
``simulate`` of the same assembled system (compiled: the run itself); ``steps``; and the
jump metrics. Each link model runs in its own fresh process (so ``first`` includes that
model's compilation; the persistent XLA cache may shorten it: ``--no-cache`` turns it off).

    python bench/flegx.py                 # rigid, prbm, cb: table + bench/results/flegx.md/.json
    python bench/flegx.py --models cb

Equal-stress ranking (``--equal-stress``): Table I's stresses all lie in 514-531 MPa, as if each
configuration's motion law had been pushed to the stress limit; with one common law the
configurations end at very different stresses. This runs the PRBM link (case 2) of No. 1-4 with
the push durations ``--pushes`` (shorter = harder), interpolates each configuration's jump height
at ``--stress`` MPa (the stress up to take-off) and ranks them (bench/results/flegx_equal_stress.md).

    python bench/flegx.py --equal-stress --pushes 0.22 0.26 0.30
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
from proleg.papers import flegx_jump
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


def equal_stress(pushes, stress_mpa, link_model="prbm"):
    """Jump height of No. 1-4 (link case 2) at equal stress up to take-off (module docstring)."""
    import numpy as np
    import pandas as pd

    sys.path.insert(0, str(HERE.parent / "src"))
    from proleg.robots import flegx_data as D
    from proleg.papers.flegx_jump import MotionLaw
    from proleg.papers.flegx_study import STUDY_T_AFTER, ranking, run_table_i

    t0 = time.perf_counter()
    rows = []
    for tp in pushes:
        law = MotionLaw(t_push=float(tp), t_after=STUDY_T_AFTER)
        tab = run_table_i(HERE / "results" / "flegx_equal_stress" / f"push_{tp:g}", (1, 2, 3, 4), (2,),
                          2 if link_model == "cb" else None, progress=False, law=law)
        tab = tab[tab["link model"] == link_model]
        for r in tab.itertuples():
            rows.append({"push [s]": tp, "configuration": r.configuration, "jump [mm]": r.jump_height * 1e3,
                         "stress take-off [MPa]": r.max_stress_takeoff / 1e6})
    df = pd.DataFrame(rows)
    at = {}
    for c in (1, 2, 3, 4):
        s = df[df["configuration"] == c].sort_values("stress take-off [MPa]")
        x, y = s["stress take-off [MPa]"].to_numpy(), s["jump [mm]"].to_numpy()
        at[c] = float(np.interp(stress_mpa, x, y, left=np.nan, right=np.nan))
    lines = [df.to_string(index=False, float_format="{:.4g}".format), "",
             f"Jump height at {stress_mpa:g} MPa (linear interpolation; NaN: outside the sampled stresses): "
             + ", ".join(f"No. {c}: {v:.1f} mm" for c, v in at.items()),
             "Ranking at equal stress: " + " > ".join(f"No. {c}" for c in ranking(at))
             + "; seed 002 Table I: " + " > ".join(f"No. {c}" for c in ranking({c: D.TABLE_I[c][1] for c in (1, 2, 3, 4)})),
             f"\n{link_model} link, case 2; wall {time.perf_counter() - t0:.0f} s, load average {os.getloadavg()[0]:.1f}"]
    text = "\n".join(lines)
    (HERE / "results").mkdir(exist_ok=True)
    (HERE / "results" / "flegx_equal_stress.md").write_text(text + "\n")
    print(text)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--models", nargs="+", default=["rigid", "prbm", "cb"])
    ap.add_argument("--no-cache", action="store_true", help="PROLEG_CACHE_DIR='' (compile every time)")
    ap.add_argument("--equal-stress", action="store_true", help="rank No. 1-4 at equal stress (module docstring)")
    ap.add_argument("--pushes", nargs="+", type=float, default=[0.22, 0.26, 0.30])
    ap.add_argument("--stress", type=float, default=520.0, help="[MPa] stress at which to compare (Table I: 514-531)")
    a = ap.parse_args(argv)
    if a.equal_stress:
        return equal_stress(a.pushes, a.stress)
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
