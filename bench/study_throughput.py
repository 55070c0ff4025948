"""Throughput of one proleg.study design (variants/s) by executor: a loop of sequential
``simulate()`` calls, ``vmap`` (proleg.sweep batches in this process), ``processes`` (2 local
worker processes) and ``dask`` (LocalCluster, 2 single-threaded workers).

    PYTHONPATH=src python bench/study_throughput.py --model pendulum --n 64
    PYTHONPATH=src python bench/study_throughput.py --model hyq --n 1000      # the issue's case (long)

Every executor starts from an empty store (wall time includes compilation and, for processes
and dask, starting the workers); the persistent compilation cache is on, as for a user.
Writes bench/results/study_throughput_<model>_<n>.csv.
"""

from __future__ import annotations

import argparse
import os
import platform
import shutil
import sys
import tempfile
import time
from pathlib import Path

import pandas as pd

import proleg as pl

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from models import spring_pendulum  # noqa: E402  (one definition, shared with the tests)


def pendulum_study():
    """The tests' spring double pendulum (tests/models.py) as a two-parameter study."""
    return pl.study.Study(spring_pendulum("bench_pendulum"), space={"spring.stiffness": (10.0, 1000.0), "spring.damping": (0.1, 1.0)},
                          outputs={"x_end": _x_end}, simulate=dict(t_end=1.0, dt_output=0.01))


def _x_end(r):
    return r.part("lower").position[-1, 0]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--model", choices=["pendulum", "hyq"], default="pendulum")
    ap.add_argument("--n", type=int, default=64)
    ap.add_argument("--executors", default="sequential,vmap,processes,dask")
    ap.add_argument("--lanes", type=int, default=None,
                    help="variants per compiled vmap call inside a batch (Study.run lanes=; default: the whole batch)")
    args = ap.parse_args()
    if args.model == "hyq":
        from proleg.papers.hyq_study import bushing_study

        study = bushing_study()
    else:
        study = pendulum_study()
    rows = []
    for ex in args.executors.split(","):
        store = Path(tempfile.mkdtemp(prefix=f"study-{ex}-"))
        t0 = time.perf_counter()
        if ex == "sequential":
            from proleg.analyses.simulate import simulate_kwargs
            from proleg.assembly.system import System

            table = study.design("lhs", args.n, seed=1)
            apply = study.apply or System.with_params
            ok = 0
            for r in table.to_dict("records"):
                res = pl.simulate(apply(study.target, {k: r[k] for k in study.space.dims}), progress=False, throw=False,
                                  **simulate_kwargs(study.simulate))
                ok += res.ok
        else:
            tab = study.run(design="lhs", n=args.n, seed=1, executor=ex, store=store, workers=None if ex == "vmap" else 2, progress=False,
                            lanes=args.lanes)
            ok = int((tab["status"] == "success").sum())
        wall = time.perf_counter() - t0
        shutil.rmtree(store, ignore_errors=True)
        rows.append({"executor": ex, "lanes": "-" if ex == "sequential" else (args.lanes or "batch"), "variants": args.n, "succeeded": ok, "wall [s]": wall, "variants/s": args.n / wall,
                     "load (1 min) at end": os.getloadavg()[0]})
        print(rows[-1], flush=True)
    df = pd.DataFrame(rows)
    df.attrs["machine"] = f"{platform.node()} {os.cpu_count()} cores"
    print(df.to_string(index=False))
    suffix = f"_lanes{args.lanes}" if args.lanes else ""
    out = Path(__file__).parent / "results" / f"study_throughput_{args.model}_{args.n}{suffix}.csv"
    df.to_csv(out, index=False)
    print(f"wrote {out} ({platform.processor() or platform.machine()}, {os.cpu_count()} cores)")


if __name__ == "__main__":
    main()
