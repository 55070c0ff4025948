"""Mesh convergence of the torque-sensor FE metrics (issue 17): gauge strain, max von Mises,
stiffness and calibration of one concept on a sequence of meshes, relative to the finest.

    PYTHONPATH=src python bench/torque_sensor_convergence.py [--concept final] [--sizes 6,5,4,3,2.5]

Case A only (with rigid interfaces case B has the same strains), stress stiffening on, default
dimensions. The default mesh (:data:`proleg.robots.torque_sensor.DEFAULT_MESH`) is chosen from
this table (copied into its comment): gauge strain within 2 % of the finest mesh from 6 mm; the max
von Mises at the neck's 0.4 mm fillets is not converged at these sizes (+-10 %).

Writes bench/results/torque_sensor_convergence_<concept>.csv and prints the table.
"""

import argparse
import os
import time
from pathlib import Path

from proleg.robots.sensor_fe import mesh_convergence

if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("--concept", default="final")
    ap.add_argument("--sizes", default="6,5,4,3", help="element sizes [mm], coarse to fine")
    a = ap.parse_args()
    t0 = time.perf_counter()
    df = mesh_convergence(a.concept, sizes=[float(s) * 1e-3 for s in a.sizes.split(",")], cases=("A",),
                          geometry_checks=False, verbose=True)
    out = Path(__file__).parent / "results"
    out.mkdir(exist_ok=True)
    df.to_csv(out / f"torque_sensor_convergence_{a.concept}.csv", index=False)
    print(df.to_string(index=False))
    print(f"wall {time.perf_counter() - t0:.1f} s; load average {os.getloadavg()[0]:.1f}")
