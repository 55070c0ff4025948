"""A standing robot's warm run against the size of XLA-CPU's intra-op thread pool (PJRT_NPROC).

proleg sets ``PJRT_NPROC=1`` at import (``proleg.XLA_CPU_ENV_DEFAULTS``,
docs/global-settings.md): XLA's executor hands a step's independent kernels to that pool, and a
simulation step's kernels take a microsecond or less, so the hand-offs between threads cost
more than they save. This script measures it: for each robot of bench/whole_robot.py and each
pool size, ``--rounds`` fresh processes (interleaved over the sizes, so all see the same machine
load) each compile the 1 s stand, run it twice untimed, then ``--repeat`` timed runs; the table
gives the median and fastest wall time over all of them, the median process CPU time (CPU above
wall: more than one thread busy) and the steps (the same for every size: the pool does not
change the arithmetic).

    python bench/xla_threads.py --robots go1 anymal_c --nproc 1 2 4 --out bench/results/xla_threads.md
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys

sys.path.insert(0, os.path.dirname(__file__))
from common import add_output_args, child_result, emit, log  # noqa: E402

CHILD = r"""
import json, sys, time, warnings
sys.path.insert(0, {bench!r})
import proleg as pl
from whole_robot import stand_model
system = pl.assemble(stand_model({robot!r})[0])
warnings.simplefilter("ignore")
for _ in range(3):  # compile, then the output processing of this length (bench/whole_robot.py)
    r = pl.simulate(system, {t_end!r}, 1e-2, progress=False)
walls, cpus = [], []
for _ in range({repeat}):
    t, c = time.perf_counter(), time.process_time()
    r = pl.simulate(system, {t_end!r}, 1e-2, progress=False)
    walls.append(time.perf_counter() - t); cpus.append(time.process_time() - c)
print("RESULT " + json.dumps(dict(walls=walls, cpus=cpus, steps=int(r.stats["steps"]))))
"""


def child(robot, nproc, t_end, repeat):
    env = {k: v for k, v in os.environ.items() if k not in ("PJRT_NPROC", "NPROC")}
    env["PJRT_NPROC"] = str(nproc)
    code = CHILD.format(bench=os.path.dirname(os.path.abspath(__file__)), robot=robot, t_end=t_end, repeat=repeat)
    return child_result(code, env, f"{robot}, PJRT_NPROC={nproc}")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--robots", nargs="+", default=["go1", "anymal_c"])
    ap.add_argument("--nproc", nargs="+", type=int, default=[1, 2, 4], help="pool sizes (PJRT_NPROC)")
    ap.add_argument("--rounds", type=int, default=3, help="fresh processes per robot and pool size")
    ap.add_argument("--t-end", type=float, default=1.0)
    add_output_args(ap, "xla_threads")
    ap.set_defaults(repeat=5)
    args = ap.parse_args(argv)
    rows = []
    for robot in args.robots:
        got = {n: [] for n in args.nproc}
        for k in range(args.rounds):
            for n in args.nproc:
                log(f"{robot} PJRT_NPROC={n} {k + 1}/{args.rounds} ...")
                got[n].append(child(robot, n, args.t_end, args.repeat))
        for n in args.nproc:
            walls = [w for r in got[n] for w in r["walls"]]
            cpus = [c for r in got[n] for c in r["cpus"]]
            rows.append({
                "robot": robot, "PJRT_NPROC": n, "runs": len(walls), "warm median [s]": statistics.median(walls),
                "warm min [s]": min(walls), "warm max [s]": max(walls), "cpu median [s]": statistics.median(cpus),
                "steps": got[n][-1]["steps"], "default": "yes" if n == 1 else "",
            })
    notes = [
        f"{args.t_end:g} s of standing (bench/whole_robot.py's stand, proleg's defaults), {args.rounds} fresh processes per "
        f"row interleaved over the pool sizes, {args.repeat} timed runs each after three untimed ones",
        "cpu: the process's CPU time per run (user + system, all threads); above the wall time when more than one thread works",
        f"cores this process may use: {len(os.sched_getaffinity(0)) if hasattr(os, 'sched_getaffinity') else os.cpu_count()}",
    ]
    emit(args, "A standing robot's warm run against XLA-CPU's intra-op pool size (PJRT_NPROC)", rows, list(rows[0]),
         meta={"rounds": args.rounds, "repeat": args.repeat}, notes=notes)


if __name__ == "__main__":
    main()
