"""Dense output (issue 20): the HyQ leg drop on the HAL bench with outputs every 1 ms and every
0.1 ms, the same physics.

The model is ``proleg.robots.hyq_leg(joints="rigid", gain="high", drop_height=0.05,
actuators="drop")`` (slider, thigh, shank, continuous PD servos, foot contact; seeds 000/001),
simulated for 1 s with the options of ``hyq_tests.drop_test`` (generalized-α, rtol 1e-6,
atol 1e-7, dt_max 1 ms). Steps are chosen by accuracy, not by the output times, and outputs
between steps come from the cubic Hermite dense output, so asking for 10× the outputs should
cost little: target ≤ 1.3× the CPU time of the 1 ms run, and the slider's lowest point within
1e-5 m of a tight-tolerance run (rtol 1e-9, atol 1e-10, outputs every 0.1 ms).

Columns: ``wall [s]`` best of ``--repeat`` runs after a compile run (the outputs' post-processing
is not prepared: ``RunOptions(prepare_outputs=False)``, so only the run is timed); ``cpu [s]`` the
least CPU time of those runs (on a shared machine the steadier figure: the target is judged on
``cpu / 1 ms run``); ``slider min [m]`` the minimum of the slider's z over the outputs;
``Δ slider min [m]`` against the tight run.

    python bench/dense_output.py [--repeat 3] [--json]
"""

from __future__ import annotations

import argparse
import sys

import numpy as np
from common import add_output_args, emit, log, timed_cpu

import proleg as pl

T_END = 1.0


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    add_output_args(ap, "dense_output")
    args = ap.parse_args(argv)
    system = pl.assemble(pl.robots.hyq_leg(joints="rigid", gain="high", drop_height=0.05, actuators="drop"))
    run = pl.RunOptions(progress=False, prepare_outputs=False)
    cases = [
        ("outputs 1 ms", 1e-3, pl.GeneralizedAlpha(rtol=1e-6, atol=1e-7, dt_max=1e-3)),
        ("outputs 0.1 ms", 1e-4, pl.GeneralizedAlpha(rtol=1e-6, atol=1e-7, dt_max=1e-3)),
        ("tight, outputs 0.1 ms", 1e-4, pl.GeneralizedAlpha(rtol=1e-9, atol=1e-10, dt_max=1e-3)),
    ]
    for name, dt, integ in cases:
        log(f"{name}: compile ...")
        pl.simulate(system, t_end=T_END, dt_output=dt, integrator=integ, run=run)
    # The cases take turns, so that a change in the machine's load reaches all of them.
    best, cpu = [None] * len(cases), [float("inf")] * len(cases)
    for _ in range(max(1, args.repeat)):
        for i, (name, dt, integ) in enumerate(cases):
            res, wall, c = timed_cpu(pl.simulate, system, t_end=T_END, dt_output=dt, integrator=integ, run=run)
            cpu[i] = min(cpu[i], c)
            if best[i] is None or wall < best[i][1]:
                best[i] = (res, wall)
    rows = []
    for (name, _, _), (res, wall), c in zip(cases, best, cpu):
        z = res.part("slider").position[:, 2]
        rows.append({"case": name, "outputs": len(res.t), "steps": res.stats["steps"], "rejected": res.stats["rejected"],
                     "wall [s]": wall, "cpu [s]": c, "slider min [m]": float(np.min(z)), "t at min [s]": float(res.t[np.argmin(z)])})
        log(f"  {rows[-1]}")
    ref = rows[2]["slider min [m]"]
    for r in rows:
        r["Δ slider min [m]"] = r["slider min [m]"] - ref
        r["wall / 1 ms run"] = r["wall [s]"] / rows[0]["wall [s]"]
        r["cpu / 1 ms run"] = r["cpu [s]"] / rows[0]["cpu [s]"]
    ratio, dev = rows[1]["cpu / 1 ms run"], abs(rows[1]["Δ slider min [m]"])
    notes = [
        f"0.1 ms outputs cost {ratio:.2f}× the CPU of the 1 ms run (target ≤ 1.3×: {'met' if ratio <= 1.3 else 'not met'}; "
        f"wall {rows[1]['wall / 1 ms run']:.2f}×); "
        f"slider minimum {dev:.2g} m from the tight run (target ≤ 1e-5 m: {'met' if dev <= 1e-5 else 'not met'}).",
        "Before dense output (issue 20, same machine class): 0.053 s / 1,002 steps with 1 ms outputs, "
        "0.478 s / 10,002 steps with 0.1 ms outputs (every output time forced a step).",
    ]
    cols = ["case", "outputs", "steps", "rejected", "wall [s]", "cpu [s]", "wall / 1 ms run", "cpu / 1 ms run", "slider min [m]", "t at min [s]", "Δ slider min [m]"]
    emit(args, "HyQ leg drop (HAL bench), 1 s: outputs every 1 ms vs 0.1 ms", rows, cols, {"t_end [s]": T_END}, notes)


if __name__ == "__main__":
    sys.exit(main())
