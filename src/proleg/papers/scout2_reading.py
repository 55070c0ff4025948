"""Scout II, the decided reading (issue 44): one quantity calibrated openly, everything else predicted.

With Table 6 and the §3.1 controller as printed, neither model bounds at Table 4's set points
(the stance-brake stall, :func:`proleg.papers.scout2_bound.stance_brake_stall`). Seed 003 §5.2
allows a calibrated simulation: its simulation "might not even be achievable with the set points
and gains used in experiment", Talebi et al. (2001) changed the sweep limits for that reason,
and §5.2 blames stiction and nonlinear damping in the telescopic legs, which its models leave
out. So one leg quantity is treated as not known:

- **calibrated**: Table 6's leg damping b (Table 2: b_i, per virtual leg), one value shared by
  Model I and Model II, in ``DAMPING_RANGE`` = 0.3–1.0 × Table 6's 55 N s/m;
- **fitted on one number only**: the robot's measured forward speed at Table 4's set points,
  1.286 m/s (seed 003 §5.2, 10 runs on carpet), with Model II, the model the paper puts forward
  (:func:`calibrate_leg_damping`; its inputs are that speed and the range, nothing else);
- **predicted, never refitted** (:func:`predict`, which takes the fitted damping only): Model I
  with the same damping (does it bound, does its brake hold the back leg at the sweep limit,
  at what speed), both models' specific resistances, Fig. 16's gait parameters, leg-state
  timing and hip torques (Figs. 13–14), the low-speed gait and the Fig. 7 analogue, whose set
  points are found by bisection on a commanded speed (:func:`proleg.papers.scout2_study.setpoint_for_speed`).

The speed of a run (:func:`bound_speed`) is the steady bound's (period one or two, not fallen,
not stalled), and 0 otherwise: a stall is the limit of ever slower bounding, and a run that
falls or wanders does not bound at all.
"""

from __future__ import annotations

import numpy as np

from ..errors import ModelError
from ..robots import scout2_data as D
from ..robots.scout2 import LEGS
from ..units import deg
from . import scout2_study as S

__all__ = ["DAMPING_RANGE", "SPEED_QUANTITY", "bound_speed", "calibrate_leg_damping", "predict", "stance_phases", "prediction_rows", "run_reading"]

#: The calibrated quantity's range [N s/m per virtual leg]: 0.3–1.0 × Table 6's 55 N s/m (issue 44).
DAMPING_RANGE = (0.3 * D.LEG_DAMPING, D.LEG_DAMPING)
#: The one measured quantity the damping is fitted to (seed 003 §5.2: 1.286 ± 0.04 m/s).
SPEED_QUANTITY = "forward speed at Table 4's set points [m/s]"


def bound_speed(run) -> float:
    """Steady bounding speed [m/s] of a run: its forward speed when it bounds (period one or
    two, not fallen, not stalled), else 0 (the stall is the limit of ever slower bounding)."""
    m = run.metrics
    v = m.get("forward_speed", np.nan)
    if m.get("fell") or m.get("stalled") or not m.get("strides") or m.get("period") not in (1, 2) or not np.isfinite(v):
        return 0.0
    return float(v)


def calibrate_leg_damping(t_end: float, *, base=None, target_speed: float = D.SPEED_MEASURED, bounds=DAMPING_RANGE, grid: int = 11,
                          xtol: float = 0.5, rows: list | None = None, log=None):
    """Fit the leg damping b [N s/m, per virtual leg] so that Model II bounds at ``target_speed``
    at Table 4's set points.

    The fit sees only the speed: each evaluation is a Model II run from standing at Table 4 with
    ``leg_damping = b`` (:func:`proleg.papers.scout2_study.run_point`), reduced to
    :func:`bound_speed`. The speed need not be monotonic in b over the whole range (too little
    damping may fall, too much stalls), so the range is first sampled at ``grid`` points; of the
    intervals between neighbours on which speed − target changes sign, the one nearest Table 6
    (the largest b) is bisected to ``xtol`` (:func:`proleg.identify.calibration.fit_to`). If no
    interval brackets the target, the sampled value whose speed is closest is returned with
    ``at_bound=True``: no damping in the range gives the measured speed, which the caller reports
    with the speed-against-damping rows; if no sample bounds at all (speed 0 everywhere), Model II
    does not bound at Table 4 anywhere in the range at the grid's resolution, and the value
    returned (the sample nearest Table 6) is no calibration: :func:`run_reading` stops there.

    Parameters
    ----------
    t_end : float [s], each run's length (steady strides from t_end / 2)
    base : a Model II :class:`~proleg.papers.scout2_bound.BoundRun` whose compiled system to reuse
    target_speed : float [m/s], the measured speed (default seed 003 §5.2's 1.286)
    bounds : (lo, hi) [N s/m], the calibrated quantity's range (default ``DAMPING_RANGE``)
    grid : int ≥ 2, samples of the range before bisecting (default 11: every 3.85 N s/m, 7 % of
        Table 6, so a bounding window narrower than that can be missed)
    xtol : float [N s/m], the bisection's final bracket width
    rows : a list to which one dict per evaluation is appended (damping, speed, the late mean
        speed of a run that moves without a steady gait, period, fell, stalled): the
        speed-against-damping table
    log : callable(str) for progress, or None

    Returns
    -------
    (:class:`~proleg.identify.calibration.Calibrated`, {b: run}) — ``target`` and ``achieved``
    are the measured and the fitted model's speed; ``bounds`` the whole range.
    """
    import dataclasses

    from ..identify.calibration import Calibrated, fit_to

    lo, hi = (float(b) for b in bounds)
    if not (np.isfinite(lo) and np.isfinite(hi) and 0 <= lo < hi):
        raise ModelError(f"calibrate_leg_damping: bounds must be 0 <= lo < hi [N s/m], got {bounds!r}; the issue's range is "
                         f"0.3–1.0 × Table 6 = {DAMPING_RANGE[0]:g}..{DAMPING_RANGE[1]:g}.")
    if int(grid) < 2:
        raise ModelError(f"calibrate_leg_damping: grid must be at least 2 samples of the range, got {grid!r}.")
    if not (np.isfinite(target_speed) and target_speed > 0):
        raise ModelError(f"calibrate_leg_damping: target_speed must be a positive speed [m/s], got {target_speed!r}.")
    runs: dict = {}

    def speed(b):
        b = float(b)
        if b not in runs:
            if log:
                log(f"calibration: Model II at Table 4, leg damping {b:.4g} N s/m")
            runs[b] = r = S.run_point("II", t_end, base=base, leg_damping=b)
            m = r.metrics
            if rows is not None:
                moved = m.get("strides") and not m.get("fell")
                rows.append({"leg damping [N s/m]": b, "× Table 6": b / D.LEG_DAMPING, "speed [m/s]": bound_speed(r),
                             "mean speed, no steady gait [m/s]": float(m.get("forward_speed", np.nan)) if moved and bound_speed(r) == 0 else np.nan,
                             "period": m.get("period"), "fell": bool(m.get("fell")), "stalled": bool(m.get("stalled"))})
        return bound_speed(runs[b])

    samples = np.linspace(hi, lo, int(grid))  # from Table 6 down: the bracket nearest Table 6 first
    res = [speed(b) - target_speed for b in samples]
    bracket = next(((samples[k + 1], samples[k]) for k in range(len(samples) - 1) if res[k] * res[k + 1] <= 0), None)
    source = "seed 003 §5.2: measured forward speed 1.286 ± 0.04 m/s at Table 4 (10 runs on carpet); range 0.3–1.0 × Table 6"
    if bracket is None:
        best = min(samples, key=lambda b: abs(speed(b) - target_speed))
        return Calibrated("leg_damping", float(best), (lo, hi), "N s/m", (SPEED_QUANTITY,), source, float(target_speed), speed(best), True), runs
    cal = fit_to("leg_damping", lambda b: {SPEED_QUANTITY: speed(b)}, {SPEED_QUANTITY: target_speed}, bracket, unit="N s/m", xtol=xtol,
                 source=source)
    return dataclasses.replace(cal, bounds=(lo, hi), target=float(target_speed), achieved=speed(cal.value)), runs


def stance_phases(run, transient: float | None = None) -> dict:
    """Leg-state timing and hip torques of the steady part of a run (seed 003 Figs. 13–14).

    Per leg (``back``, ``front``), over episodes that start after ``transient`` (default the
    run's half-time): mean stance-retraction and stance-brake durations [s], the largest
    retraction and brake torque magnitudes at the virtual leg [N m], and the furthest the leg
    (the hip joint, not the encoder) goes past its sweep limit in stance-brake [deg] (seed 003
    §5.2: "in Model I the sweep limit controller is not able to hold the back leg at the desired
    sweep limit angle").
    """
    r, info = run.result, run.info
    t = np.asarray(r.t)
    t0 = t[-1] / 2 if transient is None else transient
    late = t >= t0
    out = {}
    for leg in LEGS:
        st = np.asarray(r.controller(f"{leg}_controller").state[:, 0])
        tau = np.asarray(r.actuator(info.motors[leg]).leg_torque)
        phi = np.asarray(r.joint(f"{leg}_hip").angle)
        sweep = float(getattr(info.params, f"sweep_{leg}"))
        for name, code in (("retraction", 1), ("brake", 2)):
            on = (st == code) & late
            edges = np.flatnonzero(np.diff(np.r_[0, on.astype(int), 0]))
            d = t[np.minimum(edges[1::2], len(t) - 1)] - t[edges[0::2]]
            out[f"{leg} {name} [s]"] = float(d.mean()) if len(d) else np.nan
            out[f"{leg} {name} torque [N m]"] = float(np.max(np.abs(tau[on]))) if on.any() else np.nan
        on = (st == 2) & late
        out[f"{leg} overshoot [deg]"] = float(np.degrees(np.max(sweep - phi[on]))) if on.any() else np.nan
    return out


def predict(leg_damping: float, t_end: float, *, bases: dict | None = None, low_speed_target: float | None = D.SR_LOW_SPEED[0],
            low_speed_models=("I", "II"), low_speed_bounds=(-12 * deg, 4 * deg), low_speed_xtol=1.0 * deg, rows: list | None = None,
            log=None) -> dict:
    """The predictions at a given leg damping [N s/m, per virtual leg]; nothing here is fitted.

    Runs both models at Table 4's set points from standing and, unless ``low_speed_target`` is
    None, finds for each of ``low_speed_models`` the touchdown offset that gives the commanded
    low speed by bisection (:func:`proleg.papers.scout2_study.setpoint_for_speed`, a run that
    stalls or falls counting as too slow). Every run becomes a Fig. 7 point in ``rows``.

    Returns {"Model I": run, "Model II": run, "low": {model: (δ [rad], run) or the reason none was
    found}, "leg_damping": leg_damping}.
    """
    from ..errors import ConvergenceError

    if not (np.isfinite(leg_damping) and leg_damping >= 0):
        raise ModelError(f"predict: leg_damping must be a non-negative damping [N s/m], got {leg_damping!r}.")
    bases = bases or {}
    out = {"leg_damping": float(leg_damping), "low": {}}
    for model in ("I", "II"):
        if log:
            log(f"prediction: Model {model} at Table 4, leg damping {leg_damping:.4g} N s/m")
        out[f"Model {model}"] = r = S.run_point(model, t_end, base=bases.get(model), leg_damping=float(leg_damping))
        if rows is not None:
            rows.append(S.point_row(r, f"Model {model}, Table 4"))
    if low_speed_target is not None:
        for model in low_speed_models:
            if log:
                log(f"prediction: Model {model}, set point for {low_speed_target:g} m/s (bisection)")
            try:
                out["low"][model] = S.setpoint_for_speed(model, low_speed_target, t_end, base=out[f"Model {model}"], bounds=low_speed_bounds,
                                                         xtol=low_speed_xtol, rows=rows, leg_damping=float(leg_damping))
            except ConvergenceError as e:
                out["low"][model] = str(e)
    return out


def prediction_rows(pred: dict) -> list[dict]:
    """The predicted quantities of both models at Table 4 (one dict per model): speed, period,
    specific resistances (Eq. 8), Fig. 16's gait parameters and :func:`stance_phases`."""
    rows = []
    for model in ("I", "II"):
        run = pred[f"Model {model}"]
        m = run.metrics
        ok = bound_speed(run) > 0
        row = {"model": model, "leg damping [N s/m]": pred["leg_damping"], "bounds": ok, "fell": bool(m["fell"]), "stalled": bool(m["stalled"]),
               "period": m["period"], "speed [m/s]": m["forward_speed"] if ok else np.nan}
        for key, label in (("specific_resistance_electrical", "SR electrical"), ("specific_resistance_mechanical", "SR mechanical"),
                           ("stride_frequency", "stride frequency [Hz]"), ("duty_factor_back", "duty back"), ("duty_factor_front", "duty front"),
                           ("pitch_max", "pitch max [deg]"), ("pitch_min", "pitch min [deg]"), ("height_max", "height max [m]"),
                           ("height_min", "height min [m]")):
            row[label] = m.get(key, np.nan) if ok else np.nan
        row["hopping height [m]"] = row["height max [m]"] - row["height min [m]"]
        row.update(stance_phases(run))
        rows.append(row)
    return rows


def run_reading(t_end: float, *, grid: int = 11, xtol: float = 0.5, low_speed_target: float | None = D.SR_LOW_SPEED[0],
                low_speed_models=("I", "II"), log=None) -> dict:
    """The decided reading end to end: the as-printed runs, the calibration, then the predictions.

    1. Both models at Table 4 with Table 6's damping as printed (the stall, shown beside the
       calibrated runs);
    2. :func:`calibrate_leg_damping` on the measured speed only (Model II);
    3. :func:`predict` from the fitted value alone: it gets ``cal.value``, not the calibration's
       runs, so no predicted number comes from a run the fit chose for it.

    If no sampled damping makes Model II bound at all, step 3 is skipped (issue 44: "report that,
    and stop there"): ``stopped`` then says why and ``prediction`` is None.

    Returns {"printed": {"Model I": run, "Model II": run}, "calibration": Calibrated,
    "speed_vs_damping": rows, "prediction": :func:`predict`'s dict or None, "rows": prediction
    rows (:func:`prediction_rows`), "points": Fig. 7 points, "met": the fit is within the
    measured speed's ± 0.04 m/s, "stopped": None or the reason nothing was predicted}.
    """
    printed = {}
    for model in ("I", "II"):
        if log:
            log(f"Table 6 as printed: Model {model} at Table 4, leg damping {D.LEG_DAMPING:g} N s/m")
        printed[f"Model {model}"] = S.run_point(model, t_end)
    sweep: list = []
    cal, _ = calibrate_leg_damping(t_end, base=printed["Model II"], grid=grid, xtol=xtol, rows=sweep, log=log)
    sweep = sorted(sweep, key=lambda r: r["leg damping [N s/m]"])
    out = {"printed": printed, "calibration": cal, "speed_vs_damping": sweep, "prediction": None, "rows": [], "points": [], "met": False,
           "stopped": None}
    if not any(r["speed [m/s]"] > 0 for r in sweep):
        lo, hi = cal.bounds
        out["stopped"] = (f"no leg damping in {lo:.4g}–{hi:.4g} N s/m ({lo / D.LEG_DAMPING:.2g}–{hi / D.LEG_DAMPING:.2g} × Table 6, sampled at "
                          f"{len(sweep)} values) makes Model II bound at Table 4's set points: there is nothing to calibrate, so "
                          "nothing is predicted (issue 44: report that and stop there)")
        return out
    points: list = []
    pred = predict(cal.value, t_end, bases={m: printed[f"Model {m}"] for m in ("I", "II")}, low_speed_target=low_speed_target,
                   low_speed_models=low_speed_models, rows=points, log=log)
    met = cal.achieved is not None and abs(cal.achieved - cal.target) <= D.SPEED_MEASURED_SD
    out.update(prediction=pred, rows=prediction_rows(pred), points=points, met=bool(met))
    return out
