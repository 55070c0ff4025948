"""Scout II (seed 003): both models from standing across touchdown set points, and where the
retraction work goes.

Issue 31, second pass. Table 6 is read per virtual leg (``scout2(per="virtual")``, the reading
seed 003 §2.3 / Table 2 / §5.1 supports; scout2_data quotes it). Every run starts from standing
(Scout2Params: at rest, legs vertical, a 3 cm drop; the controller brings the robot into the
bound, or does not), the same for both models. The touchdown angles are Table 4's (19° back,
21° front) shifted together by δ; δ = 0 is the paper's set point. This is a map of the
set point, not a choice: the paper's comparison is at δ = 0.

Columns, per run: strides after the transient (t_end / 2), the steady speed and period
(1, 2; 0 = no steady gait), whether it fell, the specific resistances (Eq. 8; NaN without a
steady gait), the longest time a leg's controller stayed in stance-brake, and over the whole
run, rates in W (J per simulated second) of: the hip work in stance-retraction (what drives
the robot forward), the toe-slip dissipation during retraction (|friction| × slip speed: the
traction the toe loses while the saturated retraction torque sweeps it back), the negative hip
work in stance-brake (the PD braking the robot, §3.1 "the undesirable effect of braking the
robot") and the leg dampers.

Run: ``python bench/scout2_setpoints.py`` (Model II runs take about 2 min each on 2 cores).
"""

from __future__ import annotations

import argparse

import numpy as np

from common import add_output_args, emit, log

COLUMNS = ["model", "Table 6 per", "set", "δ [deg]", "strides", "speed [m/s]", "period", "fell", "SR mech", "SR el", "longest brake [s]",
           "retraction work [W]", "toe slip in retraction [W]", "brake negative work [W]", "leg dampers [W]", "wall [s]"]


def energy_split(run) -> dict:
    """Rates [W] over the run of retraction work, toe slip in retraction, negative brake work
    and leg-damper dissipation; the longest stance-brake [s]."""
    r, info = run.result, run.info
    t = np.asarray(r.t)
    T = t[-1] - t[0]
    b = float(info.params.leg_damping) * (2.0 if info.per == "physical" else 1.0)
    out = {"retraction work [W]": 0.0, "toe slip in retraction [W]": 0.0, "brake negative work [W]": 0.0, "leg dampers [W]": 0.0}
    longest = 0.0
    for leg in ("back", "front"):
        st = np.asarray(r.controller(f"{leg}_controller").state[:, 0])
        hp = np.asarray(r.actuator(info.motors[leg]).power)
        c = r.contact(f"{leg}_toe_contact")
        slip = np.linalg.norm(np.asarray(c["friction_force"]), axis=-1) * np.abs(np.asarray(c["slip_velocity"]))
        x = np.asarray(r.joint(f"{leg}_leg").translation)
        xd = np.gradient(x, t)
        out["retraction work [W]"] += np.trapezoid(np.where(st == 1, hp, 0.0), t) / T
        out["toe slip in retraction [W]"] += np.trapezoid(np.where(st == 1, slip, 0.0), t) / T
        out["brake negative work [W]"] += -np.trapezoid(np.where(st == 2, np.minimum(hp, 0.0), 0.0), t) / T
        out["leg dampers [W]"] += np.trapezoid(b * xd * xd, t) / T
        edges = np.flatnonzero(np.diff(np.r_[0, (st == 2).astype(int), 0]))
        if len(edges):
            longest = max(longest, float(np.max(t[np.minimum(edges[1::2], len(t) - 1)] - t[edges[0::2]])))
    out["longest brake [s]"] = longest
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--t-end", type=float, default=8.0)
    ap.add_argument("--models", default="I,II")
    ap.add_argument("--deltas", default="-4,0,4,8,12,16", help="touchdown offsets [deg]")
    ap.add_argument("--per", default="virtual", help="Table 6 reading(s), comma-separated")
    ap.add_argument("--set", action="append", default=[], metavar="NAME=V1,V2",
                    help="a Scout2Params field and values to run each at (e.g. mu=0.5,1.2 for the unknown toe friction)")
    add_output_args(ap, "scout2_setpoints")
    args = ap.parse_args()
    from proleg.papers import scout2_study as S
    from proleg.units import deg

    variants = [{}]
    for spec in args.set:
        name, vals = spec.split("=", 1)
        variants = [{**v, name: float(x)} for v in variants for x in vals.split(",")]
    rows = []
    for per in args.per.split(","):
        for model in args.models.split(","):
            base = None
            for var in variants:
                for d in (float(x) for x in args.deltas.split(",")):
                    log(f"Model {model}, per {per}, {var}, δ = {d:g}°")
                    run = S.run_point(model, args.t_end, base=base, delta=d * deg, per=per, **var)
                    base = base or run
                    m = run.metrics
                    ok = not m["fell"] and m["strides"] > 0 and m["period"] in (1, 2)
                    rows.append({
                        "model": model, "Table 6 per": per, "set": ", ".join(f"{k}={v:g}" for k, v in var.items()) or "nominal", "δ [deg]": d, "strides": m["strides"],
                        "speed [m/s]": m["forward_speed"], "period": m["period"], "fell": m["fell"],
                        "SR mech": m["specific_resistance_mechanical"] if ok else float("nan"),
                        "SR el": m["specific_resistance_electrical"] if ok else float("nan"),
                        **energy_split(run), "wall [s]": run.wall_time,
                    })
                    log(str(rows[-1]))
    emit(args, f"Scout II from standing across touchdown offsets δ ({args.t_end:g} s per run)", rows, COLUMNS,
         {"t_end [s]": args.t_end, "start": "standing (Scout2Params defaults)"})


if __name__ == "__main__":
    main()
