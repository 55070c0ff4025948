"""The HyQ drop-test report: rigid vs 4-bushing vs 8-bushing leg (seed 000 Fig. 5, seed 001
Figs. 4-12), with synthetic bench data, tables of peaks and settling, and the parameters with
their sources. Also the figures of the static and quasi-static scenarios."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pandas as pd

from ..report import Report
from ..robots import hyq_data as D
from . import hyq_tests as T
from ..robots.hyq_leg import BUSHING_PINS, PIN_NAMES

MODELS = ("rigid", "bushings4", "bushings8")
LABELS = {"rigid": "RCM (rigid pins)", "bushings4": "FCM, 4 bushings (1, 2, 3, 6)", "bushings8": "FCM, 8 bushings (1-6)"}
COLORS = {"rigid": "#1f5fa8", "bushings4": "#d9822b", "bushings8": "#2a9d4b", "bench": "#555555"}
SWEEP_STIFFNESS = (1e6, 1e7, 1e8, 1e9, 1e10)  # [N/m] radial pin stiffness of the hierarchy sweep
SWEEP_T_END = 0.35  # [s] first impact and the rebound
NOMINAL_PIN_STIFFNESS = D.BUSHING_RADIAL_STIFFNESS  # [N/m]: the 8-bushing drop itself is that row
ANIMATION_FRAMES = 300  # frames of the 3D animation per model (every 4 ms of a 1.2 s drop)
SEED_FIGS = {
    "rigid": ("seed 001 Fig. 4", "seed 001 Fig. 5", "seed 001 Fig. 6"),
    "bushings4": ("seed 001 Fig. 7", "seed 001 Fig. 8", "seed 001 Fig. 9"),
    "bushings8": ("seed 001 Fig. 10", "seed 001 Fig. 11", "seed 001 Fig. 12"),
}


def _figure(nrows=1, ncols=1, width=7.5, height=2.6, sharex=True):
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width, height * nrows), layout="constrained")
    axes = fig.subplots(nrows, ncols, sharex=sharex, squeeze=False)
    for ax in axes.ravel():
        ax.grid(True, alpha=0.3)
    return fig, axes


def _bench_series(bench: pd.DataFrame | None, what: str):
    if bench is None:
        return None
    t = bench["time_s"].to_numpy()
    if what == "slider":
        z = bench["slider_position_m"].to_numpy()
        return t, (z - z[0]) * 1e3
    return t, bench[f"{what}_force_N"].to_numpy()


# ------------------------------------------------------------------------------------------
# drop figures
# ------------------------------------------------------------------------------------------
def overlay_figure(frames: dict, column: str, ylabel: str, bench=None, bench_what=None, scale=1.0, t_max=None, title=None):
    """One channel of the three models overlaid (+ the synthetic bench record, grey)."""
    fig, axes = _figure()
    ax = axes[0, 0]
    if bench is not None and bench_what is not None:
        tb, yb = _bench_series(bench, bench_what)
        ax.plot(tb, yb, color=COLORS["bench"], lw=0.8, alpha=0.7, label="synthetic reference (model-generated)")
    for name, df in frames.items():
        ax.plot(df["time [s]"], df[column] * scale, color=COLORS[name], lw=1.3, label=LABELS[name])
    ax.set_ylabel(ylabel)
    ax.set_xlabel("time [s]")
    if t_max is not None:
        ax.set_xlim(0.0, t_max)
    ax.legend(fontsize="small", frameon=False, loc="upper right")
    if title:
        ax.set_title(title, fontsize="medium")
    return fig


def grid_figure(frames: dict, bench=None):
    """Seed 001 Figs. 4-12 layout: rows RCM, FCM-4, FCM-8; columns slider, hip force, knee force;
    each model against the (synthetic) bench record."""
    fig, axes = _figure(3, 3, width=11.0, height=2.3)
    cols = (("slider displacement [m]", "slider [mm]", 1e3, "slider"), ("hip force [N]", "hip force [N]", 1.0, "hip"), ("knee force [N]", "knee force [N]", 1.0, "knee"))
    for r, name in enumerate(MODELS):
        if name not in frames:
            continue
        df = frames[name]
        for c, (col, lab, sc, bw) in enumerate(cols):
            ax = axes[r, c]
            s = _bench_series(bench, bw)
            if s is not None:
                ax.plot(*s, color=COLORS["bench"], lw=0.8, alpha=0.7, label="bench")
            ax.plot(df["time [s]"], df[col] * sc, color=COLORS[name], lw=1.2, label=name)
            ax.set_title(f"{SEED_FIGS[name][c]}: {LABELS[name].split(',')[0]} {lab.split(' [')[0]}", fontsize="small")
            ax.set_ylabel(lab)
            if r == 2:
                ax.set_xlabel("time [s]")
            if c == 0:
                ax.legend(fontsize="x-small", frameon=False, loc="upper right")
    return fig


def angles_figure(frames: dict):
    fig, axes = _figure(2, 1)
    for name, df in frames.items():
        axes[0, 0].plot(df["time [s]"], df["SU [deg]"], color=COLORS[name], label=LABELS[name])
        axes[1, 0].plot(df["time [s]"], df["UL [deg]"], color=COLORS[name], label=LABELS[name])
    axes[0, 0].set_ylabel("SU = θ1 [deg]")
    axes[1, 0].set_ylabel("UL = θ2 [deg]")
    axes[1, 0].set_xlabel("time [s]")
    axes[0, 0].legend(fontsize="small", frameon=False, loc="upper right")
    return fig


def grf_figure(frames: dict, bench=None):
    fig, axes = _figure(3, 1)
    for k, ax_name in enumerate("xyz"):
        ax = axes[k, 0]
        if bench is not None:
            ax.plot(bench["time_s"], bench[f"grf_{ax_name}_N"], color=COLORS["bench"], lw=0.8, alpha=0.7, label="synthetic reference (model-generated)")
        for name, df in frames.items():
            ax.plot(df["time [s]"], df[f"GRF {ax_name} [N]"], color=COLORS[name], lw=1.1, label=LABELS[name])
        ax.set_ylabel(f"GRF {ax_name} [N]")
    axes[2, 0].set_xlabel("time [s]")
    axes[0, 0].legend(fontsize="small", frameon=False, loc="upper right")
    return fig


def impact_figure(frames: dict, window=0.06):
    """Cylinder forces and vertical GRF around the first impact (time from first contact)."""
    fig, axes = _figure(3, 1)
    for name, df in frames.items():
        t = df["time [s]"].to_numpy()
        touch = np.nonzero(df["GRF z [N]"].to_numpy() > 1.0)[0]
        t0 = t[touch[0]] if touch.size else 0.0
        sel = (t >= t0 - 0.005) & (t <= t0 + window)
        for k, col in enumerate(("hip force [N]", "knee force [N]", "GRF z [N]")):
            axes[k, 0].plot((t[sel] - t0) * 1e3, df[col].to_numpy()[sel], color=COLORS[name], label=LABELS[name])
            axes[k, 0].set_ylabel(col)
    axes[2, 0].set_xlabel("time after first contact [ms]")
    axes[0, 0].legend(fontsize="small", frameon=False, loc="upper right")
    return fig


def energy_figure(frames: dict):
    fig, axes = _figure(len(frames), 1, height=2.2)
    for ax, (name, df) in zip(axes[:, 0], frames.items()):
        t = df["time [s]"]
        e0 = df["energy total [J]"].iloc[0]
        ax.plot(t, df["energy kinetic [J]"], label="kinetic T")
        ax.plot(t, df["energy potential [J]"] - df["energy potential [J]"].iloc[0], label="potential V − V(0)")
        ax.plot(t, df["energy dissipated [J]"], label="dissipated D")
        ax.plot(t, -df["energy input [J]"], label="− servo input W")
        ax.plot(t, df["energy total [J]"] - e0, "k--", label="balance T+V+D−W − V(0)")
        ax.set_ylabel("[J]")
        ax.set_title(LABELS[name], fontsize="small")
    axes[0, 0].legend(fontsize="x-small", frameon=False, ncol=3, loc="upper right", bbox_to_anchor=(1.0, 1.45))
    axes[-1, 0].set_xlabel("time [s]")
    return fig


# ------------------------------------------------------------------------------------------
# tables
# ------------------------------------------------------------------------------------------
def summary_table(summaries: dict) -> pd.DataFrame:
    """Peaks, settling and differences of each model relative to the rigid model [%]."""
    df = pd.DataFrame(summaries).T
    df.index.name = "model"
    if "rigid" in df.index:
        for col in ("peak hip force [N]", "peak knee force [N]", "peak hip force, 5 ms [N]", "peak knee force, 5 ms [N]", "peak GRF z [N]", "settling time [s]"):
            df[f"{col.split(' [')[0]} vs rigid [%]"] = 100.0 * (df[col] / df.loc["rigid", col] - 1.0)
    return df


def reference_table(bench: pd.DataFrame) -> pd.DataFrame:
    """Provenance of the reference record drawn in the figures: model-generated (synthetic), so
    it cannot validate any of the three models (it comes from a variant of the 8-bushing one)."""
    prov = str(bench.attrs.get("provenance", "proleg synthetic bench data (hyq_tests.bench_measurement)"))
    return pd.DataFrame([{
        "record": "bench drop (grey curves)", "kind": "SYNTHETIC: model-generated, not measured",
        "generated by": "8-bushing model variant (hyq_tests.bench_variant) through the seed's instruments",
        "provenance": prov, "use": "illustration of a bench comparison only; no validation score is computed against it",
    }])


def difference_table(frames: dict) -> pd.DataFrame:
    """RMS and maximum differences of the time histories between model pairs."""
    rows = []
    names = list(frames)
    for a in range(len(names)):
        for b in range(a + 1, len(names)):
            fa, fb = frames[names[a]], frames[names[b]]
            row = {"pair": f"{names[b]} − {names[a]}"}
            for col, unit in (("slider displacement [m]", "mm"), ("hip force [N]", "N"), ("knee force [N]", "N"), ("GRF z [N]", "N")):
                sc = 1e3 if unit == "mm" else 1.0
                d = (fb[col].to_numpy() - fa[col].to_numpy()) * sc
                row[f"RMS Δ {col.split(' [')[0]} [{unit}]"] = float(np.sqrt(np.mean(d**2)))
                row[f"max |Δ| {col.split(' [')[0]} [{unit}]"] = float(np.max(np.abs(d)))
            rows.append(row)
    return pd.DataFrame(rows)


def energy_table(frames: dict) -> pd.DataFrame:
    rows = []
    for name, df in frames.items():
        V0 = df["energy potential [J]"].iloc[0]
        err = df["energy total [J]"].iloc[-1] - df["energy total [J]"].iloc[0]
        rows.append(
            {
                "model": name,
                "V(0) [J]": V0,
                "T(end) + V(end) [J]": df["energy kinetic [J]"].iloc[-1] + df["energy potential [J]"].iloc[-1],
                "dissipated [J]": df["energy dissipated [J]"].iloc[-1],
                "servo input [J]": df["energy input [J]"].iloc[-1],
                "balance error [J]": err,
                "error / V(0) [-]": err / V0,
                "error / dissipated [-]": err / df["energy dissipated [J]"].iloc[-1],
            }
        )
    return pd.DataFrame(rows)


def hierarchy_row(df: pd.DataFrame, rigid: pd.DataFrame) -> dict:
    """Peak cylinder forces of one drop record and their RMS differences from the rigid model
    over the same output times (the quantities :func:`proleg.papers.hyq_study.hierarchy_rows`
    computes in the study)."""
    r = rigid.iloc[: len(df)]
    row = {}
    for side in ("hip", "knee"):
        col = f"{side} force [N]"
        row[f"peak {side} force [N]"] = float(df[col].abs().max())
        row[f"RMS Δ {side} vs rigid [N]"] = float(np.sqrt(np.mean((df[col].to_numpy() - r[col].to_numpy()) ** 2)))
    return row


def hierarchy_table(sweep: dict, rigid: pd.DataFrame, t_end: float = SWEEP_T_END) -> pd.DataFrame:
    """Peak forces of the stiffness sweep ({k: :func:`hierarchy_row`-like dict}) and RMS
    differences from the rigid model, with the peaks relative to the rigid model's over the first
    ``t_end`` seconds."""
    r = rigid[rigid["time [s]"] <= t_end + 1e-12]
    rows = []
    for k, h in sorted(sweep.items()):
        row = {"pin radial stiffness [N/m]": k}
        for side in ("hip", "knee"):
            row[f"peak {side} force [N]"] = h[f"peak {side} force [N]"]
            row[f"peak {side} / rigid [-]"] = h[f"peak {side} force [N]"] / float(r[f"{side} force [N]"].abs().max())
            row[f"RMS Δ {side} vs rigid [N]"] = h[f"RMS Δ {side} vs rigid [N]"]
        rows.append(row)
    return pd.DataFrame(rows)


def hierarchy_figure(tab: pd.DataFrame):
    fig, axes = _figure(1, 2, width=10.0, height=3.4, sharex=False)
    k = tab["pin radial stiffness [N/m]"]
    for side, mk in (("hip", "o-"), ("knee", "s--")):
        axes[0, 0].semilogx(k, tab[f"peak {side} / rigid [-]"], mk, label=side)
        axes[0, 1].loglog(k, tab[f"RMS Δ {side} vs rigid [N]"], mk, label=side)
    axes[0, 0].axhline(1.0, color="k", lw=0.8)
    axes[0, 0].set_ylabel("peak force / rigid peak [-]")
    axes[0, 1].set_ylabel("RMS difference from rigid [N]")
    for ax in axes[0]:
        ax.set_xlabel("pin radial stiffness [N/m]")
        ax.legend(fontsize="small", frameon=False, loc="upper right")
    return fig


def pin_table() -> pd.DataFrame:
    rows = []
    for n, what in PIN_NAMES.items():
        rows.append(
            {
                "pin": n,
                "connects": what,
                "rigid": "Revolute" if n in (1, 4) else "Universal",
                "bushings4": "bushing" if n in BUSHING_PINS["bushings4"] else ("Revolute" if n == 4 else "Universal"),
                "bushings8": "2 bushings (double-sided)" if n in (4, 5) else "bushing",
            }
        )
    return pd.DataFrame(rows)


# ------------------------------------------------------------------------------------------
# the drop report
# ------------------------------------------------------------------------------------------
def _drop_job(job: dict) -> dict:
    """One model's drop and, for the 8-bushing model, the bench variant on the same compiled
    System (``with_params``: no recompilation). Module-level so that
    worker processes can run it; returns picklable data only (tables, HyQInfo, run statistics,
    and the 3D animation's scene: JSON data at ``ANIMATION_FRAMES`` frames)."""
    from ..report.animate import scene_from_result

    bench_variant, drop_test, instrument, variant_system = T.bench_variant, T.drop_test, T.instrument, T.variant_system
    t0 = time.perf_counter()
    d = drop_test(joints=job["joints"], gain=job["gain"], drop_height=job["drop_height"], t_end=job["t_end"], progress=job["progress"])
    st = d.result.stats
    out = {
        "name": job["joints"],
        "channels": d.tables["channels"],
        "summary": d.tables["summary"].iloc[0].to_dict(),
        "info": d.models["drop"].hyq,
        "runs": [{"model": job["joints"], "steps": st["steps"], "rejected": st["rejected"], "Newton iterations": st["newton_iterations"], "wall time [s]": time.perf_counter() - t0}],
        "bench": None,
        "scene": scene_from_result(d.result, max_frames=ANIMATION_FRAMES),
    }
    out["runs"][0]["wall time [s]"] = time.perf_counter() - t0
    if job.get("bench"):
        t0 = time.perf_counter()
        kw = bench_variant(0, gain=job["gain"], actuators="drop")
        b = drop_test(system=variant_system(d.systems["drop"], **kw), t_end=job["t_end"])
        out["bench"] = instrument(b.tables["channels"], np.random.default_rng(1))
        bst = b.result.stats
        out["runs"].append({"model": "bench variant (bushings8, perturbed)", "steps": bst["steps"], "rejected": bst["rejected"], "Newton iterations": bst["newton_iterations"], "wall time [s]": time.perf_counter() - t0})
    return out


def _sweep_job(job: dict) -> dict:
    """The hierarchy sweep: the 8-bushing leg's drop for each pin stiffness of ``job["sweep"]``
    over ``SWEEP_T_END``, through the study :func:`proleg.papers.hyq_study.hierarchy_rows` (one
    vmap batch) against the rigid leg's forces ``job["rigid"]``."""
    from .hyq_study import hierarchy_rows

    t0 = time.perf_counter()
    rows = hierarchy_rows(job["sweep"], job["rigid"], gain=job["gain"], drop_height=job["drop_height"])
    runs = [
        {"model": f"bushings8, k = {k:g} N/m (study, vmap batches of 2)", "steps": h["steps"], "rejected": np.nan, "Newton iterations": h["Newton iterations"], "wall time [s]": h["wall time [s]"]}
        for k, h in rows.items()
    ]
    runs[-1]["wall time [s]"] = time.perf_counter() - t0 - sum(r["wall time [s]"] for r in runs[:-1])
    return {"sweep": rows, "runs": runs}


def simulate_drops(*, t_end=1.2, gain="high", drop_height=0.05, bench=True, sweep=True, progress=False, workers=None) -> list[dict]:
    """Run :func:`_drop_job` for the three models, in ``workers`` processes (default: one per
    model when the machine has ≥ 2 cores; each model compiles its own simulation, which is
    most of the time). ``workers=1`` runs in this process. With ``sweep``, once the rigid model
    is done, a fourth job runs the first ``SWEEP_T_END`` seconds of the 8-bushing leg with the
    pin stiffness of ``SWEEP_STIFFNESS`` (the seed 001 hierarchy) as a study
    (:func:`_sweep_job`); its rows go to the 8-bushing output as ``sweep``."""
    import os

    jobs = [
        dict(joints=n, gain=gain, drop_height=drop_height, t_end=t_end, progress=False, bench=bench and n == "bushings8")
        for n in MODELS
    ]

    def sweep_job(rigid_out):
        ch = rigid_out["channels"]
        ref = ch.loc[ch["time [s]"] <= SWEEP_T_END + 1e-12, ["time [s]", "hip force [N]", "knee force [N]"]].reset_index(drop=True)
        return dict(sweep=[k for k in SWEEP_STIFFNESS if k != NOMINAL_PIN_STIFFNESS], rigid=ref, gain=gain, drop_height=drop_height)

    def attach(outs, sw):
        """The study's rows and, for the nominal stiffness, the 8-bushing drop itself."""
        b8 = next(o for o in outs if o["name"] == "bushings8")
        rigid = next(o for o in outs if o["name"] == "rigid")["channels"]
        nominal = b8["channels"][b8["channels"]["time [s]"] <= SWEEP_T_END + 1e-12].reset_index(drop=True)
        b8["sweep"] = {**sw["sweep"], NOMINAL_PIN_STIFFNESS: hierarchy_row(nominal, rigid)}
        b8["runs"] += sw["runs"]
        return outs

    n_cpu = os.cpu_count() or 1
    workers = (len(jobs) if n_cpu >= 2 else 1) if workers is None else int(workers)
    if workers > 1:
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor

        try:
            with ProcessPoolExecutor(max_workers=workers, mp_context=multiprocessing.get_context("spawn")) as pool:
                futures = [pool.submit(_drop_job, j) for j in jobs[::-1]]  # the bench job is longest: start it first
                outs, fsweep = [], None
                for f in futures[::-1]:  # rigid first: the sweep starts as soon as it is done
                    outs.append(f.result())
                    if progress:
                        print(f"hyq-drop: {outs[-1]['name']} done ({outs[-1]['runs'][0]['wall time [s]']:.1f} s)", flush=True)
                    if sweep and outs[-1]["name"] == "rigid":
                        fsweep = pool.submit(_sweep_job, sweep_job(outs[-1]))
                return attach(outs, fsweep.result()) if fsweep is not None else outs
        except (OSError, RuntimeError) as exc:  # no process support here: fall back to serial
            if progress:
                print(f"hyq-drop: worker processes unavailable ({exc}); running serially", flush=True)
    outs = []
    for j in jobs:
        j["progress"] = progress
        outs.append(_drop_job(j))
        if progress:
            print(f"hyq-drop: {j['joints']} done ({outs[-1]['runs'][0]['wall time [s]']:.1f} s)", flush=True)
    return attach(outs, _sweep_job(sweep_job(outs[0]))) if sweep else outs


def drop_report(
    out_dir="results/hyq-drop", *, progress: bool = True, t_end: float = 1.2, bench: bool = True, gain: str = "high",
    drop_height: float = 0.05, workers=None, sweep: bool = True,
) -> Path:
    """Simulate the drop of the three models (+ bench variant), write ``drop.parquet`` (all
    channels, long format with a ``model`` column), ``summary.csv``, ``bench_drop.csv``,
    ``fig*.png`` and ``hyq_drop_report.html`` into ``out_dir``; return the report path."""
    wall0 = time.perf_counter()
    outs = simulate_drops(t_end=t_end, gain=gain, drop_height=drop_height, bench=bench, sweep=sweep, progress=progress, workers=workers)
    return write_drop_report(out_dir, outs, t_end=t_end, gain=gain, drop_height=drop_height, wall0=wall0)


def write_drop_report(out_dir, outs: list[dict], *, t_end: float, gain: str = "high", drop_height: float = 0.05, wall0=None) -> Path:
    """Files and HTML report from the outputs of :func:`simulate_drops` (one dict per model:
    ``name``, ``channels``, ``summary``, ``info``, ``runs``, ``bench``, optional ``scene`` (the
    3D animation's data) and, for one model, ``sweep`` ({k: :func:`hierarchy_row`-like dict}))."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    wall0 = time.perf_counter() if wall0 is None else wall0
    frames = {o["name"]: o["channels"] for o in outs}
    summaries = {o["name"]: o["summary"] for o in outs}
    infos = {o["name"]: o["info"] for o in outs}
    runs = [r for o in outs for r in o["runs"]]
    bench_df = next((o["bench"] for o in outs if o["bench"] is not None), None)
    if bench_df is not None:
        bench_df.to_csv(out / "bench_drop.csv", index=False, float_format="%.9g")
    long = pd.concat([df.assign(model=name) for name, df in frames.items()], ignore_index=True)
    long.to_parquet(out / "drop.parquet", index=False)

    summ = summary_table(summaries)
    summ.to_csv(out / "summary.csv")
    figs = [
        (overlay_figure(frames, "slider displacement [m]", "slider displacement [mm]", bench_df, "slider", 1e3), "Slider vertical displacement from release, three models and the synthetic bench record (seed 001 Figs. 4, 7, 10)."),
        (overlay_figure(frames, "hip force [N]", "hip cylinder force [N]", bench_df, "hip", t_max=min(t_end, 0.5)), f"Hip cylinder (load-cell) force (first 0.5 s), positive pushing (seed 000 Fig. 5a; seed 001 Figs. 5, 8, 11), P = {D.P_GAIN[gain]:g} N m/rad."),
        (overlay_figure(frames, "knee force [N]", "knee cylinder force [N]", bench_df, "knee", t_max=min(t_end, 0.5)), "Knee cylinder (load-cell) force (first 0.5 s), positive pushing (seed 000 Fig. 5b; seed 001 Figs. 6, 9, 12)."),
        (grid_figure(frames, bench_df), "Seed 001 Figs. 4-12 layout: each model against the synthetic bench record (rows: RCM, FCM-4, FCM-8; columns: slider displacement, hip force, knee force)."),
        (impact_figure(frames), "Zoom on the first impact: cylinder forces and vertical GRF against the time after first contact."),
        (angles_figure(frames), "Joint angles SU (vertical to upper leg, = HFE θ1) and UL (upper to lower leg, = KFE θ2)."),
        (grf_figure(frames, bench_df), "Ground reaction force, three axes (force plate)."),
        (energy_figure(frames), "Energy balance: kinetic, potential change, dissipated (actuator and bushing dampers, contact), servo work; the dashed line is the balance error."),
    ]
    sweep = next((o.get("sweep") for o in outs if o.get("sweep")), None)
    sweep_tab = hierarchy_table(sweep, frames["rigid"]) if sweep and "rigid" in frames else None
    if sweep_tab is not None:
        sweep_tab.to_csv(out / "hierarchy.csv", index=False)
        figs.append((hierarchy_figure(sweep_tab), "Hierarchy (seed 001): peak cylinder forces of the 8-bushing model against the radial pin stiffness, and their RMS difference from the rigid model (first 0.35 s)."))
    for k, (fig, _) in enumerate(figs, 1):
        fig.savefig(out / f"fig{k}.png", dpi=110, bbox_inches="tight")

    rep = Report(
        "HyQ leg drop test: rigid vs bushing pins",
        f"drop height {drop_height * 100:g} cm, gain {gain} (P = {D.P_GAIN[gain]:g} N m/rad), seed 000 Table 2 drop coefficients; proleg",
    )
    rep.add_heading("What was simulated")
    rep.add_text(_INTRO.format(h=drop_height * 100, t_end=t_end))
    rep.add_heading("Results")
    scenes = {LABELS[o["name"]].split(",")[0] if o["name"] == "rigid" else LABELS[o["name"]]: o["scene"] for o in outs if o.get("scene")}
    if scenes:
        from ..report.animate import combine_scenes, scene_iframe

        rep.add_heading("3D animation", level=3)
        rep.add_html(scene_iframe(combine_scenes(scenes), height=460, title="HyQ leg drop: " + ", ".join(scenes)))
        rep.add_text(
            "The three models side by side (left to right: " + "; ".join(scenes) + "), released together; "
            "parts drawn as boxes of their mass and inertia, cylinders and bushings as lines, the foot contact force as an arrow. "
            "Drag to turn the camera, scroll to zoom."
        )
    for fig, cap in figs:
        rep.add_figure(fig, cap)
    rep.add_table(
        summ,
        "Peak cylinder forces (raw and as a 200 Hz load cell would read them: 5 ms moving average), peak GRF, first contact, "
        "settling time (2 % band of the slider travel) and differences from the rigid model.",
        float_format="{:.4g}",
    )
    rep.add_table(difference_table(frames), "Differences between the models' time histories.", float_format="{:.4g}")
    if bench_df is not None:
        rep.add_table(reference_table(bench_df), "Reference data in this report and what they may be used for (issue 31: calibration "
                      "and validation kept apart). The grey 'bench' curves are model output, not a measurement.")
    if sweep_tab is not None:
        rep.add_table(sweep_tab, "Hierarchy: 8-bushing model with every pin at the given radial stiffness (1e8 N/m nominal) against the rigid model.", float_format="{:.4g}")
    rep.add_table(energy_table(frames), "Energy balance: V(0) = T + V + dissipated − servo input at the end; the error comes from the integrator and the power quadrature.", float_format="{:.4g}")
    rep.add_text(_findings(summ))
    rep.add_heading("Model")
    rep.add_table(pin_table(), "Pins (seed 001 Fig. 2a numbering as interpreted in proleg.robots.hyq_leg).")
    rep.add_parameters(infos["rigid"].parameters, "Model parameters and their sources (MODEL_DATA = /work/shared/MODEL_DATA.md §1).")
    rep.add_table(pd.DataFrame(runs), "Runs (generalized-α, error-controlled, rtol 1e-6: impact peaks to about 0.5 %, checked against rtol 1e-8; wall time includes compilation).", float_format="{:.4g}")
    rep.add_key_values({"total wall time [s]": f"{time.perf_counter() - wall0:.1f}", "output folder": str(out)}, "Run")
    return rep.save(out / "hyq_drop_report.html")


_INTRO = """The HyQ leg of the HAL test bench (seed 000, seed 001): slider on a vertical prismatic joint, upper and lower
leg with HyQ's lengths, masses and inertias, hip and knee hydraulic cylinders (barrel + rod, pinned so that their
length follows MODEL_DATA c(θ)), actuator spring-dampers with seed 000 Table 2 drop coefficients and PD joint servos
(1 kHz) whose torque is converted to cylinder force through the lever arm l(θ). The foot sphere (r = 21.75 mm)
lands on the force plate (ground plane, Hertz contact with friction).

The leg is released at rest with the foot {h:g} cm above the plate and simulated for {t_end:g} s (outputs every
1 ms) with three joint models:

- **RCM** (seed 000): ideal lower pairs: revolute main pins, universal cylinder pins, cylindrical cylinder–rod pairs (no redundant constraint, 3 DOF);
- **FCM, 4 bushings** (seed 001): pins 1, 2, 3, 6 as 6-component bushings (free about the pin axis);
- **FCM, 8 bushings** (seed 001): all six pins as bushings, pins 4 and 5 double-sided.

The grey curves are *synthetic* bench data (no measurement is published): the 8-bushing model with half the
bushing stiffness, Table 2 k and c drawn with their printed σ and a 20 % softer foot, recorded through the seed's
instruments (encoder quantization, load-cell accuracy, force-plate noise). They show what a comparison with the
bench looks like; they are not evidence for either model."""


def _findings(summ: pd.DataFrame) -> str:
    """Findings written from the numbers (what seed 001 found, and whether this model agrees)."""
    if not set(MODELS) <= set(summ.index):
        return ""
    r = summ.loc["rigid"]
    lines = ["**Findings.**", ""]
    for side in ("hip", "knee"):
        col, col5 = f"peak {side} force [N]", f"peak {side} force, 5 ms [N]"
        d = [100.0 * (summ.loc[n, col] / r[col] - 1.0) for n in ("bushings4", "bushings8")]
        d5 = [100.0 * (summ.loc[n, col5] / r[col5] - 1.0) for n in ("bushings4", "bushings8")]
        lines.append(
            f"- Peak {side} cylinder force: rigid {r[col]:.4g} N; 4 bushings {d[0]:+.1f} %, 8 bushings {d[1]:+.1f} % "
            f"(5 ms average: {d5[0]:+.1f} %, {d5[1]:+.1f} %)."
        )
    hip_lower = all(summ.loc[n, "peak hip force [N]"] < r["peak hip force [N]"] for n in ("bushings4", "bushings8"))
    knee_lower = all(summ.loc[n, "peak knee force [N]"] < r["peak knee force [N]"] for n in ("bushings4", "bushings8"))
    text = "- Seed 001 found the rigid model's cylinder forces higher than the measured ones and the bushing models closer. "
    if hip_lower and knee_lower:
        text += "Here the bushing models give lower peaks at both cylinders, as seed 001 reports."
    elif hip_lower:
        text += (
            "Here the hip cylinder agrees (the compliant pins in series with the very stiff actuator dampers, Table 2 "
            "c ≈ 1e5 N s/m, soften the load path from the foot to the hip cylinder), but the knee peak is *higher* with "
            "bushings: right after the impact the leg rings on its compliant pins at a few hundred hertz (Figure 5) and "
            "the first overshoot adds to the knee force. The hierarchy sweep (last figure) shows the forces converging to "
            "the rigid ones as the pin stiffness grows (1e6 → 1e10 N/m), with the knee overshoot largest at 1e7-1e8 N/m."
        )
    else:
        text += "Here the bushing models do not give lower peak cylinder forces; see the impact zoom (Figure 5)."
    lines.append(text)
    g = [100.0 * (summ.loc[n, "peak GRF z [N]"] / r["peak GRF z [N]"] - 1.0) for n in ("bushings4", "bushings8")]
    lines.append(
        f"- Peak vertical GRF changes by {g[0]:+.1f} % and {g[1]:+.1f} %: the foot contact is much softer than the pins, "
        "so it sets the impact force; the pins change how it is shared inside the leg."
    )
    lines.append(
        f"- Settling time (2 % band): rigid {r['settling time [s]']:.3g} s, 4 bushings {summ.loc['bushings4', 'settling time [s]']:.3g} s, "
        f"8 bushings {summ.loc['bushings8', 'settling time [s]']:.3g} s: set by the actuator dampers and the servo, not by the pins."
    )
    return "\n".join(lines)


# ------------------------------------------------------------------------------------------
# static / quasi-static figures
# ------------------------------------------------------------------------------------------
def static_figure(table: pd.DataFrame):
    """Cylinder forces, joint angles and GRF against payload (seed 000 static test)."""
    fig, axes = _figure(1, 3, width=11.0, height=3.0, sharex=False)
    for name, grp in table.groupby("model") if "model" in table else [("rigid", table)]:
        c = COLORS.get(name, None)
        axes[0, 0].plot(grp["payload [kg]"], grp["hip force [N]"], "o-", color=c, label=f"{name} hip")
        axes[0, 0].plot(grp["payload [kg]"], grp["knee force [N]"], "s--", color=c, label=f"{name} knee")
        axes[0, 1].plot(grp["payload [kg]"], grp["SU [deg]"], "o-", color=c, label=f"{name} SU")
        axes[0, 1].plot(grp["payload [kg]"], grp["UL [deg]"], "s--", color=c, label=f"{name} UL")
        axes[0, 2].plot(grp["payload [kg]"], grp["GRF z [N]"], "o-", color=c, label=f"{name} GRF z")
    for ax, lab in zip(axes[0], ("cylinder force [N]", "angle [deg]", "GRF z [N]")):
        ax.set_xlabel("payload [kg]")
        ax.set_ylabel(lab)
        ax.legend(fontsize="x-small", frameon=False, loc="upper right")
    return fig


def loops_figure(df: pd.DataFrame):
    """Force-stroke loops of both cylinders (seed 000 Fig. 4a) with the least-squares line."""
    fig, axes = _figure(1, 2, width=10.0, height=3.6, sharex=False)
    for ax, side in zip(axes[0], ("hip", "knee")):
        s = df[f"{side} stroke [m]"].to_numpy() * 1e3
        f = df[f"{side} force [N]"].to_numpy()
        ax.plot(s, f, lw=1.0, label="force-stroke")
        k, f0 = np.polyfit(s, f, 1)
        xs = np.linspace(s.min(), s.max(), 2)
        ax.plot(xs, k * xs + f0, "-.", label=f"RMS line, k = {k * 1e3:.3g} N/m")
        ax.set_xlabel(f"{side} stroke [mm]")
        ax.set_ylabel(f"{side} force [N]")
        ax.legend(fontsize="small", frameon=False, loc="upper right")
    return fig


# ------------------------------------------------------------------------------------------
# scenario entry points
# ------------------------------------------------------------------------------------------
def run_static(out_dir="results/hyq-static", *, progress: bool = False) -> Path:
    """Static test for the rigid and 8-bushing models; writes ``static.parquet`` (table),
    ``static.png`` and returns the Parquet path."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    frames = []
    for joints in ("rigid", "bushings8"):
        tab = T.static_test(joints=joints).tables["static"]
        tab.insert(0, "model", joints)
        frames.append(tab)
    table = pd.concat(frames, ignore_index=True)
    path = out / "static.parquet"
    table.to_parquet(path, index=False)
    static_figure(table).savefig(out / "static.png", dpi=120, bbox_inches="tight")
    return path


def run_quasistatic(out_dir="results/hyq-quasistatic", *, progress: bool = False) -> Path:
    """Quasi-static test of the rigid model; writes ``quasistatic.parquet`` (channels),
    ``identification.csv`` / ``.parquet`` and ``loops.png``; returns the Parquet path."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    qs = T.quasistatic_test(progress=progress)
    path = out / "quasistatic.parquet"
    qs.tables["channels"].to_parquet(path, index=False)
    qs.tables["identification"].to_csv(out / "identification.csv", index=False)
    qs.tables["identification"].to_parquet(out / "identification.parquet", index=False)
    loops_figure(qs.tables["channels"]).savefig(out / "loops.png", dpi=120, bbox_inches="tight")
    return path


def run_drop(out_dir="results/hyq-drop", progress: bool = True, *, t_end: float = 1.2, bench: bool = True) -> Path:
    """The main job: drop test of the rigid, 4-bushing and 8-bushing models (+ synthetic bench
    data), Parquet results, figures and the self-contained HTML report; returns the report path."""
    return drop_report(out_dir, progress=progress, t_end=t_end, bench=bench)
