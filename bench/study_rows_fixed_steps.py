"""Why the HyQ leg's sweep rows are not `simulate`'s answer to 1e-9 (issue 42 item 5).

Three variants of the HyQ leg's drop (rigid pins, foot stiffness and knee gain changed), as one
``pl.sweep`` batch and as three ``pl.simulate`` runs, once with fixed steps (generalized-α,
2e-5 s: every lane takes the same steps) and once at the defaults (adaptive steps). Fixed steps
give the rows to round-off; adaptive steps give them to the integration tolerance: the batched
kernels round differently from single ones, and a step-size decision that sits at one of its
thresholds (accept at err ≤ 1, keep h for a growth factor in [1, 1.2)) goes the other way in
one of them, after which the two runs take other steps. Writes
bench/results/study_rows_fixed_steps.md.

    PYTHONPATH=src python bench/study_rows_fixed_steps.py
"""

import os
import time
import warnings
from pathlib import Path

import numpy as np


def main():
    import jax

    jax.config.update("jax_enable_x64", True)
    import proleg as pl
    from proleg.robots import hyq_leg

    warnings.simplefilter("ignore")
    s = pl.assemble(hyq_leg("rigid"))
    vals = {"foot.stiffness": np.array([6e4, 1e5, 1.8e5]), "knee_servo.kp": np.array([220.0, 300.0, 380.0])}
    kw = dict(t_end=0.3, dt_output=1e-3)
    rows = []
    for label, ig in [("generalized-α, fixed 2e-5 s steps", pl.GeneralizedAlpha(fixed_step=2e-5)), ("the defaults (adaptive)", None)]:
        extra = {} if ig is None else {"integrator": ig}
        res = pl.sweep(s, vals, **kw, **extra)
        worst = 0.0
        for i in range(3):
            r = pl.simulate(s.with_params({k: v[i] for k, v in vals.items()}), progress=False, **kw, **extra)
            q, qs = np.asarray(r.q), np.asarray(res.q)[i]
            worst = max(worst, float(np.max(np.abs(qs - q)) / np.max(np.abs(q))))
        name = res.integrator if ig is None else ig
        rows.append((label, f"{type(name).__name__}(rtol={name.rtol:g}, fixed_step={name.fixed_step})", worst,
                     [int(n) for n in np.asarray(res.stats["steps"])]))
        print(rows[-1], flush=True)
    md = ["# HyQ leg: sweep rows against simulate, fixed and adaptive steps (bench/study_rows_fixed_steps.py)", "",
          f"{time.strftime('%Y-%m-%d %H:%M')}, {os.cpu_count()} cores, load {os.getloadavg()[0]:.1f}; 3 variants, 0.3 s drop, outputs every 1 ms.", "",
          "| steps | integrator | max rel \\|row − simulate\\| | steps per lane |", "|---|---|---|---|"]
    md += [f"| {a} | {b} | {c:.2e} | {d} |" for a, b, c, d in rows]
    out = Path(__file__).parent / "results" / "study_rows_fixed_steps.md"
    out.write_text("\n".join(md) + "\n")
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
