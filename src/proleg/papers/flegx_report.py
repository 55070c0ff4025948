"""FLEGX scenarios (seed 002): ``proleg run flegx-jump``, ``flegx-machinery``, ``flegx-study``.

Each writes Parquet tables and a self-contained HTML report into its output folder.
flegx-jump and flegx-machinery run their few jumps in worker processes (one per core; each
jump is its own model: its link, gears and motion law are compiled into it); flegx-study runs
:class:`proleg.study.Study` groups (``flegx_study``: one compilation per compiled shape, the
variants as parameter tables, a resumable Parquet store).

Figures. flegx-jump: (1) free-end transverse displacement and knee joint torque of the three
link models (seed 002 Fig. 3 analogue), (2) von Mises stress at the clamped end over time,
(3) guide height and ground force, and the CB run's 3D animation. flegx-machinery: (1) hip and
knee worm (motor) torques (Fig. 4 top), (2) clamp stress and free-end displacement (Fig. 4
middle, bottom), (3) hip and knee motor power with worm and ideal gears. flegx-study: jump
height and stress up to take-off per configuration and link case (PRBM).
"""

from __future__ import annotations

import os
import time
from pathlib import Path

import numpy as np
import pandas as pd

from ..errors import ModelError
from ..robots import flegx_data as D

COLORS = {"rigid": "#444444", "prbm": "#d62728", "cb": "#1f77b4", "ideal": "#2ca02c", "worm": "#9467bd"}
LABELS = {"rigid": "rigid link", "prbm": "PRBM (Eqs. 8-11)", "cb": "Craig-Bampton (LFM)", "ideal": "ideal gears", "worm": "worm gears (η ≈ 0.60)"}


def _job(kw: dict) -> dict:
    """One jump (module-level so that worker processes can run it); picklable output only."""
    from .flegx_jump import flegx_jump

    t0 = time.perf_counter()
    kw = dict(kw)
    tag, animate = kw.pop("tag"), kw.pop("animate", False)
    j = flegx_jump(**kw)
    info = j.model.flegx
    html = None
    if animate:  # the 3D animation as an <iframe> (a string: picklable from a worker process)
        from types import SimpleNamespace

        from ..report.animate import animation_iframe

        if info.link_model == "cb":  # the strip as its undeformed L × W × t plate from the clamped frame node
            L, W, t = info.link_geometry
            X_PV = np.eye(4)
            X_PV[0, 3] = 0.5 * L
            j.model.urdf = SimpleNamespace(visuals=[SimpleNamespace(part="link", kind="box", X_PV=X_PV, size=(L, W, t), color=None)])
        html = animation_iframe(j.result, model=j.model, title=f"FLEGX jump, {LABELS.get(tag, tag)}", max_frames=650)
    return {"tag": tag, "metrics": j.metrics, "animation": html, "series": pd.DataFrame(j.series), "parameters": info.parameters,
            "wall": time.perf_counter() - t0, "sim": j.wall_s, "steps": j.result.stats["steps"],
            "masses": info.masses, "prbm": None if info.prbm is None else info.prbm.as_dict(),
            "frequencies_hz": None if not info.cb else np.asarray(info.cb["body"].frequencies_hz[:4]).tolist()}


def run_jobs(jobs: list[dict], workers: int | None = None, progress: bool = True) -> list[dict]:
    """Run :func:`_job` for every job dict (``tag`` + :func:`flegx_jump` keywords), ``workers``
    processes (default: the cores this process may use); results in the jobs' order."""
    import concurrent.futures as cf
    import multiprocessing as mp

    from .flegx_study import default_workers

    workers = workers or default_workers(len(jobs))
    out = {}
    t0 = time.perf_counter()
    if workers == 1:
        for k, job in enumerate(jobs):
            out[k] = _job(job)
            if progress:
                print(f"[{k + 1}/{len(jobs)}] {job['tag']}: {out[k]['wall']:.1f} s", flush=True)
    else:
        with cf.ProcessPoolExecutor(workers, mp_context=mp.get_context("spawn")) as ex:
            futs = {ex.submit(_job, job): k for k, job in enumerate(jobs)}
            for n, f in enumerate(cf.as_completed(futs), 1):
                k = futs[f]
                out[k] = f.result()
                if progress:
                    print(f"[{n}/{len(jobs)}] {jobs[k]['tag']}: {out[k]['wall']:.1f} s "
                          f"(elapsed {time.perf_counter() - t0:.0f} s)", flush=True)
    return [out[k] for k in range(len(jobs))]


def _figure(nrows=1, ncols=1, width=7.5, height=2.4, sharex=True):
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width, height * nrows), layout="constrained")
    axes = fig.subplots(nrows, ncols, sharex=sharex, squeeze=False)
    for ax in axes.ravel():
        ax.grid(True, alpha=0.3)
    return fig, axes


def channels_figure(outs: list[dict], channels, t_range=None, key="tag"):
    """Time histories of several channels, one panel each, every run overlaid."""
    fig, axes = _figure(len(channels))
    for ax, (col, label, scale) in zip(axes[:, 0], channels, strict=True):
        for o in outs:
            df = o["series"]
            ax.plot(df["time [s]"], df[col] * scale, lw=1.2, color=COLORS.get(o[key]), label=LABELS.get(o[key], o[key]))
        ax.set_ylabel(label)
    if t_range:
        axes[0, 0].set_xlim(*t_range)
    axes[-1, 0].set_xlabel("time [s]")
    axes[0, 0].legend(fontsize="small", frameon=False)
    return fig


def _metrics_table(outs, key="tag") -> pd.DataFrame:
    rows = []
    for o in outs:
        m = o["metrics"]
        rows.append({
            "model": LABELS.get(o[key], o[key]), "jump height [mm]": m["jump_height"] * 1e3,
            "foot clearance [mm]": m["foot_clearance"] * 1e3, "flight rise [mm]": m["flight_rise"] * 1e3, "take-off [s]": m["take_off_time"],
            "landing [s]": m["landing_time"], "take-off velocity [m/s]": m["take_off_velocity"],
            "max stress, take-off [MPa]": m["max_stress_takeoff"] / 1e6, "max stress, all [MPa]": m["max_stress"] / 1e6,
            "tip displacement [mm]": m["tip_displacement"] * 1e3,
            "peak hip torque joint / worm [N m]": f"{m['peak_hip_torque']:.1f} / {m['peak_hip_torque_worm']:.2f}",
            "peak knee torque joint / worm [N m]": f"{m['peak_knee_torque']:.1f} / {m['peak_knee_torque_worm']:.2f}",
            "motor energy [J]": m["motor_energy"], "motor work > 0 [J]": m["motor_work_positive"], "mesh loss [J]": m["mesh_loss_energy"],
            "steps": o["steps"], "wall [s]": o["wall"],
        })
    return pd.DataFrame(rows)


def _long(outs, key="tag"):
    frames = []
    for o in outs:
        df = o["series"].copy()
        df.insert(0, "run", o[key])
        frames.append(df)
    return pd.concat(frames, ignore_index=True)


def _law_rows(**fields):
    """The law's parameter rows; ``fields`` override MotionLaw's defaults (e.g. a push found by a search)."""
    from .flegx_jump import MotionLaw

    law = MotionLaw(**fields)
    d = np.rad2deg
    return [
        ("stand / squat / extend θ1", [d(law.stand[0]), d(law.squat[0]), d(law.extend[0])], "deg", "assumed (seed 002 prints no angles)"),
        ("stand / squat / extend θ2", [d(law.stand[1]), d(law.squat[1]), d(law.extend[1])], "deg", "assumed"),
        ("settle, squat, hold, push, retract", [law.t_settle, law.t_squat, law.t_hold, law.t_push, law.t_retract], "s",
         "assumed; cubic STEP, seed 002 Eq. 18" + ("; push: at the limits (flegx_codesign.push_at_limits)" if "t_push" in fields else "")),
    ]


# ------------------------------------------------------------------------------------------
# flegx-jump
# ------------------------------------------------------------------------------------------
#: the push grid [s] flegx-jump searches for the push at the limits (push_at_limits interpolates
#: between its points; the stress falls as the push lengthens)
JUMP_PUSHES = (0.16, 0.20, 0.25, 0.30, 0.38, 0.45)


def run_jump(out_dir="results/flegx-jump", progress: bool = True, workers: int | None = None) -> Path:
    """No. 4 with link case 2: rigid vs PRBM vs CB link, same motion law (seed 002 Fig. 3).

    The law is not picked by hand: its push duration is the shortest at which the PRBM leg stays
    within the limits up to take-off (520 MPa, Table I's stress; 77 N m, the wheel rating:
    :func:`~proleg.papers.flegx_codesign.push_at_limits` on :data:`JUMP_PUSHES`), the squat and
    extended pose flegx_jump's documented ones; the rigid and CB legs then run that law, as seed
    002 §III.A compares its PRBM and LFM "imposing the same motion laws"."""
    from ..report.html import Report
    from .flegx_codesign import push_at_limits

    wall0 = time.perf_counter()
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    found = push_at_limits(4, 2, "prbm", pushes=JUMP_PUSHES, store=out / "push")
    if "t_push_s" not in found:
        raise ModelError(f"flegx-jump: no push of {JUMP_PUSHES} s keeps the PRBM leg within the limits ({found['binding']}); "
                         "lengthen JUMP_PUSHES.")
    t_push = float(found["t_push_s"])
    jobs = [dict(tag=lm, configuration=4, link_case=2, link_model=lm, dt_output=1e-3, animate=lm == "cb", t_push=t_push)
            for lm in ("cb", "prbm", "rigid")]
    outs = run_jobs(jobs, workers, progress)
    outs = sorted(outs, key=lambda o: ("rigid", "prbm", "cb").index(o["tag"]))
    tab = _metrics_table(outs)
    _long(outs).to_parquet(out / "jump.parquet", index=False)
    tab.to_parquet(out / "metrics.parquet", index=False)
    push = outs[-1]["metrics"]
    t_lo = 0.15 + 0.8  # end of the squat
    win = (t_lo, t_lo + 1.0)
    rep = Report("FLEGX countermovement jump: rigid vs PRBM vs Craig-Bampton link",
                 "configuration No. 4, link case 2 (250 × 70 × 3 mm AISI 304), ideal gears; seed 002 §III-IV; proleg")
    rep.add_heading("What was simulated")
    rep.add_text(
        "The FLEGX leg (seed 002) on its vertical guide stands still, squats, and pushes off with cubic STEP laws "
        "(Eq. 18) imposed on the hip and, through the two tendons, the knee wheel; after take-off the leg returns "
        "to the standing pose for the landing. The lower leg is modelled three ways: rigid, the dynamic PRB 1R link "
        "(Eqs. 8-11) and a Craig-Bampton modal body (Eqs. 12-15, the paper's LFM) with stress recovery at the "
        "clamped end. Jump height = the guide's highest airborne position above its standing height (flegx_jump "
        "docstring); foot clearance and the guide's rise from take-off are listed beside it.")
    rep.add_heading("Results")
    rep.add_table(tab, "Jump metrics (seed 002: PRBM ≈ 60 mm vs LFM 50 mm; Table I No. 4: 104.1 mm, 530.68 MPa).",
                  float_format="{:.4g}", index=False)
    figs = [
        (channels_figure(outs, [("tip_displacement [m]", "tip transverse [mm]", 1e3), ("knee_joint_torque [N m]", "knee torque [N m]", 1.0)], win),
         "Seed 002 Fig. 3 analogue: free-end transverse displacement and knee joint torque."),
        (channels_figure(outs, [("clamp_stress [Pa]", "von Mises at clamp [MPa]", 1e-6)], win),
         "Stress at the clamped end over time (CB: stress recovery; rigid/PRBM: clamp reaction, N/A + M/(W t²/6)). 510-530 MPa: ultimate strength."),
        (channels_figure(outs, [("guide_z [m]", "guide height [m]", 1.0), ("ground_force [N]", "ground force [N]", 1.0)], win),
         "Guide (hip) height and ground reaction."),
    ]
    for k, (fig, cap) in enumerate(figs, 1):
        fig.savefig(out / f"fig{k}.png", dpi=110, bbox_inches="tight")
        rep.add_figure(fig, cap)
    rep.add_text(f"The law's push, {t_push:.3f} s, is the shortest at which the PRBM leg keeps within the limits up to take-off "
                 f"(binding: {found['binding']}, {found['stress_MPa']:.0f} MPa, hip {found['peak_hip_Nm']:.1f} N m, knee "
                 f"{found['peak_knee_Nm']:.1f} N m; flegx_codesign.push_at_limits over {len(JUMP_PUSHES)} pushes, interpolated; "
                 f"{'monotone' if found.get('monotone') else 'not monotone: the interpolation is approximate'} on the grid).")
    rep.add_text(_jump_findings(outs))
    rep.add_heading("3D animation (Craig-Bampton link)")
    rep.add_text("The whole run (stand, squat, push, flight, landing) of the CB model; drag to orbit, the slider scrubs time. "
                 "The strip is drawn undeformed (its modal deformation, tens of mm at the tip, is in the figures above); "
                 "the other parts as boxes of their inertia, the foot contact force as an arrow.")
    rep.add_html(next(o["animation"] for o in outs if o["tag"] == "cb"))
    rep.add_heading("Model")
    pr = next(o["prbm"] for o in outs if o["tag"] == "prbm")
    fr = next(o["frequencies_hz"] for o in outs if o["tag"] == "cb")
    rep.add_parameters(outs[-1]["parameters"] + _law_rows(t_push=t_push) + [
        ("PRBM γ, K_t, C_t, J", [pr["gamma"], pr["K_t"], pr["C_t"], pr["J"]], "-, N m/rad, N m s/rad, kg m²", "seed 002 Eqs. 8-11"),
        ("CB link deformation frequencies (clamped at the frame node)", fr, "Hz", "beam FE, Craig-Bampton"),
    ], "Parameters and sources (MODEL_DATA §3).")
    rep.add_key_values({"total wall time [s]": f"{time.perf_counter() - wall0:.1f}", "take-off of the CB model [s]": f"{push['take_off_time']:.3f}",
                        "output folder": str(out)}, "Run")
    return rep.save(out / "flegx_jump_report.html")


def _jump_findings(outs) -> str:
    m = {o["tag"]: o["metrics"] for o in outs}
    lines = [f"- {LABELS[k]}: jump {v['jump_height'] * 1e3:.1f} mm, max stress {v['max_stress'] / 1e6:.0f} MPa "
             f"({v['max_stress_takeoff'] / 1e6:.0f} MPa up to take-off), tip {v['tip_displacement'] * 1e3:.1f} mm."
             for k, v in m.items()]
    if "prbm" in m and "cb" in m and m["cb"]["jump_height"] > 0:
        lines.append(f"- PRBM / CB jump ratio {m['prbm']['jump_height'] / m['cb']['jump_height']:.2f} (seed 002: 60 / 50 = 1.20).")
    if "rigid" in m and m["rigid"]["jump_height"] == 0:
        lines.append("- The rigid leg does not leave the ground with this law: its push decelerates at less than g. "
                     "The flexible strip stores energy in the squat-to-push reversal and returns it near the "
                     "leg's bounce period, which is what lets the flexible leg jump.")
    return "\n".join(lines)


# ------------------------------------------------------------------------------------------
# flegx-machinery
# ------------------------------------------------------------------------------------------
#: the machinery run's co-design (flegx_codesign.optimise_law, CB link with worm gears in the
#: dynamics): a start grid of MACHINERY_START pushes, then CMA-ES, MACHINERY_TRIALS trials in
#: generations of MACHINERY_BATCH (reduced: a CB-and-worm jump costs several PRBM ones)
MACHINERY_START, MACHINERY_TRIALS, MACHINERY_BATCH = 4, 12, 4


def run_machinery(out_dir="results/flegx-machinery", progress: bool = True, workers: int | None = None) -> Path:
    """Worm-gear model (seed 002 §III.C, Fig. 4): a ≈ 50 mm jump with take-off and landing, worm vs ideal gears."""
    from ..report.html import Report
    from ..units import deg

    wall0 = time.perf_counter()
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    # the law is not picked by hand: the largest jump within 520 MPa and the 77 N m wheel rating up to take-off,
    # found with the CB link and worm gears in the dynamics by CMA-ES over the push and the extended pose
    from .flegx_codesign import optimise_law

    found = optimise_law(4, 2, "cb", "worm", n_trials=MACHINERY_TRIALS, batch=MACHINERY_BATCH, start=MACHINERY_START,
                         store=out / "codesign")
    if not found["feasible"]:
        raise ModelError("flegx-machinery: the co-design found no law within the limits; raise MACHINERY_TRIALS.")
    pd.DataFrame([found]).to_parquet(out / "codesign.parquet", index=False)
    law = dict(extend=(found["extend_hip_deg"] * deg, found["extend_knee_deg"] * deg), t_push=float(found["t_push_s"]))
    jobs = [dict(tag=g, configuration=4, link_case=2, link_model="cb", gears=g, dt_output=1e-3, animate=g == "worm", **law)
            for g in ("worm", "ideal")]
    outs = run_jobs(jobs, workers, progress)
    tab = _metrics_table(outs)
    _long(outs).to_parquet(out / "machinery.parquet", index=False)
    tab.to_parquet(out / "metrics.parquet", index=False)
    mw, mi = outs[0]["metrics"], outs[1]["metrics"]
    t_lo = 0.15 + 0.8
    win = (t_lo, t_lo + 1.0)
    rep = Report("FLEGX machinery model: worm gears, take-off and landing",
                 "configuration No. 4, CB link 250 × 70 × 3 mm, worm sets 9.67:1 (Eqs. 16-17, f = 0.14 static / 0.13 dynamic); proleg")
    rep.add_heading("What was simulated")
    rep.add_text(
        "The same motion law with worm gears in the dynamics and with ideal gears. With worm gears the motors impose the "
        "worms' rotation (s = n r1 Δθ) and each worm meshes with its wheel through a compliant contact with sliding "
        "friction (drives.gears.worm_mesh: f = 0.14 static / 0.13 dynamic, Eq. 16 efficiency η = 0.59-0.61 worm driving, "
        "η_back = 0.34-0.39 wheel driving; FLEGX's worm would self-lock only above f = 0.217); the torque at the worm is the "
        "motor's (the motion's effort), the loss is the mesh's friction power f W v_s. With ideal gears the wheels are "
        "driven directly and the worm torque is the wheel torque / 9.67. "
        f"The law (push {law['t_push']:.3f} s from the squat to ({found['extend_hip_deg']:.1f}°, {found['extend_knee_deg']:.1f}°)) "
        "is not picked by hand: it is the largest jump that CMA-ES found over the push duration and the extended pose with the "
        "CB link and worm gears in the dynamics, within 520 MPa and the 77 N m wheel rating up to take-off (Table I's phase; "
        f"flegx_codesign.optimise_law, {found['trials']} trials after a {MACHINERY_START}-push start grid, reduced size): "
        f"foot clearance {found['height_mm']:.1f} mm (guide rise {found['jump_mm']:.1f} mm) at {found['stress_MPa']:.0f} MPa, hip {found['peak_hip_Nm']:.1f} N m, knee "
        f"{found['peak_knee_Nm']:.1f} N m; binding: {found['binding']}; best per generation {found['history_mm']} mm. "
        "The landing that follows is not constrained (seed 002 designs the take-off); its peaks are in the table below.")
    rep.add_heading("Results")
    rep.add_table(tab, "Metrics (seed 002 Fig. 4: 50 mm jump, max stress 447 MPa, tip displacement ≈ 32 mm, 12.8 % of L).",
                  float_format="{:.4g}", index=False)
    figs = [
        (channels_figure(outs[:1], [("hip_worm_torque [N m]", "hip worm [N m]", 1.0), ("knee_worm_torque [N m]", "knee worm [N m]", 1.0)], win),
         "Seed 002 Fig. 4 (top) analogue: torques required at the hip and knee worms."),
        (channels_figure(outs[:1], [("clamp_stress [Pa]", "von Mises at clamp [MPa]", 1e-6), ("tip_displacement [m]", "tip transverse [mm]", 1e3)], win),
         "Seed 002 Fig. 4 (middle, bottom): stress at the clamped end and free-end transverse displacement."),
        (channels_figure(outs, [("hip_power_in [W]", "hip motor power [W]", 1.0), ("knee_power_in [W]", "knee motor power [W]", 1.0)], win),
         "Motor power with worm and ideal gears."),
    ]
    for k, (fig, cap) in enumerate(figs, 1):
        fig.savefig(out / f"fig{k}.png", dpi=110, bbox_inches="tight")
        rep.add_figure(fig, cap)
    rep.add_text(
        f"- Peak worm torque, hip: {mw['peak_hip_torque_worm']:.2f} N m with worms vs {mi['peak_hip_torque_worm']:.2f} N m ideal "
        f"(× {mw['peak_hip_torque_worm'] / mi['peak_hip_torque_worm']:.2f}); knee: {mw['peak_knee_torque_worm']:.2f} vs "
        f"{mi['peak_knee_torque_worm']:.2f} N m (× {mw['peak_knee_torque_worm'] / mi['peak_knee_torque_worm']:.2f}).\n"
        f"- Motor energy (∫|P| dt): {mw['motor_energy']:.1f} J with worms vs {mi['motor_energy']:.1f} J ideal; positive motor work "
        f"{mw['motor_work_positive']:.1f} J vs {mi['motor_work_positive']:.1f} J (× {mw['motor_work_positive'] / mi['motor_work_positive']:.2f}); "
        f"mesh friction loss {mw['mesh_loss_energy']:.1f} J.\n"
        f"- Jump with ideal gears {mi['jump_height'] * 1e3:.1f} mm, max stress {mi['max_stress'] / 1e6:.0f} MPa, tip {mi['tip_displacement'] * 1e3:.1f} mm "
        "(the worm meshes' compliance and friction change the leg's motion only slightly: the motors impose the worms' rotation).\n"
        f"- Jump {mw['jump_height'] * 1e3:.1f} mm, max stress {mw['max_stress'] / 1e6:.0f} MPa, tip {mw['tip_displacement'] * 1e3:.1f} mm "
        f"({100 * mw['tip_displacement'] / 0.25:.1f} % of L).")
    rep.add_heading("3D animation (worm gears, Craig-Bampton link)")
    rep.add_html(outs[0]["animation"])
    rep.add_heading("Model")
    rep.add_parameters(outs[0]["parameters"], "Parameters and sources (MODEL_DATA §3).")
    rep.add_key_values({"total wall time [s]": f"{time.perf_counter() - wall0:.1f}", "output folder": str(out)}, "Run")
    return rep.save(out / "flegx_machinery_report.html")


# ------------------------------------------------------------------------------------------
# flegx-study
# ------------------------------------------------------------------------------------------
def study_table(rows: pd.DataFrame) -> pd.DataFrame:
    """The study's rows (``flegx_study.run_table_i``) in report units."""
    r = rows
    return pd.DataFrame({
        "configuration": r["configuration"], "link case": r["link_case"], "link model": r["link model"],
        "total mass [kg]": r["total_mass"], "jump height [mm]": r["jump_height"] * 1e3, "foot clearance [mm]": r["foot_clearance"] * 1e3,
        "flight rise [mm]": r["flight_rise"] * 1e3, "max stress take-off [MPa]": r["max_stress_takeoff"] / 1e6,
        "hip torque take-off [N m]": r["peak_hip_torque_takeoff"], "knee torque take-off [N m]": r["peak_knee_torque_takeoff"],
        "tip displacement [mm]": r["tip_displacement"] * 1e3, "> 510 MPa": r["> 510 MPa"],
        "apex in window": r["apex_in_window"] > 0.5, "status": r["status"], "steps": r["steps"], "wall/variant [s]": r["wall_s"],
    })


def shared_law_table(per: pd.DataFrame) -> pd.DataFrame:
    """The shared law's per-configuration rows (``flegx_study.shared_push``) in report units."""
    hk = lambda h, k: [f"{a:.1f} / {b:.1f}" for a, b in zip(per[h], per[k], strict=True)]  # noqa: E731
    return pd.DataFrame({
        "configuration": per["configuration"], "shortest push at the limits [s]": per["t_push_s"], "binding": per["binding"],
        "stress to take-off [MPa]": per["stress_MPa"], "hip / knee torque to take-off [N m]": hk("peak_hip_Nm", "peak_knee_Nm"),
        "longer pushes feasible": per["feasible_after"], "sets the shared law": per["t_push_s"] == per["t_push_s"].max(),
        # peaks at the shared push interpolated on each configuration's search grid (a check that
        # every configuration is within the limits there); heights are not shown: interpolated
        # across take-off timing they can be far off (No. 4: 20.4 mm against 8.7 mm simulated),
        # and Table I's rows hold the simulated heights at this law
        "at the shared push (interpolated): stress [MPa]": per["stress_shared_MPa"],
        "hip / knee [N m] (interpolated)": hk("hip_shared_Nm", "knee_shared_Nm"), "within the limits": per["within_at_shared"]})


#: the CLI's co-design size (reduced: 24 CMA-ES trials in generations of 6 after a 6-push start
#: grid, about 4 min per configuration on a shared 2-core machine); bench/flegx_codesign.py runs
#: the full size (64 trials, population 8) and commits its table to bench/results
CODESIGN_TRIALS, CODESIGN_BATCH = 24, 6


def codesign_table(df: pd.DataFrame) -> pd.DataFrame:
    """The co-design rows (``flegx_codesign.optimise_table_i``) beside seed 002 Table I, report units."""
    return pd.DataFrame({
        "configuration": df["configuration"], "paper mass [kg]": df["paper_mass_kg"], "mass [kg]": df["total_mass_kg"],
        "paper jump [mm]": df["paper_jump_mm"], "co-designed foot clearance [mm]": df.get("height_mm"),
        "guide rise [mm]": df.get("jump_mm"), "flight rise [mm]": df.get("flight_rise_mm"),
        "paper stress [MPa]": df["paper_stress_MPa"], "stress to take-off [MPa]": df.get("stress_MPa"),
        "hip / knee torque to take-off [N m]": [f"{h:.1f} / {k:.1f}" for h, k in zip(df.get("peak_hip_Nm"), df.get("peak_knee_Nm"), strict=True)],
        "binding": df["binding"],
        "law: push [s], extended (θ1, θ2) [deg]": [f"{t:.3f}, ({a:.1f}, {b:.1f})" for t, a, b in
                                                   zip(df.get("t_push_s"), df.get("extend_hip_deg"), df.get("extend_knee_deg"), strict=True)],
        "shared law clearance [mm]": df.get("ref_height_mm"), "best per generation [mm]": df["history_mm"], "converged": df["converged"],
    })


def _codesign_section(out: Path, configurations, extra: list, n_trials: int = CODESIGN_TRIALS, batch: int = CODESIGN_BATCH,
                      reference: dict | None = None) -> tuple:
    """The co-design of each configuration (PRBM, case 2, CMA-ES over the push and the extended
    pose, flegx_codesign.optimise_table_i), stored in ``out/codesign`` and written to
    ``out/codesign.parquet``; ``reference``: the law evaluated beside each optimum ({variable:
    value}; flegx-study passes the shared law's push); returns (ranking sentence, table), every
    number from the run."""
    from .flegx_codesign import CONSTRAINT_PHASE, constraints, optimise_table_i, ranking_text

    df = optimise_table_i(tuple(configurations), (2,), "prbm", n_trials=n_trials, batch=batch, reference=dict(reference or {}),
                          store=out / "codesign")
    df.to_parquet(out / "codesign.parquet", index=False)
    lim = ", ".join(f"{k} {op} {b / 1e6:g} MPa" if "stress" in k else f"{k} {op} {b:g} N m"
                    for k, (op, b) in constraints(CONSTRAINT_PHASE).items())
    for _, r in df.iterrows():
        if r.get("feasible"):
            extra.append(f"- Co-design No. {int(r['configuration'])}: push {r['t_push_s']:.3f} s to ({r['extend_hip_deg']:.1f}°, "
                         f"{r['extend_knee_deg']:.1f}°) → foot clearance {r['height_mm']:.1f} mm (guide rise {r['jump_mm']:.1f} mm) at {r['stress_MPa']:.0f} MPa, hip {r['peak_hip_Nm']:.1f} N m, "
                         f"knee {r['peak_knee_Nm']:.1f} N m up to take-off; binding: {r['binding']}; best per generation "
                         f"{r['history_mm']} mm ({'converged' if r['converged'] else 'not converged'}); the shared law clears "
                         f"{r['ref_height_mm']:.1f} mm{'' if r['ref_feasible'] else ' (outside the limits)'} "
                         f"(paper: {r['paper_jump_mm']:.1f} mm at {r['paper_stress_MPa']:.1f} MPa).")
        else:
            extra.append(f"- Co-design No. {int(r['configuration'])}: {r['binding']}.")
    head = (f"- Co-design (PRBM, case 2; CMA-ES over the push duration and the extended pose, {n_trials} trials per configuration, "
            f"within {lim}, i.e. up to take-off, the phase of Table I, seed 002 §IV; flegx_codesign.optimise_table_i): "
            + ranking_text(df) + ".")
    return head, codesign_table(df)


def run_study(out_dir="results/flegx-study", progress: bool = True, workers: int | None = None, configurations=(1, 2, 3, 4),
              cases=(1, 2, 3, 4, 5, 6), codesign: bool = True) -> Path:
    """Configurations No. 1-4 × link cases 1-6 (PRBM) + the CB link for case 2: Table I, as
    :class:`proleg.study.Study` groups (``flegx_study``), stored in ``out_dir/store`` (resumable).
    Every variant runs one shared law, found, not picked: the shortest push at which every
    configuration (PRBM, link case 2) keeps within 520 MPa and the 77 N m wheel rating up to
    take-off (:func:`proleg.papers.flegx_study.shared_push`, stored in ``out_dir/shared_law``,
    its per-configuration pushes written to ``shared_law.parquet``). With ``codesign`` each configuration's law (push duration and extended pose) is also found
    by :func:`proleg.papers.flegx_codesign.optimise_table_i` (PRBM, case 2, CMA-ES at the reduced
    size :data:`CODESIGN_TRIALS`: the largest jump within 520 MPa and the 77 N m wheel rating up
    to take-off), stored in ``out_dir/codesign``, shown beside Table I with its binding constraint
    and the shared law's clearance (its reference law)."""
    import resource

    from ..report.html import Report
    from .flegx_study import SHARED_PUSHES, STUDY_T_AFTER, ranking, run_table_i, shared_law, shared_push, study_groups

    wall0 = time.perf_counter()
    load0 = os.getloadavg()
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    shared = shared_push(configurations, store=out / "shared_law", workers=workers)
    shared["per_configuration"].to_parquet(out / "shared_law.parquet", index=False)
    law = shared_law(shared)
    # the store is the law's: a rerun with the same push resumes, another push gets its own store
    rows = run_table_i(out / "store" / f"push_{law.t_push:.5f}s", configurations, cases, 2, progress=progress, workers=workers, law=law)
    wall = time.perf_counter() - wall0
    cpu = sum(getattr(resource.getrusage(w), f) for w in (resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN) for f in ("ru_utime", "ru_stime"))
    tab = study_table(rows)
    tab.to_parquet(out / "study.parquet", index=False)
    rep = Report("FLEGX design study: configurations No. 1-4 × link cases 1-6", "seed 002 §IV, Table I; proleg")
    rep.add_heading("What was simulated")
    rep.add_text(
        f"The countermovement jump of flegx_jump with one law for all (push {law.t_push:.3f} s, found: the shortest push that "
        "keeps every configuration within the limits, below) for every upper-leg configuration of Fig. 2 "
        "and every built link, with the PRBM link, and with the Craig-Bampton link for the 250 × 70 × 3 mm strip "
        "(Table I's), up to the apex of the jump "
        f"({STUDY_T_AFTER} s after the end of the push; Table I: \"the investigated movement was the take-off phase\"). "
        "Configurations differ in their mass split (flegx_data): the totals of Table I with link case 2. "
        "Stress over 510 MPa (the low end of AISI 304's ultimate strength, seed 002 §IV) up to take-off is flagged. "
        "Jump height: the guide's highest airborne position above its standing height (flegx_jump docstring).")
    rep.add_text("Run as proleg.study Studies, one per compiled shape (" + ", ".join(
        f"{g['name']}: {len(g['configurations']) * len(g['cases'])} variants" for g in study_groups(configurations, cases, 2))
        + "): each variant is the group's System with its own parameters (mass split, strip geometry, PRBM constants), "
        "all of a group in one vmap batch; rows in a Parquet store (store/), a rerun skips what is stored.")
    rep.add_heading("The shared law")
    per = shared["per_configuration"]
    rep.add_text(
        f"One law for all configurations, so that only the hardware differs. Its push, {shared['t_push_s']:.3f} s, is not picked "
        "by hand: it is the shortest at which every configuration, with the PRBM link on Table I's 250 × 70 × 3 mm strip, keeps "
        "within 520 MPa at the clamp and the 77 N m worm-wheel rating up to take-off (seed 002 §IV; flegx_study.shared_push: "
        f"flegx_codesign.push_at_limits per configuration over {len(SHARED_PUSHES)} pushes, refined in the binding bracket, "
        "interpolated). "
        f"No. {shared['binding_configuration']} sets it (binding: {shared['binding']}, {shared['stress_MPa']:.0f} MPa, hip "
        f"{shared['peak_hip_Nm']:.1f} N m, knee {shared['peak_knee_Nm']:.1f} N m); each configuration's own shortest push: "
        + "; ".join(f"No. {int(r.configuration)} {r.t_push_s:.3f} s ({r.binding})" for r in per.itertuples()) + ". "
        + ("At the shared push every configuration is within the limits (interpolated on its grid). " if shared["within_all"] else
           "At the shared push, interpolated on their grids, not within the limits: "
           + ", ".join(f"No. {int(r.configuration)}" for r in per.itertuples() if not r.within_at_shared) + ". ")
        + "The squat, the extended pose and the other timings are flegx_jump's documented ones (assumed; the paper prints none). "
        "The other link cases and the CB link run the same law; they may exceed the limit (flagged).")
    rep.add_table(shared_law_table(per), "Each configuration's shortest push within the limits up to take-off (PRBM, case 2; interpolated on its "
                  "push grid; flegx_codesign.push_at_limits, rule 'first') and, interpolated likewise, its peaks at the shared "
                  "push: the shared law takes the longest. The heights at that law are Table I's simulated rows below.", float_format="{:.4g}", index=False)
    rep.add_heading("Table I next to the paper")
    t1 = []
    for c in configurations:
        paper = D.TABLE_I[c]
        row = {"configuration": c, "paper mass [kg]": paper[0], "paper jump [mm]": paper[1], "paper stress [MPa]": paper[2]}
        for lm in ("prbm", "cb"):
            sel = tab[(tab["configuration"] == c) & (tab["link case"] == 2) & (tab["link model"] == lm)]
            if len(sel):
                r = sel.iloc[0]
                row["mass [kg]"] = r["total mass [kg]"]
                row[f"{lm} jump [mm]"] = r["jump height [mm]"]
                row[f"{lm} stress [MPa]"] = r["max stress take-off [MPa]"]
                row[f"{lm} hip / knee torque [N m]"] = f"{r['hip torque take-off [N m]']:.1f} / {r['knee torque take-off [N m]']:.1f}"
        t1.append(row)
    t1 = pd.DataFrame(t1)
    t1.to_parquet(out / "table1.parquet", index=False)
    rep.add_table(t1, "Link 250 × 70 × 3 mm at the shared law: total mass, jump height, max stress and joint torques up to "
                  "take-off, proleg vs seed 002 Table I.",
                  float_format="{:.4g}", index=False)
    paper_rank = ranking({c: D.TABLE_I[c][1] for c in configurations})
    lines = [f"- Ranking by jump height, seed 002: {' > '.join(f'No. {c}' for c in paper_rank)}."]
    for lm in ("prbm", "cb"):
        if f"{lm} jump [mm]" in t1:
            rank = ranking(dict(zip(t1["configuration"], t1[f"{lm} jump [mm]"], strict=True)))
            lines.append(f"- Ranking by jump height, proleg {lm}: {' > '.join(f'No. {c}' for c in rank)}"
                         f" ({'the same' if rank == paper_rank else 'not the same'}).")
    for lm in ("cb", "prbm"):
        if f"{lm} stress [MPa]" in t1:
            st = t1[f"{lm} stress [MPa]"]
            ps = [D.TABLE_I[c][2] for c in configurations]
            lines.append(f"- Why the ranking differs ({lm}): with one motion law for all configurations (the shortest push within the "
                         f"limits for all, set by No. {shared['binding_configuration']}) the stress up to take-off "
                         f"spans {st.min():.0f}-{st.max():.0f} MPa, where Table I's all lie within {min(ps):.1f}-{max(ps):.1f} MPa. The paper "
                         "\"required that the maximum value of the stresses ... was sufficiently lower than the ultimate tensile "
                         "strength\" (§IV): its laws were evidently set per configuration near that limit, so Table I compares the "
                         "heights at about equal stress, and ours at an equal law. With imposed joint motions a rigid leg's take-off "
                         "speed does not depend on its mass; the configurations differ only through the strip's dynamics (a "
                         "heavier leg bends the strip more and the push then lands elsewhere on its bounce period), and through "
                         "the mass split, which Table I does not print (assumed: flegx_data). The co-design section below "
                         "gives each configuration its own law (push duration and extended pose), found by CMA-ES within the stress limit "
                         "and the wheel rating.")
            break
    cd_tab = None
    if codesign:
        extra: list = []
        head, cd_tab = _codesign_section(out, configurations, extra, reference={"law_t_push": law.t_push})
        lines.append(head)
        lines += extra
    flagged = tab[tab["> 510 MPa"]]
    lines.append(f"- Over 510 MPa up to take-off: {len(flagged)} of {len(tab)} variants"
                 + (": " + ", ".join(f"No. {r['configuration']} case {r['link case']} {r['link model']}" for _, r in flagged.iterrows()) if len(flagged) else "") + ".")
    rep.add_text("\n".join(lines))
    if cd_tab is not None:
        rep.add_table(cd_tab, f"Table I by co-design (PRBM, link 250 × 70 × 3 mm): each configuration's law of largest jump within "
                      f"520 MPa and the 77 N m wheel rating up to take-off (height: the foot's clearance over the flight), found by CMA-ES ({CODESIGN_TRIALS} trials, reduced; "
                      f"bench/flegx_codesign.py runs 64), beside seed 002 Table I. 'shared law': the shared law above ({law.t_push:.3f} s push to "
                      f"({np.rad2deg(law.extend[0]):.0f}°, {np.rad2deg(law.extend[1]):.0f}°)).",
                      float_format="{:.4g}", index=False)
    rep.add_heading("All variants")
    rep.add_table(tab, "Every run (PRBM for all cases, CB for case 2). '> 510 MPa' flags the stress up to take-off.",
                  float_format="{:.4g}", index=False)
    fig, axes = _figure(1, 2, width=9, height=3.2, sharex=False)
    prb = tab[tab["link model"] == "prbm"]
    for c in configurations:
        s = prb[prb["configuration"] == c]
        axes[0, 0].plot(s["link case"], s["jump height [mm]"], "o-", label=f"No. {c}")
        axes[0, 1].plot(s["link case"], s["max stress take-off [MPa]"], "o-", label=f"No. {c}")
    axes[0, 1].axhspan(510, 530, color="r", alpha=0.15)
    axes[0, 0].set_xlabel("link case")
    axes[0, 1].set_xlabel("link case")
    axes[0, 0].set_ylabel("jump height [mm]")
    axes[0, 1].set_ylabel("max stress [MPa]")
    axes[0, 0].legend(fontsize="small", frameon=False)
    fig.savefig(out / "fig1.png", dpi=110, bbox_inches="tight")
    rep.add_figure(fig, "PRBM link: jump height and stress up to take-off per configuration and link case (red band: 510-530 MPa).")
    rep.add_heading("Model")
    rep.add_parameters(D.sources() + _law_rows(t_push=law.t_push), "Parameters and sources (MODEL_DATA §3).")
    rep.add_key_values({"variants": len(tab), "total wall time [s]": f"{wall:.1f}", "CPU time, all processes [s]": f"{cpu:.1f}",
                        "load average at start / end (1 min)": f"{load0[0]:.1f} / {os.getloadavg()[0]:.1f}",
                        "output folder": str(out)}, "Run")
    return rep.save(out / "flegx_study_report.html")
