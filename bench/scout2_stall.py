"""Scout II (seed 003): what the stance-brake stall is, measured (issue 31, the blocker).

Neither model bounds from standing at Table 4's set points: both end standing on braked legs.
This script measures the mechanism, one row per run (Model I unless ``--models``):

- ``start``: "standing" is the builder's start (at rest, legs vertical, 3 cm drop, controllers
  in flight); "in gait" starts in double flight at a bounding-like state (COM 1 cm above the
  toes' reach, 1.5 m/s, 2.16 rad/s nose-up, back leg at 19°: the former cycle apex of
  bench/scout2_diagnose.py, the same toe clearance), so a run that stalls from there shows that
  the gait, not the start, fails;
- ``case``: Table 6 read per virtual leg as printed (scout2's default), the same with the leg
  damping set to 0 (is it dissipation?), per physical leg, per physical leg with the damping
  halved (the configuration the model used to bound with), and Table 4's touchdown angles
  shifted by +12° (where Model I bounds);
- ``stalled``: the run ends with both legs' controllers in stance-brake and the body at rest
  (|v_x| < 5 cm/s): a fixed point of the seed's controller (§3.1, Fig. 4: brake leaves only at
  lift-off, and a robot standing on both legs never lifts off), so nothing injects energy again;
- ``front retraction [s]`` / ``front brake [s]``: mean durations of the front leg's
  stance-retraction (touchdown to sweep limit) and stance-brake (sweep limit to lift-off), and
  ``longest brake [s]``; ``stance half-period [s]``: π √(m_e / k) of the virtual leg's spring,
  m_e = m I / (I + m L²) the mass a leg at one end of the body feels (m whole robot, I pitch
  inertia, L half hip spacing): the time the spring needs to throw the body off the leg;
- rates over the run [W]: hip work in retraction (the energy the controller injects), negative
  hip work in brake, leg dampers; and ``first-second hip work [J]``;
- the brake itself (seed 003 §5.2 says Model I's sweep-limit controller "is not able to hold the
  back leg at the desired sweep limit angle"): ``back overshoot [deg]``, the furthest the back
  leg (the hip joint, not the encoder) goes past its sweep limit in stance-brake;
  ``brake torque [N m]``, the largest leg torque either brake applies, against ``current limit
  [N m]``, the drive's α K_T i_max (Eq. 6); ``Δv in back brake [m/s]``, the mean change of the
  body's forward speed over one back stance-brake episode (negative: the brake slows the robot).

Run: ``python bench/scout2_stall.py`` (about 1 min per Model I run on 2 cores).
"""

from __future__ import annotations

import argparse

import numpy as np

from common import add_output_args, emit, log
from scout2_setpoints import energy_split

COLUMNS = ["model", "start", "case", "strides", "speed [m/s]", "fell", "stalled", "longest brake [s]", "front retraction [s]",
           "front brake [s]", "stance half-period [s]", "retraction work [W]", "brake negative work [W]", "leg dampers [W]", "back overshoot [deg]", "brake torque [N m]",
           "current limit [N m]", "Δv in back brake [m/s]", "wall [s]"]
IN_GAIT = dict(height=0.324, speed=1.5, pitch_rate=2.16)
CASES = {
    "virtual (as printed)": dict(per="virtual"),
    "virtual, leg damping 0": dict(per="virtual", leg_damping=0.0),
    "physical": dict(per="physical"),
    "physical, damping halved": dict(per="physical", leg_damping=27.5),
    "virtual, touchdown +12°": dict(per="virtual", delta=12.0),
    "virtual, one motor per virtual leg": dict(per="virtual", motors_per_leg=1),
    "virtual, toe friction 1.5": dict(per="virtual", mu=1.5),
}


def phase_durations(run, leg="front"):
    """Mean durations [s] of a leg's stance-retraction and stance-brake episodes."""
    r = run.result
    t = np.asarray(r.t)
    st = np.asarray(r.controller(f"{leg}_controller").state[:, 0])
    out = {}
    for k, code in (("retraction", 1), ("brake", 2)):
        edges = np.flatnonzero(np.diff(np.r_[0, (st == code).astype(int), 0]))
        d = t[np.minimum(edges[1::2], len(t) - 1)] - t[edges[0::2]]
        out[k] = float(d.mean()) if len(d) else float("nan")
    return out


def brake_phase(run) -> dict:
    """How the stance-brake holds: the back leg's largest overshoot past its sweep limit [deg],
    the largest brake torque at the leg [N m] (either leg), the drive's current-limit torque
    [N m] and the mean change of forward speed over a back-brake episode [m/s]."""
    r, info = run.result, run.info
    t = np.asarray(r.t)
    vx = np.asarray(r.part("body").velocity[:, 0])
    out = {"back overshoot [deg]": float("nan"), "brake torque [N m]": float("nan"), "Δv in back brake [m/s]": float("nan")}
    torques = []
    for leg in ("back", "front"):
        st = np.asarray(r.controller(f"{leg}_controller").state[:, 0])
        on = st == 2
        if not on.any():
            continue
        torques.append(float(np.max(np.abs(np.asarray(r.actuator(info.motors[leg]).leg_torque)[on]))))
        if leg == "back":
            phi = np.asarray(r.joint("back_hip").angle)
            sweep = float(info.params.sweep_back)
            out["back overshoot [deg]"] = float(np.degrees(np.max(sweep - phi[on])))
            edges = np.flatnonzero(np.diff(np.r_[0, on.astype(int), 0]))
            i0, i1 = edges[0::2], np.minimum(edges[1::2], len(t) - 1)
            out["Δv in back brake [m/s]"] = float(np.mean(vx[i1] - vx[i0]))
    if torques:
        out["brake torque [N m]"] = max(torques)
    return out


def stalled(run) -> bool:
    r = run.result
    end = [int(np.asarray(r.controller(f"{leg}_controller").state[-1, 0])) for leg in ("back", "front")]
    return end == [2, 2] and abs(float(r.part("body").velocity[-1, 0])) < 0.05


def half_period(run) -> float:
    p, n = run.info.params, (2.0 if run.info.per == "physical" else 1.0)
    m = p.body_mass + 2 * n * p.leg_mass
    L = p.half_hip_spacing
    me = m * p.body_inertia / (p.body_inertia + m * L * L)
    return float(np.pi * np.sqrt(me / (n * p.leg_stiffness)))


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--t-end", type=float, default=5.0)
    ap.add_argument("--models", default="I")
    ap.add_argument("--starts", default="standing,in gait")
    ap.add_argument("--cases", default=";".join(CASES), help="semicolon-separated keys of CASES")
    add_output_args(ap, "scout2_stall")
    args = ap.parse_args()
    from proleg.papers import scout2_study as S
    from proleg.papers.scout2_bound import scout2_bound
    from proleg.units import deg

    rows = []
    for model in args.models.split(","):
        for start in args.starts.split(","):
            for case in args.cases.split(";"):
                kw = dict(CASES[case])
                delta = kw.pop("delta", 0.0) * deg
                if start == "in gait":
                    kw.update(IN_GAIT, leg_angle_back=19 * deg + delta)
                log(f"Model {model}, {start}, {case}")
                run = scout2_bound(model, args.t_end, transient=args.t_end / 2, variables=S._td(delta), **kw)
                m = run.metrics
                e = energy_split(run)
                ph = phase_durations(run)
                rows.append({
                    "model": model, "start": start, "case": case, "strides": m["strides"], "speed [m/s]": m["forward_speed"],
                    "fell": m["fell"], "stalled": stalled(run), "longest brake [s]": e["longest brake [s]"],
                    "front retraction [s]": ph["retraction"], "front brake [s]": ph["brake"], "stance half-period [s]": half_period(run),
                    "retraction work [W]": e["retraction work [W]"], "brake negative work [W]": e["brake negative work [W]"],
                    "leg dampers [W]": e["leg dampers [W]"], **brake_phase(run),
                    "current limit [N m]": float(run.info.drive.tau_current_limit), "wall [s]": run.wall_time,
                })
                log(str(rows[-1]))
    emit(args, f"Scout II: the stance-brake stall, measured ({args.t_end:g} s per run)", rows, COLUMNS,
         {"t_end [s]": args.t_end, "in-gait start": str(IN_GAIT) + ", back leg at 19° + offset"})


if __name__ == "__main__":
    main()
