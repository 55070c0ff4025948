"""Bushing double pendulum and the 7-part target model: compile time and cost per step.

Cases (``--cases`` picks some; default all):

``bushing2``   double pendulum, two 0.2 m / 1 kg rods; each hinge is a Bushing with 1e8 N/m on
               the three translations, 1e6 N m/rad on the two tilts and 0 about the hinge axis;
               damping 1e3 N s/m (translations), 10 N m s/rad (tilts), 0 (hinge axis).
``revolute2``  the same double pendulum with Revolute joints (the rigid reference).
``chain7``     7-part model for the target "under 100 µs per step": a chain of seven 0.15 m /
               0.1 kg rods on Revolute joints. A planar mechanism, so ``simulate`` runs it in
               planar coordinates (3 per part, assembly/coordinates.py; Newton matrix n = 35).
``chain7_absolute`` ``chain7`` forced into absolute coordinates (7 per part, n = 91), the
               formulation every non-planar model runs in.
``bushing7``   the same 7-link chain with the bushing hinges above.
``chain7_reuse`` ``chain7`` with ``jacobian_reuse=True`` (Newton matrix kept across steps).

``--cpus 1`` runs the process on one core (see bench/README.md: XLA-CPU hands small kernels to
a thread pool, and for models this small the hand-offs cost more than they save).

All start straight, 30° below the horizontal, at rest; ``--t-end`` seconds (default 10) with
the default integrator (generalized-α, ρ∞ = 0.8, rtol 1e-6), outputs every 10 ms.
"""

from __future__ import annotations

import argparse
import sys

from common import add_output_args, bench_simulate, build_chain, emit, log, timed

CASES = {
    "bushing2": ("double pendulum, bushing hinges", dict(n=2, length=0.2, mass=1.0, joints="bushing")),
    "revolute2": ("double pendulum, revolute hinges", dict(n=2, length=0.2, mass=1.0, joints="revolute")),
    "chain7": ("7-link chain, revolute (7-part target)", dict(n=7, joints="revolute")),
    "chain7_absolute": ("7-link chain, revolute, absolute coordinates", dict(n=7, joints="revolute")),
    "bushing7": ("7-link chain, bushing hinges", dict(n=7, joints="bushing")),
    "chain7_reuse": ("7-link chain, revolute, Jacobian reuse", dict(n=7, joints="revolute")),
}
SIMULATE_KW = {"chain7_reuse": {"jacobian_reuse": True}, "chain7_absolute": {"coordinates": "absolute"}}
COLUMNS = ["case", "parts", "coordinates", "newton n", "assemble [s]", "compile [s]", "xla [s]", "cache hits", "wall [s]", "steps", "rejected", "newton", "jacobians", "us/step", "median us/step", "runs", "cpu us/step", "us/newton"]
TARGET_US_PER_STEP = 100.0


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cases", nargs="+", choices=list(CASES), default=list(CASES))
    ap.add_argument("--t-end", type=float, default=10.0, help="simulated time [s] (default 10)")
    add_output_args(ap, "bushing_pendulum")
    args = ap.parse_args(argv)

    import proleg as pl

    rows = []
    for key in args.cases:
        label, kw = CASES[key]
        log(f"{key}: {label} ...")
        system, t_asm = timed(pl.assemble, build_chain(**kw))
        row = {"case": label, "parts": kw["n"], "assemble [s]": t_asm}
        try:
            row.update(bench_simulate(system, args.t_end, repeat=args.repeat, **SIMULATE_KW.get(key, {})))
        except Exception as exc:
            row["status"] = f"{type(exc).__name__}: {exc}"
        rows.append(row)
        log(f"  {row}")

    cols = COLUMNS + (["status"] if any(r.get("status", "success") != "success" for r in rows) else [])
    notes = [
        "compile = first simulate call minus second, xla = the part of it in the XLA backend compiler; wall = second call; us/step = wall / accepted steps.",
    ]
    for r in rows:
        if r["parts"] == 7 and "us/step" in r:
            ok = "meets" if r["us/step"] < TARGET_US_PER_STEP else "misses"
            notes.append(
                f"{r['case']}: {r['us/step']:.0f} us/step wall (fastest of {r['runs']}; median {r['median us/step']:.0f}; "
                f"{r['cpu us/step']:.0f} CPU) {ok} the target of < {TARGET_US_PER_STEP:g} us/step."
            )
    emit(args, f"Bushing double pendulum and 7-part model, {args.t_end:g} s simulated", rows, cols, {"t_end [s]": args.t_end}, notes)


if __name__ == "__main__":
    sys.exit(main())
