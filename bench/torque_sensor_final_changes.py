"""From the requirement search's optimum to the final concept's defaults (issue 44): the study's
design (:data:`proleg.robots.torque_sensor.FINAL_STUDY`), then each change of
:data:`~proleg.robots.torque_sensor.FINAL_CHANGES` in turn, on one refined mesh.

    PYTHONPATH=src python bench/torque_sensor_final_changes.py [--mesh 3] [--fillet-element 0.35]

Each row is ``torque_sensor_analysis("final", ...)`` at ``--mesh`` mm with fillet elements of
``--fillet-element`` mm whatever the fillet radius (the defaults: the final concept's default mesh,
3 mm and 0.175 x its 2 mm fillets), case A, stress stiffening, no gauge-face checks; the gauge
stays at the study's gauge_offset (:func:`proleg.papers.sensor_requirement.spoke_dimensions`).
Rows: the study's optimum (1 mm fillets; yields once the mesh resolves its spoke roots), with a
2 mm end mill (the roots stiffen: less twist), and with the spoke width re-tuned as well (the
defaults), plus one alternative that was not taken (hub and thickness at their search bounds as
well: more margin, but four of the study's dimensions changed instead of two).
Writes bench/results/torque_sensor_final_changes.csv and prints it.
"""

import argparse
import os
import time
from pathlib import Path

import pandas as pd

from proleg.papers.sensor_requirement import gauge_position, spoke_dimensions
from proleg.robots.sensor_fe import torque_sensor_analysis
from proleg.robots.torque_sensor import DEFAULTS, FINAL_CHANGES, FINAL_STUDY

VARIANTS = {
    "study optimum (FINAL_STUDY)": {},
    "+ 2 mm end mill": dict(fillet=FINAL_CHANGES["fillet"]),
    "+ spoke width re-tuned (the defaults)": dict(FINAL_CHANGES),
    "alternative: + r_hub 10 mm, thickness 15 mm, width 3.09 mm": dict(fillet=0.002, r_hub=0.010, thickness=0.015,
                                                                      spoke_width=0.0030933),
}

if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("--mesh", type=float, default=3.0, help="element size [mm]")
    ap.add_argument("--fillet-element", type=float, default=0.35, help="element size at the fillets [mm]")
    a = ap.parse_args()
    t0 = time.perf_counter()
    rows = []
    for name, change in VARIANTS.items():
        d = {**spoke_dimensions(FINAL_STUDY), **change}
        d["gauge_position"] = gauge_position(d, FINAL_STUDY["gauge_offset"])
        t = time.perf_counter()
        m = torque_sensor_analysis("final", mesh_size=a.mesh * 1e-3, fillet_size=a.fillet_element * 1e-3 / d["fillet"],
                                   cases=("A",),
                                   geometry_checks=False, **d).metrics
        rows.append({"design": name, **{k: d[k] for k in ("spoke_width", "fillet", "r_hub", "thickness", "gauge_position")},
                     **{k: m[k] for k in ("twist", "stiffness", "gauge_strain", "max_von_mises", "safety_factor",
                                          "max_von_mises_radius_mm", "n_dofs")}, "wall_s": time.perf_counter() - t})
        print(rows[-1], flush=True)
    df = pd.DataFrame(rows)
    assert all(df.iloc[2][k] == DEFAULTS["final"][k] for k in ("spoke_width", "fillet", "r_hub", "thickness"))
    out = Path(__file__).parent / "results"
    out.mkdir(exist_ok=True)
    df.to_csv(out / "torque_sensor_final_changes.csv", index=False)
    with pd.option_context("display.width", 250, "display.max_columns", 20):
        print(df.to_string(index=False, float_format=lambda x: f"{x:.5g}"))
    print(f"mesh {a.mesh} mm, fillet elements {a.fillet_element} mm; wall {time.perf_counter() - t0:.1f} s; "
          f"load average {os.getloadavg()[0]:.1f}")
