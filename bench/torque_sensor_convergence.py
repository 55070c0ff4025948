"""Mesh convergence of the torque-sensor FE metrics (issue 17): gauge strain, max von Mises,
stiffness and calibration of one concept on a sequence of meshes, relative to the finest.

    PYTHONPATH=src python bench/torque_sensor_convergence.py [--concept final] [--sizes 6,5,4,3]
        [--fillet-sizes 0.5,0.5,0.5,0.5] [--tag NAME]

Case A only (with rigid interfaces case B has the same strains), stress stiffening on, default
dimensions. Two sequences make the study (:data:`proleg.robots.torque_sensor.DEFAULT_MESH`, the
table in its comment): the global size h with the fillets resolved alike on every mesh
(``--sizes 6,5,4,3``), and the fillet element size at the default h (``--sizes 6,6,6
--fillet-sizes 0.5,0.35,0.25 --tag fillet``), then the default against everything refined
(``--sizes 5,3 --fillet-sizes 0.35,0.25 --tag refined``). The first sequence in the CSV was run
with fillet_size 0.5 (the default then). Max von Mises is the averaged vertex stress
(:meth:`proleg.fem.SolidModel.vertex_stress`).

Writes bench/results/torque_sensor_convergence_<concept>[_<tag>].csv and prints the table with
the wall time and the load average (the machine is shared: compare times only at similar load).
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
    ap.add_argument("--fillet-sizes", default=None, help="fillet element size / radius, one per size")
    ap.add_argument("--tag", default="")
    a = ap.parse_args()
    t0 = time.perf_counter()
    fs = None if a.fillet_sizes is None else [float(s) for s in a.fillet_sizes.split(",")]
    df = mesh_convergence(a.concept, sizes=[float(s) * 1e-3 for s in a.sizes.split(",")], fillet_sizes=fs,
                          cases=("A",), geometry_checks=False, verbose=True)
    out = Path(__file__).parent / "results"
    out.mkdir(exist_ok=True)
    df.to_csv(out / f"torque_sensor_convergence_{a.concept}{'_' + a.tag if a.tag else ''}.csv", index=False)
    print(df.to_string(index=False))
    print(f"wall {time.perf_counter() - t0:.1f} s; load average {os.getloadavg()[0]:.1f}")
