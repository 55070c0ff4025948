"""Design space of the open-links torque-sensor concept (issue 17; the `final` concept before issue 44): a 1-D scan of one dimension (default
the neck width, the gauge section) with the others at their defaults, and which constraint binds.

    PYTHONPATH=src python bench/torque_sensor_design_space.py [--name neck_width] [--values 4,5,6,7] [--mesh 6]

Each point is the optimisation's evaluation (:func:`proleg.papers.sensor_study.evaluate_design`:
case A, no stress stiffening, sharp corners, ``--mesh`` mm). Columns c_* are the constraint values (feasible when
<= 0): c_strain = gauge strain / 0.06 % - 1, c_yield = 2 / safety factor - 1, c_stiffness =
1 - stiffness / 140 N m/deg, c_reach = 1 if a gauge face has < 6 mm free in front. Writes
bench/results/torque_sensor_design_space_<name>.csv and prints the table.
"""

import argparse
import os
import time
from pathlib import Path

import pandas as pd

from proleg.papers.sensor_study import CONSTRAINTS, SPACE, evaluate_design
from proleg.robots.torque_sensor import DEFAULTS

if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("--name", default="neck_width", help="a dimension of the open_links concept")
    ap.add_argument("--values", default="4,5,5.5,6,7", help="values [mm]")
    ap.add_argument("--mesh", type=float, default=6.0, help="element size [mm]")
    a = ap.parse_args()
    d = DEFAULTS["open_links"]
    base = dict(link_width=d["link_width"], neck_ratio=d["neck_width"] / d["link_width"], r_link=d["r_link"],
                thickness=d["thickness"])
    t0 = time.perf_counter()
    rows = []
    for v in (float(x) * 1e-3 for x in a.values.split(",")):
        p = dict(base)
        if a.name == "neck_width":
            p["neck_ratio"] = v / p["link_width"]
        elif a.name in SPACE:
            p[a.name] = v
        else:
            raise SystemExit(f"--name must be neck_width or one of {list(SPACE)}")
        r = evaluate_design(p, search_mesh=a.mesh * 1e-3)
        # the continuous constraint closest to its bound (c_reach is 0/1 and reported as is)
        binding = max(CONSTRAINTS[:3], key=lambda c: r[c]) if r["status"] == "success" else "-"
        rows.append({f"{a.name}_mm": v * 1e3, "gauge_strain_%": r["gauge_strain"] * 100,
                     "safety_factor": r["safety_factor"], "stiffness_Nm_per_deg": r["stiffness"],
                     **{c: r[c] for c in CONSTRAINTS}, "feasible": r.get("feasible"), "closest_constraint": binding,
                     "status": r["status"], "wall_s": r["wall_s"]})
        print(rows[-1], flush=True)
    df = pd.DataFrame(rows)
    out = Path(__file__).parent / "results"
    out.mkdir(exist_ok=True)
    df.to_csv(out / f"torque_sensor_design_space_{a.name}.csv", index=False)
    print(df.to_string(index=False, float_format=lambda x: f"{x:.4g}"))
    print(f"mesh {a.mesh} mm; wall {time.perf_counter() - t0:.1f} s; load average {os.getloadavg()[0]:.1f}")
