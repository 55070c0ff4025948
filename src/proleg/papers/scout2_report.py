"""The ``scout2-bound`` scenario, the decided reading of issue 44 (seed 003): both models at Table 4
with Table 6 as printed (the stall), the leg damping calibrated on the robot's measured speed
only (Model II), and from the fitted value alone the predictions: both models' gait, specific
resistances, Fig. 16 quantities, leg-state timing and hip torques, the low-speed set points
found for a commanded speed and the Fig. 7 analogue; optionally the unknown parameters' ranges,
the Table 6 readings and the Table 5 sensitivity; a self-contained HTML report and Parquet.

The calibration and the predictions are :mod:`proleg.papers.scout2_reading`'s. Everything runs
on two compiled systems (Model I, Model II): the variants change parameters only, so they reuse
them (:func:`proleg.papers.scout2_study.variant_system`). The findings prose is written by
:func:`findings` from the run's numbers; the paper's values enter only as cited references
(scout2_data).
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pandas as pd

from ..units import deg
from ..robots import scout2_data as D
from ..robots.scout2 import LEGS
from .scout2_bound import BoundRun, energy_balance, pitch_deg, scout2_bound
from . import scout2_study as S
from .scout2_study import variant_system

__all__ = ["run_bound", "variant_system", "bound_figures", "findings", "NOMINAL_START", "LOW_SPEED_TARGET"]

# Initial condition of every run: the builder's (Scout2Params: at rest in the standing posture,
# legs vertical, released from a 3 cm drop; the same for both models); documented in the report.
# Override fields here to change it.
NOMINAL_START: dict = {}
# Commanded low speed (seed 003 §3.3 and §5.3: the robot's low-speed point, 0.85 m/s in Fig. 7);
# the set points for it are found by bisection for each model (scout2_study.setpoint_for_speed).
LOW_SPEED_TARGET = D.SR_LOW_SPEED[0]
METRIC_LABELS = {
    "forward_speed": "forward speed [m/s]",
    "stride_frequency": "stride frequency [Hz]",
    "duty_factor_back": "duty factor back [-]",
    "duty_factor_front": "duty factor front [-]",
    "pitch_max": "pitch max [deg]",
    "pitch_min": "pitch min [deg]",
    "height_max": "COM height max [m]",
    "height_min": "COM height min [m]",
    "specific_resistance_mechanical": "specific resistance, mechanical [-]",
    "specific_resistance_electrical": "specific resistance, electrical [-]",
    "period": "period (1, 2; 0 = none)",
    "strides": "steady strides",
}


def _stride_window(run: BoundRun):
    """Output index range of the last complete steady stride (back lift-off to back lift-off)."""
    st = run.strides
    t = run.result.t
    if len(st) == 0:
        return 0, len(t) - 1
    row = st.iloc[-1]
    a = int(np.searchsorted(t, row["start [s]"]))
    b = int(np.searchsorted(t, row["start [s]"] + row["duration [s]"]))
    return a, min(b, len(t) - 1)


def bound_figures(runs: dict[str, BoundRun]):
    """Figures analogous to seed 003 Figs. 9, 12–16 for runs {"Model I": run, "Model II": run}."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figs = []
    styles = {"Model I": ":", "Model II": "--"}
    # Fig. 12: pitch and COM height over one stride
    fig, ax = plt.subplots(1, 2, figsize=(10, 3.4))
    for name, run in runs.items():
        a, b = _stride_window(run)
        r = run.result
        t = r.t[a : b + 1] - r.t[a]
        ax[0].plot(t, pitch_deg(r)[a : b + 1], styles.get(name, "-"), label=name)
        ax[1].plot(t, r.part("body").position[a : b + 1, 2], styles.get(name, "-"), label=name)
    ax[0].set(xlabel="time in stride [s]", ylabel="pitch [deg]", title="pitch over one stride")
    ax[1].set(xlabel="time in stride [s]", ylabel="COM height [m]", title="COM height over one stride")
    ax[0].legend()
    figs.append((fig, "Fig. 12 analogue: body pitch (nose-up positive) and COM height over the last steady stride, from back-leg lift-off."))
    # Fig. 13: leg angles and rates with the leg-state square wave
    fig, ax = plt.subplots(2, 2, figsize=(10, 5.5), sharex="col")
    for j, leg in enumerate(LEGS):
        for name, run in runs.items():
            a, b = _stride_window(run)
            r = run.result
            t = r.t[a : b + 1] - r.t[a]
            jr = r.joint(f"{leg}_hip")
            c = f"C{list(runs).index(name)}"
            ax[0, j].plot(t, np.degrees(jr.angle[a : b + 1]), styles.get(name, "-"), color=c, label=name)
            rate = np.gradient(np.unwrap(jr.angle), r.t)
            ax[1, j].plot(t, rate[a : b + 1], styles.get(name, "-"), color=c, label=name)
            st = r.controller(f"{leg}_controller").state[a : b + 1, 0]
            sq = np.choose(st.astype(int), [1.0, -1.0, 0.0])  # flight high, retraction low, brake medium
            lo, hi = ax[0, j].get_ylim()
            ax[0, j].step(t, 0.5 * (lo + hi) + 0.2 * (hi - lo) * sq, where="post", lw=0.8, alpha=0.5, color=c, label=f"{name} state")
        ax[0, j].set(ylabel="leg angle φ [deg]", title=f"{leg} leg")
        ax[1, j].set(xlabel="time in stride [s]", ylabel="φ̇ [rad/s]")
    ax[0, 0].legend(fontsize=7)
    figs.append((fig, "Fig. 13 analogue: leg angles relative to the body and their rates over one stride; the step lines are the leg states (flight high, stance-retraction low, stance-brake middle)."))
    # Fig. 14: hip torques
    fig, ax = plt.subplots(1, 2, figsize=(10, 3.4))
    for j, leg in enumerate(LEGS):
        for name, run in runs.items():
            a, b = _stride_window(run)
            r = run.result
            t = r.t[a : b + 1] - r.t[a]
            act = r.actuator(run.info.motors[leg])
            ax[j].plot(t, act.leg_torque[a : b + 1], styles.get(name, "-"), label=f"{name} delivered")
            ax[j].plot(t, act.command[a : b + 1], styles.get(name, "-"), lw=0.7, alpha=0.6, label=f"{name} commanded")
        ax[j].set(xlabel="time in stride [s]", ylabel="hip torque [N m] (virtual leg)", title=f"{leg} hip torque")
    ax[0].legend(fontsize=7)
    figs.append((fig, "Fig. 14 analogue: torque at the virtual leg (two motors) commanded by the controller and delivered by the saturated drive."))
    # Fig. 15: torque–speed operating points over the saturation lines
    fig, ax = plt.subplots(1, 2, figsize=(10, 3.8))
    from ..drives.dcmotor import torque_speed_limits

    for j, leg in enumerate(LEGS):
        run0 = next(iter(runs.values()))
        d = run0.info.drive
        w = np.linspace(-12, 12, 200)
        lo, hi = torque_speed_limits(d, w, battery=True)
        ax[j].plot(np.asarray(hi), w, "k-", lw=1, label="saturation (battery)")
        ax[j].plot(np.asarray(lo), w, "k-", lw=1)
        for name, run in runs.items():
            r = run.result
            act = r.actuator(run.info.motors[leg])
            phid = np.asarray(act.rate) / (float(d.beta) if run.model == "II" else 1.0)
            ax[j].plot(act.leg_torque, phid, ".", ms=1.5, alpha=0.4, label=name)
        ax[j].set(xlabel="leg torque [N m]", ylabel="leg speed φ̇ [rad/s] (motor speed / β)", title=f"{leg} motor", xlim=(-130, 130))
    ax[0].legend(fontsize=7, markerscale=6)
    figs.append((fig, "Fig. 15 analogue: operating points (torque, speed) of the virtual motors over the four-quadrant saturation envelope (current limit and battery-voltage limit, Eqs. 6, 9–14)."))
    # Fig. 9: battery voltage and current; stance torque against Eq. 3
    fig, ax = plt.subplots(1, 2, figsize=(10, 3.4))
    name, run = list(runs.items())[-1]
    r = run.result
    a, b = _stride_window(run)
    a0 = max(0, a - (b - a))
    t = r.t[a0 : b + 1]
    bat = r.element("battery")
    ax[0].plot(t, bat.voltage[a0 : b + 1], label="terminal voltage [V]")
    ax0 = ax[0].twinx()
    ax0.plot(t, bat.current[a0 : b + 1], "C1", lw=0.8, label="current [A]")
    ax[0].set(xlabel="time [s]", ylabel="voltage [V]", title=f"battery ({name}), Eq. 9")
    ax0.set_ylabel("current [A]")
    act = r.actuator(run.info.motors["back"])
    st = r.controller("back_controller").state[:, 0]
    sel = st == 1
    ax[1].plot(r.t[sel], act.command[sel], ".", ms=2, label="commanded, Eq. 3 at 36 V (clipped, Eqs. 6–7)")
    ax[1].plot(r.t[sel], act.leg_torque[sel], ".", ms=2, label="delivered with battery sag (Eq. 14)")
    ax[1].set(xlabel="time [s]", ylabel="back leg torque [N m]", title="stance-retraction torque", xlim=(r.t[a0], r.t[b]))
    ax[1].legend(fontsize=7, markerscale=4)
    figs.append((fig, "Fig. 9 analogue: battery terminal voltage and total current; the stance-retraction torque commanded by Eq. 3 and delivered by the drive."))
    return figs


def _metrics_table(runs: dict[str, BoundRun]) -> pd.DataFrame:
    rows = []
    for key, label in METRIC_LABELS.items():
        rows.append({"metric": label, **{name: run.metrics.get(key, np.nan) for name, run in runs.items()}})
    return pd.DataFrame(rows)


def _fig16(runs):
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(1, 2, figsize=(10, 3.4))
    names = list(runs)
    speeds = [runs[n].metrics["forward_speed"] for n in names]
    ax[0].bar(names + ["paper Model I", "paper Model II", "experiment"], speeds + [D.SPEED_MODEL_I, D.SPEED_MODEL_II, D.SPEED_MEASURED],
              color=["C0", "C1", "0.6", "0.6", "k"][: len(names) + 3] if len(names) == 2 else None)
    ax[0].axhspan(D.SPEED_MEASURED - D.SPEED_MEASURED_SD, D.SPEED_MEASURED + D.SPEED_MEASURED_SD, color="k", alpha=0.1)
    ax[0].set(ylabel="forward speed [m/s]", title="speed: proleg vs seed 003 §5.2")
    ax[0].tick_params(axis="x", labelrotation=30, labelsize=8)
    keys = ["stride_frequency", "duty_factor_back", "duty_factor_front", "pitch_max", "pitch_min", "height_max", "height_min"]
    base = runs[names[0]].metrics
    x = np.arange(len(keys))
    for k, n in enumerate(names):
        vals = [runs[n].metrics[q] / base[q] if base[q] else np.nan for q in keys]
        ax[1].bar(x + 0.4 * k, vals, 0.4, label=n)
    ax[1].set_xticks(x + 0.2, [METRIC_LABELS[q].split(" [")[0] for q in keys], rotation=35, ha="right", fontsize=7)
    ax[1].set(ylabel=f"relative to {names[0]}", title="gait metrics (Fig. 16 quantities)")
    ax[1].legend(fontsize=7)
    return fig


def run_bound(out_dir, *, t_end: float = 8.0, low_speed: bool = True, sensitivity: bool = False, ranges: bool | tuple = False,
              table6: bool = False, grid: int = 4, xtol: float = 0.5, progress=None) -> Path:
    """Run the scenario (the decided reading of issue 44) and write ``scout2_bound_report.html``
    + Parquet into ``out_dir``.

    Stages (:mod:`proleg.papers.scout2_reading`): both models at Table 4 with Table 6 as printed
    (the stall); the leg damping calibrated on the robot's measured speed only, with Model II
    (``grid``, ``xtol``: :func:`~proleg.papers.scout2_reading.calibrate_leg_damping`); the
    predictions from the fitted value alone: both models at Table 4 and, with ``low_speed``, the
    set point for LOW_SPEED_TARGET by bisection for each model. Optional, at the fitted damping:
    ``ranges``, Model II at the ends of each unknown parameter's range (True: all of
    scout2_study.RANGES, or a tuple of their names); ``sensitivity``, the Table 5
    interpretations; ``table6``, Table 6 read per physical leg. Every run of the predictions is a
    point of the Fig. 7 analogue. ``progress``: None prints stages to stderr, False is silent."""
    from ..report.html import Report
    from . import scout2_reading as R

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    wall0 = time.perf_counter()
    if progress is None:
        import sys

        def progress(msg):
            print(f"[{time.perf_counter() - wall0:6.1f} s] {msg}", file=sys.stderr, flush=True)

    log = progress or (lambda msg: None)
    reading = R.run_reading(t_end, grid=grid, xtol=xtol, low_speed_target=LOW_SPEED_TARGET if low_speed else None, log=log)
    cal, pred, points = reading["calibration"], reading["prediction"], list(reading["points"])
    printed = {f"{k}, Table 6 as printed": v for k, v in reading["printed"].items()}
    if reading["stopped"]:
        return _stopped_report(out, reading, printed, t_end, wall0)
    runs = {"Model I": pred["Model I"], "Model II": pred["Model II"]}
    b_kw = {**NOMINAL_START, "leg_damping": cal.value}
    extra, targets = {}, {}
    for model, v in pred["low"].items():
        if isinstance(v, str):
            targets[model] = v
        else:
            targets[model], extra[f"Model {model}, low speed"] = v
    range_tab = []
    if ranges:
        log("Model II: ends of the unknown parameters' ranges (calibrated damping)")
        names = tuple(S.RANGES) if ranges is True else tuple(ranges)
        range_tab = S.range_rows(t_end, base=runs["Model II"], names=names, rows=points, **b_kw)
    sens = sensitivity_rows(t_end, runs["Model II"], rows=points, leg_damping=cal.value) if sensitivity else []
    per_runs = {}
    if table6:
        for model in ("I", "II"):
            log(f"Model {model}: Table 6 read per physical leg (the other reading), calibrated damping")
            sv = variant_system(runs[f"Model {model}"].system, model, per="physical", **b_kw)
            per_runs[f"Model {model}, per physical leg"] = r = scout2_bound(model, t_end, system=sv, per="physical", transient=t_end / 2, **b_kw)
            points.append(S.point_row(r, f"Model {model}, Table 6 per physical leg"))
    all_runs = {**printed, **runs, **extra, **per_runs}
    # data
    frames = []
    for name, run in all_runs.items():
        st = run.strides.copy()
        st.insert(0, "run", name)
        frames.append(st)
    pd.concat(frames, ignore_index=True).to_parquet(out / "strides.parquet")
    for model in ("I", "II"):
        runs[f"Model {model}"].result.to_parquet(out / f"model_{model}.parquet")
    pts = pd.DataFrame(points)
    pts.to_parquet(out / "fig7_points.parquet")
    sweep = pd.DataFrame(reading["speed_vs_damping"])
    sweep.to_parquet(out / "speed_vs_damping.parquet")
    metrics = pd.DataFrame({name: run.metrics for name, run in all_runs.items()}).T
    metrics.index.name = "run"
    metrics.astype(str).to_parquet(out / "metrics.parquet")
    cal_rows, pred_rows = _calibration_tables(cal, runs, extra)
    # report
    rep = Report("Scout II bounding: Model I vs Model II", "seed 003 (Poulakakis, Smith, Buehler 2005), proleg.robots.scout2")
    _introduction(rep, runs["Model II"], t_end)
    rep.add_heading("Calibrated on (not evidence)")
    rep.add_table(cal_rows, "The one calibrated parameter, its range (0.3–1.0 × Table 6), the one quantity it was fitted to and the fitted "
                  "model's value of it. Agreement here is by construction.", float_format="{:.4g}")
    rep.add_table(sweep, "Model II's speed at Table 4 against the leg damping: every evaluation of the fit (0 = no steady bound; the "
                  "range's top is Table 6 as printed).", float_format="{:.4g}")
    rep.add_heading("Predicted (held-out data only)")
    rep.add_table(pred_rows, "Predictions against data the model was not fitted on (held_out_score refuses the fitted speed). "
                  "Measured values: seed 003 §5.2 (speed, 10 runs), Fig. 7 / §3.3 (specific resistances).", float_format="{:.4g}")
    rep.add_heading("Table 6 as printed beside the calibrated damping")
    both_tab = _metrics_table({**printed, **runs})
    phases = pd.DataFrame({name: R.stance_phases(run) for name, run in {**printed, **runs}.items()}).reset_index(names="metric")
    rep.add_table(pd.concat([both_tab, phases], ignore_index=True), "Steady-state gait metrics (seed 003 Fig. 16 quantities), leg-state "
                  "timing and hip torques (Figs. 13–14; overshoot: how far the leg goes past its sweep limit in stance-brake) at Table 4, "
                  f"with Table 6's damping as printed ({D.LEG_DAMPING:g} N s/m) and calibrated ({cal.value:.4g} N s/m). Paper (reference): "
                  f"experiment {D.SPEED_MEASURED} ± {D.SPEED_MEASURED_SD} m/s, Model I {D.SPEED_MODEL_I} m/s, Model II {D.SPEED_MODEL_II} m/s.",
                  float_format="{:.4g}")
    rep.add_figure(_fig16(runs), "Fig. 16 analogue: forward speed of both models (calibrated damping) next to the paper's, and the gait metrics of Model II relative to Model I.")
    rep.add_figure(_fig7(pts), "Fig. 7 analogue: specific resistance against forward speed for every prediction run (Table 4 and the "
                   "low-speed set-point bisections), both models, with the paper's robot measurements (stars).")
    for fig, cap in bound_figures(runs):
        rep.add_figure(fig, cap)
    from ..report.animate import animation_iframe

    rep.add_heading("3D animation (Model II, the whole run)", level=3)
    r2 = runs["Model II"].result
    rep.add_html(animation_iframe(r2, height=420, max_frames=min(400, len(r2.t))))
    rep.add_text(findings(_summary(printed, runs, extra, targets, sens, range_tab, cal)))
    if extra:
        rep.add_heading("Low speed (seed 003 §5.3)")
        rep.add_table(_metrics_table(extra), "Runs at the set points found for the commanded low speed (touchdown offsets: "
                      + ", ".join(f"Model {k}: {v / deg:+.2f}°" if not isinstance(v, str) else f"Model {k}: not found" for k, v in targets.items())
                      + "). The paper: at 0.8 m/s Model I fails to bound and Model II converges to a period-two gait.", float_format="{:.4g}")
    if range_tab:
        rep.add_heading("The finding across the unknown parameters' ranges (Model II)")
        rep.add_table(pd.DataFrame(range_tab), "Model II with each unknown parameter at the ends of its justified range (scout2_data), the others nominal.", float_format="{:.4g}")
    if per_runs:
        rep.add_heading("Table 6: per physical or per virtual leg")
        rep.add_table(_metrics_table({**runs, **per_runs}), "The calibrated runs (Table 6 per virtual leg) next to the other reading, every Table 6 leg value per physical leg.", float_format="{:.4g}")
    if sens:
        rep.add_heading("Sensitivity to the interpreted Table 5 values (Model II)")
        rep.add_table(pd.DataFrame(sens), "Each garbled Table 5 value ×0.1 and ×10.", float_format="{:.4g}")
    rep.add_heading("Energy bookkeeping")
    eb = pd.DataFrame({name: energy_balance(run.result, run.info) for name, run in runs.items()})
    rep.add_table(eb, "Energies over the whole run [J]: battery = hip work + copper + gear losses (the gear losses include the load- and "
                  "speed-dependent drag); hip work (the integrator's 'input') = change of mechanical energy + dissipation (leg dampers and "
                  "leg friction, toe contacts, extension stops, belt, joint friction).", float_format="{:.5g}")
    rep.add_heading("Model")
    rep.add_parameters(runs["Model II"].info.parameters, "Model parameters and their sources (seed 003 tables; MODEL_DATA §4; interpretations and ranges in proleg.robots.scout2_data).")
    rep.add_table(pd.DataFrame([{"run": n, "wall time [s]": r.wall_time, "steps": r.result.stats.get("steps") if isinstance(r.result.stats, dict) else np.nan,
                                 "status": r.metrics.get("status")} for n, r in all_runs.items()]),
                  "Runs (wall time includes compilation for the first run of each model).", float_format="{:.4g}")
    rep.add_key_values({"total wall time [s]": f"{time.perf_counter() - wall0:.1f}", "output folder": str(out)}, "Run")
    return rep.save(out / "scout2_bound_report.html")


def _introduction(rep, run, t_end):
    """The report's 'What was simulated' and 'The reading' sections (``run``: a Model II run)."""
    rep.add_heading("What was simulated")
    p = run.info.params
    rep.add_text(
        f"The planar Scout II model of seed 003 (body, two virtual legs with compliant prismatic legs, toe contacts with friction "
        f"μ = {p.mu:g}), driven by the constant-touchdown-angle controller of §3.1 (Table 4 set points: touchdown {p.touchdown_front / deg:g}° "
        f"front, {p.touchdown_back / deg:g}° back, sweep limit {p.sweep_front / deg:g}°) through the saturated DC drives of Eqs. 3–14 on one shared battery. "
        f"**Model I** applies the delivered torque at the hip; **Model II** adds the hip unit of Fig. 10 (drive and driven gear "
        f"inertias tied by a gear Coupler of ratio β = {float(run.info.drive.beta):.1f}, the belt/backlash spring-damper, "
        f"joint stiction and damping) and the dissipation the paper names but did not model: stick–slip friction in the telescopic "
        f"legs growing with their side load (SlideFriction: μ_d = {p.leg_mu:g}, an estimate, not calibrated) and a gearbox drag of "
        f"{p.gear_drag * 1e3:g} mN m + {p.gear_viscous:g} N m s/rad per motor. Table 6 is read per {run.info.per} leg "
        f"({p.leg_stiffness:g} N/m). Both models start the same way: at rest in the standing posture (legs vertical, no speed), released "
        f"{1e3 * (p.height - p.leg_length):.0f} mm above touching; the controller brings them into the bound. Runs last {t_end:g} s; "
        f"strides from back-leg lift-off starting after {t_end / 2:g} s are the steady ones."
    )
    rep.add_heading("The reading: one quantity calibrated, the rest predicted")
    rep.add_text(
        "With Table 6 and the §3.1 controller as printed, neither model bounds at Table 4 (the stance-brake stall; the as-printed "
        "runs are shown below). Seed 003 §5.2 allows a calibrated simulation (its Model I 'might not even' "
        "reach cyclic motion 'with the set points and gains used in experiment'; Talebi et al. 2001 changed the sweep limits) and "
        "blames stiction and nonlinear damping in the telescopic legs, which its models leave out. So the leg damping (Table 6's b, "
        "per virtual leg, one value for both models) is treated as not known and fitted, with Model II, on one measurement only: the "
        "robot's forward speed at Table 4. Everything else is predicted from the fitted value and never refitted; if no damping "
        "in the range makes Model II bound at Table 4 there is nothing to fit, and the report says so and predicts nothing."
    )


def _stopped_report(out, reading, printed, t_end, wall0):
    """The report where no damping in the range makes Model II bound (issue 44: report and stop)."""
    from ..report.html import Report

    pd.DataFrame(reading["speed_vs_damping"]).to_parquet(out / "speed_vs_damping.parquet")
    metrics = pd.DataFrame({name: run.metrics for name, run in printed.items()}).T
    metrics.index.name = "run"
    metrics.astype(str).to_parquet(out / "metrics.parquet")
    rep = Report("Scout II bounding: Model I vs Model II", "seed 003 (Poulakakis, Smith, Buehler 2005), proleg.robots.scout2")
    _introduction(rep, printed["Model II, Table 6 as printed"], t_end)
    rep.add_heading("Calibrated on: nothing (no damping in the range bounds)")
    rep.add_text(reading["stopped"][0].upper() + reading["stopped"][1:] + ".")
    rep.add_table(pd.DataFrame(reading["speed_vs_damping"]), "Model II's speed at Table 4 against the leg damping: every evaluation "
                  "(speed 0 = no steady bound; 'mean speed' is the late average of a run that moves without a steady gait; the range's "
                  "top is Table 6 as printed).", float_format="{:.4g}")
    rep.add_table(_metrics_table(printed), "Table 6 as printed: gait metrics at Table 4.", float_format="{:.4g}")
    rep.add_text(findings({"printed_I": printed["Model I, Table 6 as printed"].metrics, "printed_II": printed["Model II, Table 6 as printed"].metrics,
                           "stopped": reading["stopped"]}))
    rep.add_key_values({"total wall time [s]": f"{time.perf_counter() - wall0:.1f}", "output folder": str(out)}, "Run")
    return rep.save(out / "scout2_bound_report.html")


SENSITIVITY = (("drive_gear_inertia", "drive gear inertia"), ("driven_gear_inertia", "driven gear inertia"),
               ("joint_damping", "joint damping"), ("belt_damping", "belt damper"))


def sensitivity_rows(t_end, base, factors=(0.1, 10.0), rows=None, **params) -> list[dict]:
    """Model II forward speed with each garbled Table 5 value scaled by ``factors`` (on
    ``base``'s compiled system; runs of ``t_end`` s, steady after t_end / 2)."""

    v0 = base.metrics["forward_speed"]
    out = []
    for pname, label in SENSITIVITY:
        nominal = getattr(base.info.params, pname)
        for f in factors:
            kw = {**NOMINAL_START, **params, pname: nominal * f}
            r = scout2_bound("II", t_end, system=variant_system(base.system, "II", **kw), transient=t_end / 2, **kw)
            v = r.metrics["forward_speed"]
            out.append({"parameter": label, "factor": f, "value": nominal * f, "forward speed [m/s]": v, "period": r.metrics["period"],
                        "fell": r.metrics["fell"], "speed change [%]": 100 * (v / v0 - 1)})
            if rows is not None:
                rows.append(S.point_row(r, f"Model II, {label} ×{f:g}"))
    return out


def _calibration_tables(cal, runs, extra):
    """("calibrated on" rows, "predicted" rows) DataFrames; the predicted rows go through
    held_out_score, which refuses the quantity the damping was fitted on (the speed)."""
    from ..identify.calibration import held_out_score
    from .scout2_reading import bound_speed

    cal_tab = pd.DataFrame([{**cal.row(), "× Table 6": cal.value / D.LEG_DAMPING, "quantity": cal.fitted_on[0],
                             "model at the fit": cal.achieved, "measured": cal.target}])
    pred, meas = {}, {}

    def speed(run):
        v = bound_speed(run)
        return v if v > 0 else np.nan

    pred["Model I forward speed at Table 4 [m/s]"] = speed(runs["Model I"])
    meas["Model I forward speed at Table 4 [m/s]"] = D.SPEED_MEASURED
    for model in ("I", "II"):
        m = runs[f"Model {model}"].metrics
        ok = bound_speed(runs[f"Model {model}"]) > 0
        for key, label, ref in (("specific_resistance_electrical", "electrical", D.SR_ELECTRICAL), ("specific_resistance_mechanical", "mechanical", D.SR_MECHANICAL)):
            q = f"Model {model} {label} specific resistance at Table 4"
            pred[q], meas[q] = (m[key] if ok else np.nan), ref
        low = extra.get(f"Model {model}, low speed")
        if low is not None:
            lm, ok = low.metrics, bound_speed(low) > 0
            for key, label, ref in (("specific_resistance_mechanical", "mechanical", D.SR_LOW_SPEED[1]), ("specific_resistance_electrical", "electrical", D.SR_LOW_SPEED[2])):
                q = f"Model {model} {label} specific resistance, low speed"
                pred[q], meas[q] = (lm[key] if ok else np.nan), ref
    rows = held_out_score([cal], pred, meas)
    v1, v2 = speed(runs["Model I"]), speed(runs["Model II"])
    slower = float(v2 < v1) if np.isfinite(v1) and np.isfinite(v2) else np.nan  # undefined unless both bound
    rows.append({"quantity": "Model II slower than Model I (1 = yes; paper's models: yes)", "predicted": slower, "measured": 1.0,
                 "error": slower - 1.0, "relative error [%]": np.nan})
    return cal_tab, pd.DataFrame(rows)


def _fig7(pts: pd.DataFrame):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from .scout2_study import PAPER_POINTS

    fig, ax = plt.subplots(1, 2, figsize=(10, 3.6))
    for j, (col, k) in enumerate((("SR mechanical", 1), ("SR electrical", 2))):
        for m, mk in (("I", "o"), ("II", "s")):
            sel = pts[(pts["model"] == m) & np.isfinite(pts["speed [m/s]"])] if len(pts) else pts
            ax[j].plot(sel["speed [m/s]"], sel[col], mk, ms=4, alpha=0.7, label=f"Model {m}")
        ax[j].plot([pp[0] for pp in PAPER_POINTS], [pp[k] for pp in PAPER_POINTS], "k*", ms=10, label="robot (seed 003 Fig. 7)")
        ax[j].set(xlabel="forward speed [m/s]", ylabel=f"specific resistance, {col.split()[1]} [-]", xlim=(0.6, 2.0))
    ax[0].legend(fontsize=7)
    return fig


def _summary(printed, runs, extra, targets, sens, range_tab, cal) -> dict:
    """The numbers the findings are written from (all computed by the run)."""
    from .scout2_reading import stance_phases

    out = {"printed_I": printed["Model I, Table 6 as printed"].metrics, "printed_II": printed["Model II, Table 6 as printed"].metrics,
           "I": runs["Model I"].metrics, "II": runs["Model II"].metrics, "calibrated": cal.value, "calibrated_ratio": cal.value / D.LEG_DAMPING,
           "calibrated_speed": cal.achieved, "calibration_met": abs(cal.achieved - cal.target) <= D.SPEED_MEASURED_SD,
           "overshoot_I": stance_phases(runs["Model I"])["back overshoot [deg]"], "low": {}, "sens": sens, "ranges": range_tab}
    for k, r in extra.items():
        out["low"][k] = r.metrics
    out["targets"] = {k: (v if isinstance(v, str) else float(v)) for k, v in targets.items()}
    return out


def _gait(name, m):
    if m["fell"]:
        return f"{name} falls."
    if m.get("stalled"):
        return (f"{name} stalls: it ends standing on both legs held in stance-brake, which only lift-off ends "
                f"(the longest stance-brake lasts {m['longest_brake']:.2f} s; bench/scout2_stall.py).")
    if m["strides"] == 0 or not np.isfinite(m["forward_speed"]):
        return f"{name} stops bounding (no steady stride)."
    if m["period"] not in (1, 2):
        return (f"{name} does not settle into a steady gait (period detector 0): it stalls and restarts, "
                f"{m['forward_speed']:.3f} m/s on average over the late strides.")
    per = {1: "period one", 2: "period two"}[m["period"]]
    return f"{name} bounds ({per}) at {m['forward_speed']:.3f} m/s, electrical specific resistance {m['specific_resistance_electrical']:.3g}."


def findings(s: dict) -> str:
    """Findings prose written from :func:`_summary`'s numbers; the paper's values enter only
    as cited references (scout2_data), so every other number is computed by the run."""
    vm = D.SPEED_MEASURED
    lines = ["**Findings.**", "With Table 6 as printed:", _gait("Model I", s["printed_I"]), _gait("Model II", s["printed_II"])]
    if s.get("stopped"):
        return " ".join(lines + [s["stopped"][0].upper() + s["stopped"][1:] + "."])
    lines.append(
        f"Calibrated on the robot's {vm} m/s with Model II, the leg damping is {s['calibrated']:.3g} N s/m per virtual leg "
        f"({s['calibrated_ratio']:.2f} × Table 6), where Model II bounds at {s['calibrated_speed']:.3f} m/s"
        + (" (within the measured spread)." if s["calibration_met"] else " (the closest the range gives: not within the measured spread).")
        + " Predicted with that damping, nothing refitted:"
    )
    lines += [_gait("Model I", s["I"]), _gait("Model II", s["II"])]
    ov = s.get("overshoot_I", np.nan)
    if np.isfinite(ov):
        lines.append(f"Model I's brake holds its back leg within {ov:.1f}° past the sweep limit (seed 003 §5.2 says the paper's Model I cannot hold it).")
    v1, v2 = s["I"]["forward_speed"], s["II"]["forward_speed"]
    if np.isfinite(v1) and np.isfinite(v2) and not s["I"]["fell"] and not s["II"]["fell"]:
        order = "slower" if v2 < v1 else "faster"
        lines.append(
            f"Model II is {order} than Model I ({v2:.3f} against {v1:.3f} m/s); in the paper it is slower ({D.SPEED_MODEL_II} against "
            f"{D.SPEED_MODEL_I} m/s). Model I is {100 * (v1 / vm - 1):+.0f} % from the robot's speed (the paper's Model I: "
            f"{100 * (D.SPEED_MODEL_I / vm - 1):+.0f} %)."
        )
    for k, m in s["low"].items():
        lines.append(_gait(k, m))
    for k, v in s.get("targets", {}).items():
        if isinstance(v, str):
            lines.append(f"Model {k}: no set point gives the commanded {LOW_SPEED_TARGET} m/s within the searched touchdown offsets.")
    sens = [r for r in s.get("sens", []) if np.isfinite(r.get("speed change [%]", np.nan))]
    if sens:
        big = max(sens, key=lambda r: abs(r["speed change [%]"]))
        lines.append(f"Of the Table 5 interpretations, the {big['parameter']} ×{big['factor']:g} moves Model II's speed most: {big['speed change [%]']:+.1f} %.")
    rng = [r for r in s.get("ranges", []) if np.isfinite(r.get("speed [m/s]", np.nan))]
    if rng:
        lo, hi = min(r["speed [m/s]"] for r in rng), max(r["speed [m/s]"] for r in rng)
        lines.append(f"Across the unknown parameters' ranges Model II's speed spans {lo:.3f}–{hi:.3f} m/s"
                     + (f" (Model I: {v1:.3f} m/s)." if np.isfinite(v1) else "."))
    return " ".join(lines)
