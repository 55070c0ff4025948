"""A design change costs a run, not a compile (issue 42): per-variant time of a new design against
the same design assembled again, in one warm process.

Cases: the README double pendulum with new upper-link lengths; the HyQ leg (rigid, 0.3 s drop)
with new cylinder and rod lengths; the whole HyQ trot on torque sources (0.2 s) at a second gait
speed. Each case starts in a fresh compile-cache folder: its first model compiles, the first
model with other numbers decides (two traces, the first model's export reused), every later one
traces nothing. Columns: median wall time [s] of ``assemble`` + ``simulate`` per variant.

    python bench/design_loop.py [--legs 20] [--out bench/results/design_loop.md]
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time
import warnings

sys.path.insert(0, os.path.dirname(__file__))


def _timed(build, run):
    t0 = time.perf_counter()
    s = build()
    run(s)
    return time.perf_counter() - t0


def case(name, build_variant, run, variants, same):
    """(name, first, same again, deciding variant, median new variant, n) for one design loop."""
    import proleg.compile_cache as cc

    first = _timed(lambda: build_variant(variants[0]), run)
    again = statistics.median(_timed(lambda: build_variant(variants[0]), run) for _ in range(same))
    decide = _timed(lambda: build_variant(variants[1]), run)
    before = cc.stats["exported"]
    news = [_timed(lambda v=v: build_variant(v), run) for v in variants[2:]]
    traced = cc.stats["exported"] - before
    return dict(case=name, first=first, again=again, decide=decide, new=statistics.median(news), n=len(news), traced=traced)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--legs", type=int, default=20, help="new HyQ-leg geometries")
    ap.add_argument("--skip-trot", action="store_true")
    ap.add_argument("--out", default=os.path.join(os.path.dirname(__file__), "results", "design_loop.md"))
    args = ap.parse_args()
    os.environ["PROLEG_CACHE_DIR"] = tempfile.mkdtemp(prefix="proleg-design-loop-")
    warnings.simplefilter("ignore")
    import numpy as np

    import proleg as pl
    from proleg.robots import hyq_leg

    sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "tests"))
    from test_shared_trace import readme_pendulum

    rows = []
    rows.append(case(
        "README pendulum, new upper-link length", lambda L: pl.assemble(readme_pendulum(L)),
        lambda s: pl.simulate(s, t_end=2.0, dt_output=1e-3, progress=False), list(np.linspace(1.0, 1.3, 8)), 3,
    ))
    geoms = [(0.20 + 0.004 * k, 0.30 - 0.002 * k) for k in range(args.legs + 2)]
    rows.append(case(
        f"HyQ leg (rigid), new cylinder and rod lengths, 0.3 s drop", lambda g: pl.assemble(hyq_leg("rigid", cylinder_length=g[0], rod_length=g[1])),
        lambda s: pl.simulate(s, t_end=0.3, progress=False), geoms, 3,
    ))
    if not args.skip_trot:
        from proleg.robots.hyq_trot import hyq_trot_model
        from proleg.solvers.galpha import GeneralizedAlpha

        rows.append(case(
            "HyQ trot (torque sources), new gait speed, 0.2 s", lambda v: pl.assemble(hyq_trot_model(v, "torque")),
            lambda s: pl.simulate(s, t_end=0.2, dt_output=5e-3, integrator=GeneralizedAlpha(jacobian_reuse=True), progress=False),
            [1.0, 0.9, 0.8, 0.7], 1,
        ))
    head = "| case | first run [s] | same design assembled again [s] | first new design (decides) [s] | new design, median [s] | new designs | traces for them | new / again |"
    lines = [head, "|" + "---|" * 8]
    for r in rows:
        lines.append(f"| {r['case']} | {r['first']:.2f} | {r['again']:.2f} | {r['decide']:.2f} | {r['new']:.2f} | {r['n']} | {r['traced']} | {r['new'] / r['again']:.2f} |")
    try:
        load = os.getloadavg()[0]
    except OSError:
        load = float("nan")
    text = "\n".join([
        "# Design loop: a new design against the same design again (bench/design_loop.py)", "",
        f"One warm process, a fresh compile cache per run; load average {load:.1f} at the end on {os.cpu_count()} CPUs.", "",
        *lines, "",
    ])
    print(text)
    os.makedirs(os.path.dirname(args.out), exist_ok=True)
    with open(args.out, "w") as f:
        f.write(text)


if __name__ == "__main__":
    main()
