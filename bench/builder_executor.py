"""Which executor a builder study should default to on the CPU (issue 42): the builder study of
bench/builder_study.py (HyQ leg with 8 bushings, cylinder length 0.16-0.24 m, each design a new
``assemble``; the same drop and options) run with one executor, in a process of its own from a
fresh compile cache, so that "vmap" (one process: every build, grouping key and the group's one
compile in turn) and "processes" (2 spawned workers, each building, grouping and compiling its
batch) start alike.

Prints one table row: executor, designs, succeeded, wall time [s] of ``study.run()`` (the
workers' start included), designs per second, load average at the end.

    python bench/builder_executor.py --executor vmap [--n 16] [--t-end 0.1]

(The ``--z0-structure`` flag of the earlier runs, bench/results/builder_study_64_z0.md, declared
a DiscreteController's ``z0`` structure before 47a7fad made it a parameter; it is gone.)
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
import warnings



def leg(cylinder_length):
    import proleg as pl

    return pl.assemble(pl.robots.hyq_leg("bushings8", cylinder_length=float(cylinder_length), rod_length=0.30))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--executor", default="vmap")
    ap.add_argument("--n", type=int, default=16)
    ap.add_argument("--t-end", type=float, default=0.1)
    args = ap.parse_args()
    os.environ["PROLEG_CACHE_DIR"] = tempfile.mkdtemp(prefix="proleg-builder-executor-")
    warnings.simplefilter("ignore")
    import proleg as pl

    from proleg.papers.hyq_study import peak_hip_force, peak_knee_force

    outputs = {"peak_hip_force": peak_hip_force, "peak_knee_force": peak_knee_force}
    sim = dict(t_end=args.t_end, dt_output=1e-3, dt_max=1e-3, rtol=1e-6, atol=1e-7)
    study = pl.study.Study(leg, {"cylinder_length": (0.16, 0.24)}, outputs, sim)
    t0 = time.perf_counter()
    table = study.run(design="grid", n=args.n, executor=args.executor, store=tempfile.mkdtemp(prefix="proleg-builder-executor-store-"),
                      progress=False)
    wall = time.perf_counter() - t0
    ok = int((table["status"] == "success").sum())
    print(f"| {args.executor} | {len(table)} | {ok} | {wall:.1f} | {len(table) / wall:.3f} | {os.getloadavg()[0]:.1f} |", flush=True)
    pl.study.executors.shutdown_pools()


if __name__ == "__main__":
    main()
