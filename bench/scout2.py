"""Scout II bounding (seed 003): wall time and step counts of each model's run, and the gait.

Each model is assembled, then simulated for ``--t-end`` seconds (default 10) from the nominal
start (:class:`proleg.robots.scout2.Scout2Params`: standing, legs vertical, a 3 cm drop; the
same for both models; bench/scout2_diagnose.py shows where the bound is lost) twice in one process: the first call includes compilation, the second is the run alone.
Columns: compile+run and run wall times [s], steps, Newton iterations, the steady forward
speed, period (1 = period-one bound), stride frequency, and the specific resistances (Eq. 8).
The scenario ``proleg run scout2-bound`` runs these plus the leg-friction calibration, the
low-speed set-point search, the parameter ranges, the Table 6 reading and the Table 5
sensitivity on the same two compiled systems.
"""

from __future__ import annotations

import argparse
import time

from common import add_output_args, emit, log

COLUMNS = ["model", "first call [s]", "run [s]", "steps", "newton", "speed [m/s]", "period", "stride [Hz]", "SR mech", "SR el"]


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--t-end", type=float, default=10.0)
    ap.add_argument("--models", default="I,II")
    add_output_args(ap, "scout2")
    args = ap.parse_args()
    from proleg.papers.scout2_bound import scout2_bound

    rows = []
    for model in args.models.split(","):
        log(f"Model {model}")
        t0 = time.perf_counter()
        first = scout2_bound(model, args.t_end)
        t1 = time.perf_counter()
        run = scout2_bound(model, args.t_end, system=first.system)
        t2 = time.perf_counter()
        m, st = run.metrics, run.result.stats
        rows.append({
            "model": model, "first call [s]": t1 - t0, "run [s]": t2 - t1, "steps": st["steps"], "newton": st["newton_iterations"],
            "speed [m/s]": m["forward_speed"], "period": m["period"], "stride [Hz]": m["stride_frequency"],
            "SR mech": m["specific_resistance_mechanical"], "SR el": m["specific_resistance_electrical"],
        })
    emit(args, f"Scout II bounding, {args.t_end:g} s simulated", rows, COLUMNS, {"t_end [s]": args.t_end})


if __name__ == "__main__":
    main()
