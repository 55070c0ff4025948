"""The ``scout2-bound`` scenario: Model I and Model II from the same standing start, the leg-friction
calibration kept apart from validation, the low-speed set points found for a commanded speed,
the finding across the unknown parameters' ranges, the Table 6 readings, the Table 5
sensitivity, the Fig. 7 analogue, a self-contained HTML report and Parquet (seed 003, issue 31).

Everything runs on two compiled systems (Model I, Model II): the variants change parameters
only, so they reuse them (:func:`proleg.papers.scout2_study.variant_system`). The findings prose
is written by :func:`findings` from the run's numbers; the paper's values enter only as cited
references (scout2_data).
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


def run_bound(out_dir, *, t_end: float = 6.0, low_speed: bool = True, sensitivity: bool = True, calibrate: bool = True,
              ranges: bool | tuple = True, table6: bool = True, progress=None) -> Path:
    """Run the scenario and write ``scout2_bound_report.html`` + Parquet into ``out_dir``.

    Both models start from standing (NOMINAL_START over Scout2Params). Stages, each optional:
    the nominal runs; ``calibrate``: Model II's leg friction fitted on the electrical specific
    resistance at the nominal set point only (then used by every later Model II run);
    ``low_speed``: for each model the set point that gives LOW_SPEED_TARGET by bisection;
    ``ranges``: Model II at the ends of each unknown parameter's range (True: all of
    scout2_study.RANGES, or a tuple of their names); ``sensitivity``: the
    Table 5 interpretations; ``table6``: the per-virtual-leg reading. Every run is a point of
    the Fig. 7 analogue. ``progress``: None prints stages to stderr, False is silent."""
    from ..report.html import Report

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    wall0 = time.perf_counter()
    if progress is None:
        import sys

        def progress(msg):
            print(f"[{time.perf_counter() - wall0:6.1f} s] {msg}", file=sys.stderr, flush=True)

    log = progress or (lambda msg: None)
    points: list[dict] = []
    runs = {}
    for model in ("I", "II"):
        log(f"Model {model}: compiling and running {t_end:g} s from standing")
        runs[f"Model {model}"] = scout2_bound(model, t_end, transient=t_end / 2, **NOMINAL_START)
        points.append(S.point_row(runs[f"Model {model}"], f"Model {model}, nominal"))
    base = {m: runs[f"Model {m}"] for m in ("I", "II")}
    cal, cal_hist, cal_err = None, [], None
    mu_kw = {}
    if calibrate:
        log("Model II: calibrating the leg friction on one specific resistance")
        from ..errors import ConvergenceError

        try:
            cal, cal_runs = S.calibrate_leg_friction(t_end, base=base["II"], rows=points, history=cal_hist, **NOMINAL_START)
            mu_kw = {"leg_mu": cal.value}
            runs["Model II, calibrated"] = cal_runs[min(cal_runs, key=lambda m: abs(m - cal.value))]
        except ConvergenceError as e:
            cal_err = str(e)
    extra = {}
    targets = {}
    if low_speed:
        from ..errors import ConvergenceError

        for model in ("I", "II"):
            log(f"Model {model}: set point for {LOW_SPEED_TARGET:g} m/s (bisection)")
            kw = {**NOMINAL_START, **(mu_kw if model == "II" else {})}
            try:
                delta, run = S.setpoint_for_speed(model, LOW_SPEED_TARGET, t_end, base=base[model], rows=points, **kw)
                extra[f"Model {model}, low speed"] = run
                targets[model] = delta
            except ConvergenceError as e:
                targets[model] = str(e)
    range_tab = []
    if ranges:
        log("Model II: ends of the unknown parameters' ranges")
        names = tuple(S.RANGES) if ranges is True else tuple(ranges)
        range_tab = S.range_rows(t_end, base=base["II"], names=names, rows=points, **{**NOMINAL_START, **mu_kw})
    sens = []
    if sensitivity:
        log("Model II: Table 5 interpretations ×0.1, ×10")
        sens = sensitivity_rows(t_end, base["II"], rows=points, **mu_kw)
    per_runs = {}
    if table6:
        for model in ("I", "II"):
            log(f"Model {model}: Table 6 read per physical leg (the other reading)")
            kw = {**NOMINAL_START, **(mu_kw if model == "II" else {})}
            sv = variant_system(base[model].system, model, per="physical", **kw)
            per_runs[f"Model {model}, per physical leg"] = r = scout2_bound(model, t_end, system=sv, per="physical", transient=t_end / 2, **kw)
            points.append(S.point_row(r, f"Model {model}, Table 6 per physical leg"))
        for model in ("I", "II"):
            log(f"Model {model}: per physical leg with the damping halved (the earlier mixed reading)")
            kw = {**NOMINAL_START, **(mu_kw if model == "II" else {}), "leg_damping": D.LEG_DAMPING / 2}
            sv = variant_system(base[model].system, model, per="physical", **kw)
            per_runs[f"Model {model}, damping halved"] = r = scout2_bound(model, t_end, system=sv, per="physical", transient=t_end / 2, **kw)
            points.append(S.point_row(r, f"Model {model}, per physical leg, damping halved"))
    all_runs = {**runs, **extra, **per_runs}
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
    metrics = pd.DataFrame({name: run.metrics for name, run in all_runs.items()}).T
    metrics.index.name = "run"
    metrics.astype(str).to_parquet(out / "metrics.parquet")
    # calibration and validation tables
    m2c = runs.get("Model II, calibrated", runs["Model II"]).metrics
    cal_rows, pred_rows = _calibration_tables(cal, cal_err, runs, extra, m2c)
    # report
    rep = Report("Scout II bounding: Model I vs Model II", "seed 003 (Poulakakis, Smith, Buehler 2005), proleg.robots.scout2")
    rep.add_heading("What was simulated")
    p = runs["Model II"].info.params
    rep.add_text(
        f"The planar Scout II model of seed 003 (body, two virtual legs with compliant prismatic legs, toe contacts with friction "
        f"μ = {p.mu:g}), driven by the constant-touchdown-angle controller of §3.1 (Table 4 set points: touchdown {p.touchdown_front / deg:g}° "
        f"front, {p.touchdown_back / deg:g}° back, sweep limit {p.sweep_front / deg:g}°) through the saturated DC drives of Eqs. 3–14 on one shared battery. "
        f"**Model I** applies the delivered torque at the hip; **Model II** adds the hip unit of Fig. 10 (drive and driven gear "
        f"inertias tied by a gear Coupler of ratio β = {float(runs['Model I'].info.drive.beta):.1f}, the belt/backlash spring-damper, "
        f"joint stiction and damping) and the dissipation the paper names but did not model: stick–slip friction in the telescopic "
        f"legs growing with their side load (SlideFriction: μ_d = {p.leg_mu:g} before calibration, bushing overlap {p.leg_overlap:g} m "
        f"centred {p.leg_bearing:g} m below the hip) and a gearbox drag of {p.gear_drag * 1e3:g} mN m + {p.gear_viscous:g} N m s/rad per "
        f"motor that makes the efficiency depend on load, speed and the direction of power flow. Table 6's leg damping is used as "
        f"printed and, as seed 003 §2.3, Table 2 and §5.1 imply, per {runs['Model II'].info.per} leg ({p.leg_stiffness:g} N/m, {p.leg_damping:g} N s/m). Both models start the same way: at rest in the standing posture "
        f"(legs vertical, no speed), released {1e3 * (p.height - p.leg_length):.0f} mm above touching; the controller "
        f"brings them into the bound. Runs last {t_end:g} s; strides from back-leg lift-off starting after {t_end / 2:g} s are the steady ones."
    )
    rep.add_heading("Calibrated on (not evidence)")
    if cal_rows is not None:
        rep.add_table(cal_rows, "The one calibrated parameter, its justified range and the one quantity it was fitted to, with the "
                      "fitted model's value of that quantity. Agreement here is by construction.", float_format="{:.4g}")
    else:
        rep.add_text("No parameter was calibrated in this run" + (f": {cal_err}" if cal_err else "."))
    rep.add_heading("Predicted (held-out data only)")
    if pred_rows is not None and len(pred_rows):
        rep.add_table(pred_rows, "Predictions against data the model was not fitted on (held_out_score refuses fitted quantities). "
                      "Measured values: seed 003 §5.2 (speed, 10 runs), Fig. 7 / §3.3 (specific resistances).", float_format="{:.4g}")
    rep.add_heading("Gait metrics against the paper")
    rep.add_table(_metrics_table(runs), "Steady-state gait metrics (seed 003 Fig. 16 quantities) of the nominal runs and of Model II "
                  f"with the calibrated leg friction. Paper (reference): experiment {D.SPEED_MEASURED} ± {D.SPEED_MEASURED_SD} m/s, Model I "
                  f"{D.SPEED_MODEL_I} m/s, Model II {D.SPEED_MODEL_II} m/s.", float_format="{:.4g}")
    both = {"Model I": runs["Model I"], "Model II": runs.get("Model II, calibrated", runs["Model II"])}
    rep.add_figure(_fig16(both), "Fig. 16 analogue: forward speed of both models next to the paper's, and the gait metrics of Model II relative to Model I.")
    rep.add_figure(_fig7(pts), "Fig. 7 analogue: specific resistance against forward speed for every run of this report (set-point "
                   "searches, calibration, ranges), both models, with the paper's robot measurements (stars).")
    for fig, cap in bound_figures(both):
        rep.add_figure(fig, cap)
    from ..report.animate import animation_iframe

    rep.add_heading("3D animation (Model II, the whole run)", level=3)
    r2 = both["Model II"].result
    rep.add_html(animation_iframe(r2, height=420, max_frames=min(400, len(r2.t))))
    rep.add_text(findings(_summary(runs, extra, targets, sens, range_tab, cal)))
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
        rep.add_table(_metrics_table({**{k: runs[k] for k in ("Model I", "Model II")}, **per_runs}), "The nominal runs (Table 6 per virtual leg, the reading the seed's text supports) next to the other reading, every Table 6 leg value per physical leg (a virtual leg twice each), and that reading with the damping halved (the mixed reading that let Model I bound before issue 31).", float_format="{:.4g}")
    if sens:
        rep.add_heading("Sensitivity to the interpreted Table 5 values (Model II)")
        rep.add_table(pd.DataFrame(sens), "Each garbled Table 5 value ×0.1 and ×10.", float_format="{:.4g}")
    rep.add_heading("Energy bookkeeping")
    eb = pd.DataFrame({name: energy_balance(run.result, run.info) for name, run in both.items()})
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


def _calibration_tables(cal, cal_err, runs, extra, m2c):
    """("calibrated on" rows, "predicted" rows) DataFrames; the predicted rows go through
    held_out_score, which refuses the quantity the friction was fitted on."""
    from ..identify.calibration import held_out_score

    cal_tab = None
    if cal is not None:
        q = cal.fitted_on[0]
        cal_tab = pd.DataFrame([{**cal.row(), "quantity": q, "model at the fit": m2c["specific_resistance_electrical"], "measured": D.SR_ELECTRICAL}])
    pred, meas = {}, {}
    pred["forward speed, nominal set point [m/s]"] = m2c["forward_speed"]
    meas["forward speed, nominal set point [m/s]"] = D.SPEED_MEASURED
    pred["mechanical specific resistance, nominal set point"] = m2c["specific_resistance_mechanical"]
    meas["mechanical specific resistance, nominal set point"] = D.SR_MECHANICAL
    low = extra.get("Model II, low speed")
    if low is not None:
        lm = low.metrics
        pred["mechanical specific resistance, low speed"] = lm["specific_resistance_mechanical"]
        meas["mechanical specific resistance, low speed"] = D.SR_LOW_SPEED[1]
        pred["electrical specific resistance, low speed"] = lm["specific_resistance_electrical"]
        meas["electrical specific resistance, low speed"] = D.SR_LOW_SPEED[2]
    if cal is None:
        pred["electrical specific resistance at the nominal set point"] = m2c["specific_resistance_electrical"]
        meas["electrical specific resistance at the nominal set point"] = D.SR_ELECTRICAL
    rows = held_out_score([cal] if cal is not None else [], pred, meas)
    v1 = runs["Model I"].metrics["forward_speed"]
    both = np.isfinite(v1) and np.isfinite(m2c["forward_speed"])
    slower = float(m2c["forward_speed"] < v1) if both else np.nan  # undefined unless both bound
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


def _summary(runs, extra, targets, sens, range_tab, cal) -> dict:
    """The numbers the findings are written from (all computed by the run)."""
    m1, m2 = runs["Model I"].metrics, runs["Model II"].metrics
    m2c = runs.get("Model II, calibrated", runs["Model II"]).metrics
    out = {"I": m1, "II": m2, "II_cal": m2c, "calibrated": None if cal is None else cal.value, "low": {}, "sens": sens, "ranges": range_tab}
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
    lines = ["**Findings.**", _gait("Model I", s["I"]), _gait("Model II (nominal leg friction)", s["II"])]
    if s["calibrated"] is not None:
        lines.append(f"With the leg friction calibrated to μ_d = {s['calibrated']:.3g}: " + _gait("Model II", s["II_cal"]))
    v1, v2 = s["I"]["forward_speed"], s["II_cal"]["forward_speed"]
    vm = D.SPEED_MEASURED
    if np.isfinite(v1) and np.isfinite(v2):
        order = "slower" if v2 < v1 else "faster"
        lines.append(
            f"Model II is {order} than Model I ({v2:.3f} against {v1:.3f} m/s); in the paper it is slower ({D.SPEED_MODEL_II} against "
            f"{D.SPEED_MODEL_I} m/s). Against the robot's {vm} m/s the models here are {100 * (v1 / vm - 1):+.0f} % (Model I) and "
            f"{100 * (v2 / vm - 1):+.0f} % (Model II); the paper's are {100 * (D.SPEED_MODEL_I / vm - 1):+.0f} % and "
            f"{100 * (D.SPEED_MODEL_II / vm - 1):+.0f} %. Model II is {100 * (v2 / D.SPEED_MODEL_II - 1):+.0f} % from the paper's Model II speed."
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
