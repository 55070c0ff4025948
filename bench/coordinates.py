"""Joint vs planar vs absolute coordinates: compile time and cost per step (issue 21).

Each model is assembled once and simulated twice per coordinate set with generalized-α
(ρ∞ = 0.8, rtol 1e-6, atol 1e-7; the default integrator of these models but the smooth trees,
which ``auto`` gives Tsit5) in one process: ``compile [s]`` is
the first call minus the second, ``wall [s]`` the second, ``us/step`` the second per accepted
step. ``planar`` only where the model is planar. The "auto" rule of
``proleg.assembly.coordinates.coordinate_set`` is decided from these figures.

Models: ``pendulum`` (1 rod), ``double_pendulum``, ``chain3``, ``chain8`` (bench/common.py
``build_chain``), ``heavy_top`` (a spinning top on a spherical joint: in joint coordinates a
floating base with the spherical joint as cut-joint rows), ``floating_chain`` (a free base with
two links, tests/test_joint_coordinates.py), ``four_bar`` (a closed loop, tests/test_core_fourbar.py),
``hyq_leg`` (the HyQ leg drop, rigid joints), ``scout2`` (Scout II Model I bounding, its
Planar body joint), ``flegx`` (the FLEGX leg, configuration 4, rigid links: tendon-rod loops)
and ``hyq_stand`` (the whole HyQ, a floating base with 12 servos and four feet, dropped 5 cm:
run with ``GeneralizedAlpha(jacobian_reuse=True)`` in every coordinate set, so that only the
coordinates differ; bench/whole_robot.py times the defaults on whole quadrupeds).

    python bench/coordinates.py                         # all models (~15 min on the 2-core VM)
    python bench/coordinates.py --models chain3 hyq_leg --coordinates joint planar
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time

import numpy as np
from common import add_output_args, bench_simulate, build_chain, emit, log

COLUMNS = ["model", "coordinates", "nbody", "tree dofs", "cut joints", "loop rows", "compile [s]", "wall [s]", "steps", "rejected", "us/step", "cpu us/step", "status"]


def heavy_top():
    import proleg as pl

    model = pl.Model("heavy_top", gravity=(0.0, 0.0, -9.81))
    tilt = math.radians(20.0)
    com = 0.1 * np.array([math.sin(tilt), 0.0, math.cos(tilt)])
    R = np.array([[math.cos(tilt), 0.0, math.sin(tilt)], [0.0, 1.0, 0.0], [-math.sin(tilt), 0.0, math.cos(tilt)]])
    top = model.add_part("top", mass=1.0, inertia=(0.004, 0.004, 0.008), position=tuple(com), orientation=R,
                         angular_velocity=tuple(R @ np.array([0.0, 0.0, 60.0])))
    model.add_joint(pl.Spherical("tip", top, model.ground, at=(0.0, 0.0, 0.0)))
    return model


def _tests_model(module, name):
    sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "tests"))
    return getattr(__import__(module), name)()


def models():
    """name → (build, t_end [s], dt_output [s], simulate keywords)."""
    import proleg as pl

    return {
        "pendulum": (lambda: build_chain(1), 2.0, 1e-2, {}),
        "double_pendulum": (lambda: build_chain(2), 2.0, 1e-2, {}),
        "chain3": (lambda: build_chain(3), 2.0, 1e-2, {}),
        "chain8": (lambda: build_chain(8), 2.0, 1e-2, {}),
        "heavy_top": (heavy_top, 1.0, 1e-2, {}),
        "floating_chain": (lambda: _tests_model("test_joint_coordinates", "floating_chain"), 1.0, 1e-2, {}),
        "four_bar": (lambda: _tests_model("test_core_fourbar", "build"), 0.5, 1e-2, {}),
        "hyq_leg": (lambda: pl.robots.hyq_leg(joints="rigid", actuators="drop"), 0.3, 1e-3, {}),
        "scout2": (lambda: pl.robots.scout2("I"), 0.3, 1e-3, {}),
        "flegx": (lambda: pl.robots.flegx(4, 2, "rigid"), 0.3, 1e-3, {}),
        # a floating-base tree with contacts and servos; one integrator for every coordinate set
        # (GeneralizedAlpha with the Newton matrix reused), so that only the coordinates differ
        "hyq_stand": (lambda: pl.robots.hyq(drop=0.05), 0.2, 1e-2, {"integrator": pl.GeneralizedAlpha(jacobian_reuse=True)}),
    }


def topology(system):
    """(nbody, tree dofs, cut joints, loop rows) of the joint-coordinate set."""
    from proleg.assembly.coordinates import coordinate_set

    try:
        dyn = coordinate_set(system, system.params["q_init"], "joint")
    except Exception as exc:  # a model joint coordinates cannot take
        return system.topo.nbody, None, f"{type(exc).__name__}", None
    return system.topo.nbody, dyn.nq, len(dyn.tree.cut), dyn.nc


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--models", nargs="+", default=list(models()))
    ap.add_argument("--coordinates", nargs="+", default=["absolute", "planar", "joint", "auto"])
    add_output_args(ap, "coordinates")
    args = ap.parse_args(argv)

    import warnings

    import proleg as pl

    warnings.simplefilter("ignore")
    table = models()
    rows = []
    for name in args.models:
        build, t_end, dt, kw = table[name]
        system = pl.assemble(build())
        nb, ndof, ncut, nrows = topology(system)
        planar = getattr(system.topo, "planar", (None,))[0] is not None
        for coords in args.coordinates:
            if coords == "planar" and not planar:
                continue
            log(f"{name} {coords} ...")
            t0 = time.perf_counter()
            row = {"model": name, "nbody": nb, "tree dofs": ndof, "cut joints": ncut, "loop rows": nrows}
            try:
                r = bench_simulate(system, t_end, dt_output=dt, repeat=args.repeat, coordinates=coords, **kw)
                row.update({k: r[k] for k in ("compile [s]", "wall [s]", "steps", "rejected", "us/step", "cpu us/step", "status")})
                row["coordinates"] = coords if coords != "auto" else f"auto ({r['coordinates']})"
            except Exception as exc:
                row.update({"coordinates": coords, "status": f"{type(exc).__name__}: {str(exc)[:80]}"})
            rows.append(row)
            log(f"   {time.perf_counter() - t0:.1f} s: {row}")
    notes = ["default integrator (integrator='auto': generalized-α at rtol 1e-6 on absolute and planar coordinates and on models "
             "with contacts, stops, controllers or loops; Tsit5 for smooth trees with coordinates 'joint' or 'auto'); hyq_stand: "
             "GeneralizedAlpha(jacobian_reuse=True) in every coordinate set; compile = first call − second; us/step = second call / accepted steps",
             "tree dofs / cut joints / loop rows: the joint-coordinate set (loop rows include floating-base normalization rows)"]
    emit(args, "Coordinates: compile time and cost per step", rows, COLUMNS, notes=notes)


if __name__ == "__main__":
    main()
