"""Tune the torso's unprinted parameters to seed 001 Table 2 (issue 17): Nelder-Mead on the
log-parameters inside stated physical ranges, minimising sum (log f_FE / f_paper)^2 over the six
modes of :func:`proleg.robots.torso.table2_modes` against Table 2's numerical column.

    OPENBLAS_NUM_THREADS=1 PYTHONPATH=src python bench/torso_table2_tuning.py [--maxfev 300]

Ranges (what a HyQ-size torso can have; seed 001 prints none of these):
pad_stiffness 300..10 000 N/m per foam pad (soft PU blocks ~100 x 100 x 50 mm, E ~ 2..50 kPa),
mount_stiffness 2e4..1e6 N/m per rubber mount (isolators for 5..20 kg machines), its rotational
stiffness 10..2000 N m/rad, tube_outer 30..60 mm and tube_wall 2..4 mm (square aluminium tube), motor 8..16 kg, pump 5..12 kg, tank (with oil) 5..15 kg (HyQ
~80 kg, of which the four legs ~26 kg: MODEL_DATA §1). Prints the start and the tuned values and
the Table 2 comparison; writes bench/results/torso_table2_tuning.csv.
"""

import argparse
import math
import os
import time
from pathlib import Path

import numpy as np
import pandas as pd
from scipy.optimize import minimize

from proleg.robots.torso import TABLE2, TORSO_DEFAULTS, table2_comparison, torso_modal

RANGES = dict(pad_stiffness=(300.0, 1e4), mount_stiffness=(2e4, 1e6), mount_rot_stiffness=(10.0, 2e3),
              tube_outer=(0.03, 0.06), tube_wall=(0.002, 0.004), motor_mass=(8.0, 16.0), pump_mass=(5.0, 12.0),
              tank_mass=(5.0, 15.0))


def params_of(x):
    p = {}
    for (k, (lo, hi)), xi in zip(RANGES.items(), x, strict=True):
        p[k] = float(np.exp(np.clip(xi, math.log(lo), math.log(hi))))
    p["pad_shear_stiffness"] = 0.5 * p["pad_stiffness"]  # foam: shear ~ half the compression stiffness
    return p


def cost(x):
    try:
        t = table2_comparison(torso_modal(n_modes=40, **params_of(x)))
    except Exception:
        return 1e3
    out = float(np.sum(np.log(t["FE [Hz]"] / t["paper numerical [Hz]"]) ** 2))
    lo = np.log([a for a, _ in RANGES.values()])
    hi = np.log([b for _, b in RANGES.values()])
    return out + 10 * float(np.sum(np.clip(lo - x, 0, None) ** 2 + np.clip(x - hi, 0, None) ** 2))


if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("--maxfev", type=int, default=300)
    t0 = time.perf_counter()
    ap.add_argument("--start", default="", help="python dict of start values (default TORSO_DEFAULTS)")
    a = ap.parse_args()
    start = {**TORSO_DEFAULTS, **(eval(a.start) if a.start else {})}
    x0 = np.log([start[k] for k in RANGES])
    print("start", params_of(x0), "cost", cost(x0), flush=True)
    res = minimize(cost, x0, method="Nelder-Mead", options=dict(maxfev=a.maxfev, xatol=1e-3, fatol=1e-5))
    p = params_of(res.x)
    print("tuned", {k: float(f"{v:.4g}") for k, v in p.items()}, "cost", res.fun, "evaluations", res.nfev)
    r = torso_modal(n_modes=40, **p)
    tab = table2_comparison(r)
    print(tab.to_string(index=False, float_format=lambda v: f"{v:.4g}"))
    print("total mass [kg]", r.effective_mass.attrs["total_mass"])
    out = Path(__file__).parent / "results"
    out.mkdir(exist_ok=True)
    tab.assign(**{f"param {k}": v for k, v in p.items()}).to_csv(out / "torso_table2_tuning.csv", index=False)
    print(f"wall {time.perf_counter() - t0:.1f} s; load average {os.getloadavg()[0]:.1f}; Table 2 rows {len(TABLE2)}")
