"""Generalized-α with and without the velocity term in its error estimate (issue 21).

``GeneralizedAlpha(error_on="positions")`` (default) against ``"positions+velocities"``
(solvers/galpha.py, "Velocity error"): energy error of the undamped double pendulum and
8-link chain (bench/common.py ``build_chain``, 10 s, coordinates "auto" = planar, an index-3
DAE) against rtol (atol = rtol/10), with the slope in decades of error per decade of rtol; and
the HyQ leg drop (``proleg.papers.hyq_tests.drop_test`` settings: rigid joints, 5 cm, rtol
1e-6, dt_max 1 ms) for its step count and peak foot force.

    python bench/galpha_error.py                       # everything (~10 min on the 2-core VM)
    python bench/galpha_error.py --problems hyq --t-end-hyq 0.3
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np
from common import add_output_args, build_chain, emit, log

COLUMNS = ["problem", "error_on", "rtol", "error", "slope", "steps", "rejected", "wall [s]", "peak GRF z [N]", "lowest slider z [m]"]
MODES = ["positions", "positions+velocities"]


def energy_error(r):
    T, V = np.asarray(r.energy["kinetic"]), np.asarray(r.energy["potential"])
    E = T + V
    return float(np.abs(E - E[0]).max() / T.max())


def chain_rows(n, rtols, name):
    import proleg as pl

    system = pl.assemble(build_chain(n))
    rows = []
    for mode in MODES:
        prev = None
        for rtol in sorted(rtols, reverse=True):
            log(f"{name} {mode} rtol {rtol:g} ...")
            ig = pl.GeneralizedAlpha(rtol=rtol, atol=rtol / 10, error_on=mode)
            t0 = time.perf_counter()
            r = pl.simulate(system, t_end=10.0, dt_output=0.01, integrator=ig, progress=False, throw=False)
            wall = time.perf_counter() - t0
            err = energy_error(r) if r.ok else float("nan")
            slope = (math.log10(prev[1]) - math.log10(err)) / (math.log10(prev[0]) - math.log10(rtol)) if prev and r.ok else float("nan")
            prev = (rtol, err)
            rows.append({"problem": name, "error_on": mode, "rtol": rtol, "error": err, "slope": slope, "steps": r.stats["steps"],
                         "rejected": r.stats["rejected"], "wall [s]": wall})
    return rows


def hyq_rows(t_end):
    import proleg as pl
    from proleg.papers import hyq_tests as T

    system = pl.assemble(pl.robots.hyq_leg(joints="rigid", gain="high", drop_height=0.05, actuators="drop"))
    rows = []
    for mode in MODES:
        log(f"hyq drop {mode} ...")
        ig = pl.GeneralizedAlpha(dt_max=1e-3, rtol=1e-6, atol=1e-7, error_on=mode)
        t0 = time.perf_counter()
        r = pl.simulate(system, t_end=t_end, dt_output=1e-3, integrator=ig, progress=False, throw=False)
        wall = time.perf_counter() - t0
        df = T.channels(r, light=True)
        rows.append({"problem": f"hyq drop {t_end:g} s", "error_on": mode, "rtol": 1e-6, "error": float("nan"), "slope": float("nan"),
                     "steps": r.stats["steps"], "rejected": r.stats["rejected"], "wall [s]": wall,
                     "peak GRF z [N]": float(df["GRF z [N]"].max()), "lowest slider z [m]": float(df["slider z [m]"].min())})
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--problems", nargs="+", default=["double_pendulum", "chain8", "hyq"])
    ap.add_argument("--rtols", type=float, nargs="+", default=[1e-4, 1e-6, 1e-8])
    ap.add_argument("--t-end-hyq", type=float, default=1.2)
    add_output_args(ap, "galpha_error")
    args = ap.parse_args(argv)
    rows = []
    if "double_pendulum" in args.problems:
        rows += chain_rows(2, args.rtols, "double_pendulum")
    if "chain8" in args.problems:
        rows += chain_rows(8, args.rtols, "chain8")
    if "hyq" in args.problems:
        rows += hyq_rows(args.t_end_hyq)
    notes = ["error: energy error / max kinetic energy (chains); hyq: the drop's answers (peak ground force, lowest slider height)",
             "slope: decades of error per decade of rtol from the previous row; wall includes compilation"]
    emit(args, "Generalized-α error estimate: positions vs positions+velocities", rows, COLUMNS, meta={"atol": "rtol/10"}, notes=notes)


if __name__ == "__main__":
    main()
