"""Mesh convergence of the torque-sensor FE metrics (issue 17): gauge strain, max von Mises,
stiffness and calibration of one concept on a sequence of meshes, relative to the finest.

    PYTHONPATH=src python bench/torque_sensor_convergence.py [--concept final] [--sizes 5,4,3,2]
        [--fillet-sizes 0.35,0.35,0.35,0.35] [--tag NAME] [--study-best]

Case A only (with rigid interfaces case B has the same strains), stress stiffening on, default
dimensions (``--study-best``: the final concept at the requirement search's own optimum,
:data:`proleg.robots.torque_sensor.FINAL_STUDY`, instead). A mesh is accepted when its gauge
strain, stiffness and max von Mises (the averaged vertex stress,
:meth:`proleg.fem.SolidModel.vertex_stress`) are each within 2 % of the finest mesh's; the
concept's default mesh (:data:`proleg.robots.torque_sensor.DEFAULT_MESH`, the table in its
comment) is the coarsest accepted one. Two sequences make the study: the global size h at one
fillet element size (``--sizes 5,4,3,2``), and the fillet element size at the chosen h
(``--sizes 3,3,3 --fillet-sizes 0.25,0.175,0.125 --tag fillet``); ``--tag refined`` compares a
coarse default with everything refined. Runs (bench/results/torque_sensor_convergence_*.csv):

- final (issue 44): ``--sizes 5,4,3,2 --fillet-sizes 0.35,0.35,0.35,0.35``, ``--sizes 5,2
  --fillet-sizes 0.35,0.25 --tag refined``, ``--sizes 3,3,3 --fillet-sizes 0.25,0.175,0.125 --tag
  fillet`` (the default, 3 mm and 0.175, is the coarsest accepted);
- the study's optimum before its changes: ``--study-best --sizes 5.8,5,4,3 --fillet-sizes
  0.35,0.35,0.35,0.25`` (writes ..._study_best.csv);
- open_links (the final concept before issue 44; its numbers in the DEFAULT_MESH comment):
  ``--concept open_links --sizes 6,5,4,3`` (fillet_size 0.5, the default then), ``--sizes
  6,6,6 --fillet-sizes 0.5,0.35,0.25 --tag fillet``, ``--sizes 5,3 --fillet-sizes 0.35,0.25
  --tag refined``.

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
    ap.add_argument("--sizes", default="5,4,3,2", help="element sizes [mm], coarse to fine")
    ap.add_argument("--fillet-sizes", default=None, help="fillet element size / radius, one per size")
    ap.add_argument("--tag", default="")
    ap.add_argument("--study-best", action="store_true", help="final concept at FINAL_STUDY's dimensions")
    a = ap.parse_args()
    dims = {}
    if a.study_best:
        from proleg.papers.sensor_requirement import spoke_dimensions
        from proleg.robots.torque_sensor import FINAL_STUDY

        if a.concept != "final":
            raise SystemExit("--study-best is the final concept at the requirement search's optimum")
        dims, a.tag = spoke_dimensions(FINAL_STUDY), a.tag or "study_best"
    t0 = time.perf_counter()
    fs = None if a.fillet_sizes is None else [float(s) for s in a.fillet_sizes.split(",")]
    df = mesh_convergence(a.concept, sizes=[float(s) * 1e-3 for s in a.sizes.split(",")], fillet_sizes=fs,
                          cases=("A",), geometry_checks=False, verbose=True, **dims)
    out = Path(__file__).parent / "results"
    out.mkdir(exist_ok=True)
    df.to_csv(out / f"torque_sensor_convergence_{a.concept}{'_' + a.tag if a.tag else ''}.csv", index=False)
    print(df.to_string(index=False))
    print(f"wall {time.perf_counter() - t0:.1f} s; load average {os.getloadavg()[0]:.1f}")
