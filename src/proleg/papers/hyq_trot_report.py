"""``proleg run hyq-trot``: HyQ trotting on hydraulic cylinders, beside the same trot on ideal
torque sources (the fidelity switch), as a self-contained HTML report with Parquet results.

Figures: 3D animation, gait diagram (feet in contact over time), trunk speed and height, joint
torques against the 140 N m rating (seed 001), chamber pressures and valve flows, and the energy
balance from the supply to the joints. Every number in the text is computed by the run.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ..robots.hyq import LEGS
from ..robots.hyq_trot import RATING, hyq_trot


def metrics_table(metrics: dict):
    """{variant: {metric: value}} → one row per numeric metric, one column per variant (the
    Parquet table the docs show; text-valued metrics stay in metrics.csv and the report)."""
    import numbers

    import pandas as pd

    keys = [k for k in next(iter(metrics.values())) if all(isinstance(m.get(k), numbers.Real) for m in metrics.values())]
    return pd.DataFrame({"metric": keys, **{a: [float(m[k]) for k in keys] for a, m in metrics.items()}})


def pressure_figures(rep, t, ho, names):
    """All eight cylinders, one panel per leg and joint (4 legs × HFE, KFE): chamber pressures
    p_A, p_B against the supply and the cavitation floor, and the valve flows Q_A, Q_B; then the
    total supply flow (the pump's demand)."""
    import matplotlib.pyplot as plt

    ps = ho["supply"].pressure / 1e6
    for key, unit, scale, title in (("pressure", "MPa", 1e-6, "Chamber pressures p_A (piston side) and p_B (rod side) of all eight "
                                     f"cylinders, per leg (rows) and joint (columns), against the {ps:.0f} MPa supply (dashed)"),
                                    ("flow", "l/min", 6e4, "Valve flows Q_A, Q_B into the chambers of all eight cylinders")):
        fig, axs = plt.subplots(len(LEGS), 2, figsize=(10, 9), sharex=True, sharey=True)
        for i, leg in enumerate(LEGS):
            for j, kind in enumerate(("hfe", "kfe")):
                k = names.index(f"{leg}_{kind}_joint")
                ax = axs[i, j]
                ax.plot(t, ho[f"{key}_a"][:, k] * scale, lw=0.8, label="A")
                ax.plot(t, ho[f"{key}_b"][:, k] * scale, lw=0.8, label="B")
                if key == "pressure":
                    ax.axhline(ps, color="k", ls="--", lw=0.8)
                    ax.axhline(ho["cylinder"].cavitation_pressure / 1e6, color="grey", ls=":", lw=0.8)
                ax.set_title(f"{leg} {kind.upper()}", fontsize=8)
                if j == 0:
                    ax.set_ylabel(unit)
        axs[0, 0].legend(fontsize=7, ncol=2)
        for ax in axs[-1]:
            ax.set_xlabel("time [s]")
        rep.add_figure(fig, title)
        plt.close(fig)
    fig, ax = plt.subplots(figsize=(9, 2.6))
    ax.plot(t, ho["supply_flow"].sum(1) * 6e4)
    ax.set_ylabel("supply flow [l/min]")
    ax.set_xlabel("time [s]")
    rep.add_figure(fig, "Total flow drawn from the supply: the pump flow the motion needs")
    plt.close(fig)


def run_trot(out_dir="results/hyq-trot", progress: bool = True, *, speed: float = 1.0, t_end: float | None = None) -> Path:
    """Both trots (hydraulic and torque), Parquet, CSV metrics and the HTML report."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import pandas as pd

    from ..control.hydraulic import hydraulic_outputs
    from ..report import Report
    from ..report.animate import animation_iframe

    t_end = float(os.environ.get("PROLEG_HYQ_TROT_T_END", 8.0)) if t_end is None else t_end
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    from concurrent.futures import ThreadPoolExecutor

    # the two variants run side by side (XLA releases the GIL while a compiled chunk runs)
    with ThreadPoolExecutor(2) as pool:
        futs = {a: pool.submit(hyq_trot, speed=speed, t_end=t_end, actuators=a, progress=False) for a in ("hydraulic", "torque")}
        runs = {a: f.result() for a, f in futs.items()}
    for a, r in runs.items():
        r.result.to_parquet(out / f"hyq_trot_{a}.parquet")
    table = pd.DataFrame({a: r.metrics for a, r in runs.items()})
    table.to_csv(out / "metrics.csv")
    metrics_table({a: r.metrics for a, r in runs.items()}).to_parquet(out / "metrics.parquet", index=False)
    h, tq = runs["hydraulic"].metrics, runs["torque"].metrics
    from ..robots.hyq_trot import flow_demand

    ho = hydraulic_outputs(runs["hydraulic"].result, "cylinders")
    fd = flow_demand(runs["torque"], ho["cylinder"], ho["valve"], ho["supply"])
    rep = Report(f"HyQ trots at {speed:g} m/s: hydraulic cylinders vs ideal torque sources",
                 f"proleg.robots.hyq_trot, {t_end:g} s simulated per variant; wall time (both in parallel, compile included) "
                 f"hydraulic {h['wall_s']:.0f} s ({h['steps']} steps), torque {tq['wall_s']:.0f} s ({tq['steps']} steps), on a shared 2-core "
                 f"machine at load average {os.getloadavg()[0]:.1f}")
    rep.add_text(
        f"The whole HyQ ({runs['hydraulic'].result.system.topo.nbody} parts from the URDF) trots with diagonal pairs "
        f"(stride {runs['hydraulic'].gait.period:g} s, duty factor {runs['hydraulic'].gait.duty:g}, step height "
        f"{runs['hydraulic'].gait.step_height:g} m, Raibert foot placement, virtual-model stance), the commanded speed ramped from "
        f"standing. Hydraulic: HFE and KFE by valve-controlled cylinders with chamber pressures (16 mm bore, E024-class valve, "
        f"{h['supply_pressure'] / 1e6:.1f} MPa supply) under HyQ's 1 kHz pressure force loop; HAA electric (torque source). "
        f"Mean forward speed over the last half: hydraulic {h['forward_speed']:.3f} m/s, torque sources {tq['forward_speed']:.3f} m/s "
        f"(command {speed:g}). Lowest trunk height {h['base_height_min']:.3f} / {tq['base_height_min']:.3f} m; largest joint torque "
        f"{h['max_joint_torque']:.1f} / {tq['max_joint_torque']:.1f} N m (rating {RATING:g}). Chamber pressures between "
        f"{h['min_chamber_pressure'] / 1e6:.2f} and {h['max_chamber_pressure'] / 1e6:.2f} MPa (supply {h['supply_pressure'] / 1e6:.1f} MPa; "
        f"cavitation floor {ho['cylinder'].cavitation_pressure / 1e6:.1f} MPa; relief valves set at {h['relief_setting'] / 1e6:.1f} MPa "
        f"passed at most {h['peak_relief_flow'] * 6e4:.3f} l/min and dissipated {h['relief_loss']:.2f} J). Servo valves "
        f"{ho['valve'].rated_flow * 6e4:.1f} l/min at {ho['valve'].rated_drop / 1e6:.0f} MPa, sized from the torque-source trot's flow "
        f"demand: its peak required opening {fd['peak'].max():.2f} of that valve ({fd['names'][int(np.argmax(fd['peak']))]}). "
        f"Energy balance residual {100 * h['energy_residual'] / h['hydraulic_energy']:.3f} % of the energy drawn. Cost of transport: hydraulic "
        f"(energy drawn from the supply) {h['cost_of_transport']:.2f}, its positive joint work {h['mechanical_cost_of_transport']:.2f}; "
        f"torque sources (positive joint work) {tq['cost_of_transport']:.2f}."
    )
    rep.add_heading("3D animation (hydraulic)")
    rep.add_html(animation_iframe(runs["hydraulic"].result, height=460, max_frames=400))
    fig, axs = plt.subplots(2, 1, figsize=(9, 4), sharex=True)
    for ax, (a, r) in zip(axs, runs.items()):
        for k, leg in enumerate(LEGS):
            c = np.asarray(r.result.contact(f"{leg}_foot.contact")["normal_force"]) > 1.0
            ax.fill_between(r.result.t, k, k + 0.8 * c, step="mid")
        ax.set_yticks(np.arange(4) + 0.4, LEGS)
        ax.set_title(f"{a}: feet in contact")
    axs[-1].set_xlabel("time [s]")
    rep.add_figure(fig, "Gait diagram (normal force > 1 N)")
    plt.close(fig)
    fig, ax = plt.subplots(2, 1, figsize=(9, 5), sharex=True)
    for a, r in runs.items():
        x = np.asarray(r.result.part("base_link").position)
        v = np.asarray(r.result.part("base_link").velocity)
        ax[0].plot(r.result.t, v[:, 0], label=a)
        ax[1].plot(r.result.t, x[:, 2], label=a)
    g = runs["hydraulic"].gait
    ax[0].plot(runs["hydraulic"].result.t, [float(g.commanded_speed(t)) for t in runs["hydraulic"].result.t], "k--", label="command")
    ax[0].set_ylabel("trunk forward speed [m/s]")
    ax[1].set_ylabel("trunk COM height [m]")
    ax[1].set_xlabel("time [s]")
    ax[0].legend()
    rep.add_figure(fig, "Trunk speed and height")
    plt.close(fig)
    fig, axs = plt.subplots(2, 1, figsize=(9, 6), sharex=True)
    for ax, (a, r) in zip(axs, runs.items()):
        for leg in LEGS[:2]:
            for k in ("hfe", "kfe"):
                jn = f"{leg}_{k}_joint"
                ax.plot(r.result.t, np.asarray(r.result.actuator(f"{jn}.drive")["effort"]), label=jn)
        ax.axhline(RATING, color="k", ls="--")
        ax.axhline(-RATING, color="k", ls="--")
        ax.set_ylabel(f"{a} torque [N m]")
    axs[0].legend(ncol=4, fontsize=7)
    axs[-1].set_xlabel("time [s]")
    rep.add_figure(fig, f"Joint torques (front legs) against the {RATING:g} N m rating")
    plt.close(fig)
    names = runs["hydraulic"].result.system.topo.model.trot["hydraulic"].hydraulic["joints"]
    pressure_figures(rep, runs["hydraulic"].result.t, ho, names)
    bal = {
        "drawn from the supply [J]": h["hydraulic_energy"], "valve throttling loss [J]": h["valve_loss"],
        "relief valve loss [J]": h["relief_loss"], "leakage loss [J]": h["leakage_loss"], "change of oil compression energy [J]": h["compression_energy_change"],
        "cylinder work on the joints [J]": h["cylinder_work_on_joints"],
        "residual (drawn − the five above) [J]": h["energy_residual"],
        "residual / drawn [%]": 100 * h["energy_residual"] / h["hydraulic_energy"],
        "positive joint work, all 12 joints [J]": h["mechanical_energy"],
        "peak / mean pump flow [l/min]": f"{h['peak_supply_flow'] * 6e4:.2f} / {h['mean_supply_flow'] * 6e4:.2f}",
    }
    rep.add_key_values(bal, "Energy balance, supply → valve → oil → joints (hydraulic trot)")
    rep.add_table(table.reset_index().rename(columns={"index": "metric"}).astype(str), "Metrics of both trots")
    return rep.save(out / "report.html")
