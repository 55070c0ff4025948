"""A geometry study at the parameter-study rate (issue 42): a builder Study over N HyQ-leg
geometries (new cylinder and rod lengths: each design a new ``assemble``) against a System Study
over N pin stiffnesses of one assembled leg (``with_params``), both ``executor="vmap"``, the
same drop (8-bushing leg, ``t_end`` 0.1 s), in one process from a fresh compile cache.

Columns: wall time [s] of ``study.run()``, designs per second, traces (lowered functions
exported by the compile cache), shared loads (a function of another model of the same structure
loaded instead of traced) and groups (compiled ``vmap`` batches: ``proleg.sweep`` calls) of the run.

    python bench/builder_study.py [--n 64] [--t-end 0.1] [--out bench/results/builder_study.md]

(The ``--z0-structure`` flag of the earlier runs, bench/results/builder_study_64_z0.md, declared
a DiscreteController's ``z0`` structure before 47a7fad made it a parameter; it is gone.)
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
import warnings


def leg(cylinder_length, rod_length):
    import proleg as pl

    return pl.assemble(pl.robots.hyq_leg("bushings8", cylinder_length=float(cylinder_length), rod_length=float(rod_length)))


def studies(t_end, build=leg):
    """{"system": make, "builder": make}: the two studies compared (module docstring), each made
    by calling its ``make()``; ``build(cylinder_length, rod_length)`` builds a builder design
    (bench/builder_study_profile.py passes a timed one)."""
    import proleg as pl
    from proleg.papers.hyq_study import peak_hip_force, peak_knee_force, pin_stiffness_apply
    from proleg.study import LogRange

    outputs = {"peak_hip_force": peak_hip_force, "peak_knee_force": peak_knee_force}
    sim = dict(t_end=t_end, dt_output=1e-3, dt_max=1e-3, rtol=1e-6, atol=1e-7)  # the bushing study's options
    return {
        "system": lambda: pl.study.Study(leg(0.20, 0.30), {"pin_stiffness": LogRange(1e6, 1e10)}, outputs, sim, apply=pin_stiffness_apply),
        "builder": lambda: pl.study.Study(lambda cylinder_length: build(cylinder_length, 0.30), {"cylinder_length": (0.16, 0.24)}, outputs, sim),
    }


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=64)
    ap.add_argument("--t-end", type=float, default=0.1)
    ap.add_argument("--out", default=os.path.join(os.path.dirname(__file__), "results", "builder_study.md"))
    args = ap.parse_args()
    os.environ["PROLEG_CACHE_DIR"] = tempfile.mkdtemp(prefix="proleg-builder-study-")
    warnings.simplefilter("ignore")
    import proleg.compile_cache as cc

    import proleg.analyses.sweep as sweep_module

    sweeps = {"n": 0}  # compiled batches: one proleg.sweep call per group of a batch (executors.evaluate_batch)
    sweep0 = sweep_module.sweep

    def counted_sweep(*a, **k):
        sweeps["n"] += 1
        return sweep0(*a, **k)

    sweep_module.sweep = counted_sweep
    studies_ = studies(args.t_end)
    rows = []
    for name, make in (
        ("System study: pin stiffness 1e6-1e10 N/m (with_params)", studies_["system"]),
        ("builder study: cylinder length 0.16-0.24 m (assemble per design)", studies_["builder"]),
    ):
        before, sweeps["n"] = dict(cc.stats), 0
        study = make()
        t0 = time.perf_counter()
        table = study.run(design="grid", n=args.n, executor="vmap", store=tempfile.mkdtemp(prefix="proleg-builder-study-store-"), progress=False)
        wall = time.perf_counter() - t0
        ok = int((table["status"] == "success").sum()) if "status" in table else len(table)
        rows.append(dict(case=name, designs=len(table), ok=ok, wall=wall, rate=len(table) / wall,
                         traces=cc.stats["exported"] - before["exported"], shared=cc.stats["shared"] - before["shared"], groups=sweeps["n"]))
    lines = ["| study | designs | succeeded | wall [s] | designs/s | traces | shared loads | groups |", "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['case']} | {r['designs']} | {r['ok']} | {r['wall']:.1f} | {r['rate']:.2f} | {r['traces']} | {r['shared']} | {r['groups']} |")
    load = os.getloadavg()[0]
    text = "\n".join([
        "# Builder study against a parameter study (bench/builder_study.py)", "",
        f"HyQ leg with 8 bushings, {args.t_end} s drop, executor vmap, one process, fresh compile cache"
        "; "
        f"load average {load:.1f} at the end on {os.cpu_count()} CPUs. Rate ratio (builder / System): "
        f"{rows[1]['rate'] / rows[0]['rate']:.2f}.", "", *lines, "",
    ])
    print(text)
    with open(args.out, "w") as f:
        f.write(text)


if __name__ == "__main__":
    main()
