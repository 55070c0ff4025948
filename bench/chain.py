"""Hanging chain of N revolute-jointed rods: compile time and cost per step against N.

Each link is a 0.15 m, 0.1 kg rod; the chain starts straight, 30° below the horizontal, at
rest, and falls for ``--t-end`` seconds (default 10 s) under gravity with the default
integrator (generalized-α, ρ∞ = 0.8, rtol 1e-6, outputs every 10 ms).

    python bench/chain.py                 # N = 2 4 8
    python bench/chain.py --n 16 32 --blas-threads 1   # larger sizes (minutes; see README on BLAS threads)
    python bench/chain.py --json          # one JSON object on stdout
    python bench/chain.py --profile       # also: time per output chunk, cProfile of one run
"""

from __future__ import annotations

import argparse
import sys
import time

from common import add_output_args, bench_simulate, build_chain, emit, log, timed

COLUMNS = ["N", "coordinates", "newton n", "assemble [s]", "compile [s]", "xla [s]", "cache hits", "wall [s]", "steps", "rejected", "newton", "jacobians", "us/step", "median us/step", "runs", "cpu us/step", "us/newton"]


def profile_run(system, t_end, top: int = 20):
    """cProfile of one (already compiled) simulate call, to stderr: where the Python side waits."""
    import cProfile
    import io
    import pstats

    import proleg as pl

    pr = cProfile.Profile()
    pr.enable()
    pl.simulate(system, t_end=t_end, dt_output=1e-2, progress=False)
    pr.disable()
    s = io.StringIO()
    pstats.Stats(pr, stream=s).sort_stats("tottime").print_stats(top)
    log(s.getvalue())


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, nargs="+", default=[2, 4, 8], help="chain sizes (default 2 4 8; 16+ take minutes)")
    ap.add_argument("--t-end", type=float, default=10.0, help="simulated time [s] (default 10)")
    ap.add_argument("--profile", action="store_true", help="time per output chunk; cProfile of the largest N to stderr")
    ap.add_argument(
        "--coordinates", default="auto", choices=["auto", "absolute", "planar"],
        help="simulate(coordinates=...): the chain is planar, so auto runs planar coordinates",
    )
    add_output_args(ap, "chain")
    args = ap.parse_args(argv)

    import proleg as pl

    rows, system = [], None
    for n in args.n:
        log(f"chain N = {n} ...")
        t0 = time.perf_counter()
        system, t_asm = timed(pl.assemble, build_chain(n))
        row = {"N": n, "assemble [s]": t_asm}
        try:
            row.update(bench_simulate(system, args.t_end, profile_chunks=args.profile, repeat=args.repeat, coordinates=args.coordinates))
        except Exception as exc:  # report, keep going with the other sizes
            row["status"] = f"{type(exc).__name__}: {exc}"
        rows.append(row)
        log(f"  done in {time.perf_counter() - t0:.1f} s: {row}")
    if args.profile and system is not None:
        # The same System object: a fresh assemble() has a new static topology and recompiles.
        profile_run(system, args.t_end)

    cols = COLUMNS + (["chunk [s]"] if args.profile else [])
    if any(r.get("status", "success") != "success" for r in rows):
        cols = cols + ["status"]
    notes = [
        "compile = first simulate call minus second (tracing + XLA compile of the IC solve and stepping loop), xla = the part spent in the XLA backend compiler; "
        "wall = second call; us/step = wall / accepted steps.",
        "assemble = pl.assemble(model) (includes an eager constraint Jacobian at the modelled pose).",
    ]
    emit(args, f"Hanging chain, {args.t_end:g} s simulated", rows, cols, {"t_end [s]": args.t_end, "dt_output [s]": 0.01}, notes)


if __name__ == "__main__":
    sys.exit(main())
