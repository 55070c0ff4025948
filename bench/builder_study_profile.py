"""Where a builder study's time goes against a System study's (issue 42): the two studies of
bench/builder_study.py (HyQ leg, 8 bushings; builder over cylinder length, System over pin
stiffness), ``executor="vmap"``, in one process from a fresh compile cache, each stage timed:
the builds (``hyq_leg`` + ``assemble``), the grouping keys (``executors._shape_key``), the
sweep's compilation and run (``SweepResult.compile_time`` / ``wall_time``) and the outputs.

    python bench/builder_study_profile.py [--n 8] [--t-end 0.02] [--executor vmap] [--only both|builder|system]
        [--cprofile FILE] [--csv FILE]

(The ``--z0-structure`` flag of the earlier runs, bench/results/builder_study_64_z0.md, declared
a DiscreteController's ``z0`` structure before 47a7fad made it a parameter; it is gone.)
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
import warnings
from collections import defaultdict

from builder_study import leg, studies


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=8)
    ap.add_argument("--t-end", type=float, default=0.02)
    ap.add_argument("--executor", default="vmap")
    ap.add_argument("--only", choices=("both", "builder", "system"), default="both")
    ap.add_argument("--cprofile", default=None, help="write a cProfile of the builder study here")
    ap.add_argument("--csv", default=None, help="write the builder study's rows here")
    args = ap.parse_args()
    os.environ["PROLEG_CACHE_DIR"] = tempfile.mkdtemp(prefix="proleg-builder-profile-")
    warnings.simplefilter("ignore")
    import proleg.analyses.sweep as sw
    import proleg.compile_cache as cc
    import proleg.study.executors as ex

    spent, calls = defaultdict(float), defaultdict(int)

    def timed(name, fn):
        def wrapper(*a, **k):
            calls[name] += 1
            t0 = time.perf_counter()
            try:
                return fn(*a, **k)
            finally:
                spent[name] += time.perf_counter() - t0
        return wrapper

    sweep0 = sw.sweep

    def sweep(*a, **k):
        res = sweep0(*a, **k)
        spent["sweep: compile"] += res.compile_time
        spent["sweep: run"] += res.wall_time
        return res

    ex._shape_key = timed("grouping key (_shape_key)", ex._shape_key)
    sw.sweep = timed("sweep (all)", sweep)
    ex._outputs_of = timed("outputs", ex._outputs_of)
    timed_leg = timed("build (hyq_leg + assemble)", leg)

    studies_ = studies(args.t_end, build=timed_leg)
    cases = []
    if args.only in ("both", "system"):
        cases.append(("System (pin stiffness)", studies_["system"]))
    if args.only in ("both", "builder"):
        cases.append(("builder (cylinder length)", studies_["builder"]))
    for name, make in cases:
        spent.clear()
        calls.clear()
        before = dict(cc.stats)
        study = make()
        prof = None
        if args.cprofile and name.startswith("builder"):
            import cProfile

            prof = cProfile.Profile()
            prof.enable()
        t0 = time.perf_counter()
        table = study.run(design="grid", n=args.n, executor=args.executor, store=tempfile.mkdtemp(prefix="proleg-profile-store-"), progress=False)
        wall = time.perf_counter() - t0
        if prof is not None:
            prof.disable()
            prof.dump_stats(args.cprofile)
        ok = int((table["status"] == "success").sum())
        print(f"\n## {name}: {len(table)} designs ({ok} ok), executor {args.executor}, wall {wall:.1f} s, "
              f"traces {cc.stats['exported'] - before['exported']}, shared loads {cc.stats['shared'] - before['shared']}, "
              f"steps max {int(table['steps'].max())} mean {table['steps'].mean():.0f}, load {os.getloadavg()[0]:.1f}")
        for k, v in sorted(spent.items(), key=lambda kv: -kv[1]):
            print(f"  {k:32s} {v:8.2f} s" + (f"  ({calls[k]} calls)" if calls.get(k) else ""))
        if args.csv and name.startswith("builder"):
            table.to_csv(args.csv, index=False, float_format="%.17g")
        print(table[[c for c in table.columns if c in (*study.space.dims, *study.outputs, "steps")]].to_string())


if __name__ == "__main__":
    main()
