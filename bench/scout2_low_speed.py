"""Scout II (seed 003 §5.3): the touchdown set point for a commanded 0.8 m/s, found by bisection.

Issue 31, step 3. The set point is not picked: :func:`proleg.papers.scout2_study.setpoint_for_speed`
bisects the touchdown offset δ (Table 4's 19° back / 21° front shifted together) on the sign
of (steady speed − 0.8 m/s); a run that stops or falls counts as speed 0. Both models start
from standing, Table 6 per virtual leg (the default reading). The bracket is given per model
(``--bounds``): bisection needs a sign change on it, which bench/scout2_setpoints.py maps.
Where none exists the row says so (the paper: at 0.8 m/s Model I stops, Model II converges to
a period-two "quasi-bounding" gait).

One row per evaluation (the bisection's history) and a final row per model with the result.
Run: ``python bench/scout2_low_speed.py`` (Model II evaluations take 1–2 min each on 2 cores).
"""

from __future__ import annotations

import argparse

from common import add_output_args, emit, log

COLUMNS = ["model", "row", "δ [deg]", "speed [m/s]", "period", "fell", "SR mech", "SR el", "result"]


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--t-end", type=float, default=8.0)
    ap.add_argument("--target", type=float, default=0.8)
    ap.add_argument("--models", default="I,II")
    ap.add_argument("--bounds", default="-4,12", help="bracket on δ [deg], lo,hi")
    add_output_args(ap, "scout2_low_speed")
    args = ap.parse_args()
    from proleg.errors import ConvergenceError
    from proleg.papers import scout2_study as S
    from proleg.units import deg

    lo, hi = (float(x) * deg for x in args.bounds.split(","))
    rows = []
    for model in args.models.split(","):
        log(f"Model {model}: bisection for {args.target:g} m/s on δ in [{lo / deg:g}, {hi / deg:g}]°")
        pts: list[dict] = []
        base = S.run_point(model, args.t_end)
        try:
            delta, run = S.setpoint_for_speed(model, args.target, args.t_end, base=base, bounds=(lo, hi), rows=pts)
            m = run.metrics
            res = f"δ = {delta / deg:+.2f}°: {m['forward_speed']:.3f} m/s, period {m['period']}, fell {m['fell']}"
            if not abs(m["forward_speed"] - args.target) <= 0.1 * args.target:  # NaN too
                res += f" (the bisection's end point: no steady gait within 10 % of {args.target:g} m/s on the bracket)"
        except ConvergenceError as e:
            res = f"not bracketed / not found: {e}"
        for p in pts:
            rows.append({"model": model, "row": "evaluation", "δ [deg]": p["touchdown offset [deg]"], "speed [m/s]": p["speed [m/s]"],
                         "period": p["period"], "fell": p["fell"], "SR mech": p["SR mechanical"], "SR el": p["SR electrical"], "result": ""})
        rows.append({"model": model, "row": "result", "δ [deg]": float("nan"), "speed [m/s]": float("nan"), "period": "", "fell": "",
                     "SR mech": float("nan"), "SR el": float("nan"), "result": res})
        log(res)
    emit(args, f"Scout II set point for {args.target:g} m/s by bisection ({args.t_end:g} s per run, from standing)", rows, COLUMNS,
         {"t_end [s]": args.t_end, "target [m/s]": args.target, "bracket δ [deg]": args.bounds})


if __name__ == "__main__":
    main()
