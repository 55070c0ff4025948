"""Optimisation of the final torque-sensor concept with optuna, and ``proleg run torque-sensor-study``.

Problem (seed 001 Problem 2; ModeFRONTIER + Nastran in the paper): maximise the gauge strain of
the ``final`` concept subject to gauge strain <= ``max_gauge_strain`` (0.06 %), max von Mises
<= yield / ``safety`` and stiffness >= ``min_stiffness`` [N m/deg], over link_width, neck ratio
(neck_width / link_width), r_link and thickness. Every trial is a real FE solve
(:func:`proleg.robots.torque_sensor_analysis`); constraint violations enter as a penalty
(objective = gauge strain - sum of the relative violations x 1e-3), infeasible geometry
(ModelError) is pruned. The optuna study lives in an SQLite file, so a run resumes where it
stopped; the trial history is saved as Parquet.

Speed: the search uses ``search_mesh`` (5 mm, gauges at 2.5 mm) without stress stiffening; the
chosen design is re-analysed on the default mesh with stress stiffening.
"""

from __future__ import annotations

import json
import math
import time
from pathlib import Path

import numpy as np
import pandas as pd

from ..errors import ModelError
from .sensor_fe import torque_sensor_analysis

SPACE = dict(link_width=(0.005, 0.010), neck_ratio=(0.45, 0.9), r_link=(0.009, 0.012), thickness=(0.008, 0.015))


def _dims(params):
    p = dict(params)
    p["neck_width"] = p.pop("neck_ratio") * p["link_width"]
    return p


def optimize_sensor(storage: str | None = None, n_trials: int = 8, *, study_name: str = "final-sensor",
                    max_gauge_strain: float = 6e-4, safety: float = 2.0, min_stiffness: float = 140.0,
                    search_mesh: float = 0.005, seed: int = 0, torque: float = 140.0):
    """Run (or resume) the optuna study; returns (study, history DataFrame).

    storage : optuna storage URL (e.g. "sqlite:///results/torque-sensor-study/optuna.db"); None: in memory.
    n_trials : trials to add in this call (a resumed study keeps its earlier trials).
    """
    import optuna

    optuna.logging.set_verbosity(optuna.logging.WARNING)
    study = optuna.create_study(study_name=study_name, storage=storage, direction="maximize", load_if_exists=True,
                                sampler=optuna.samplers.TPESampler(seed=seed, n_startup_trials=4))
    if not study.trials:  # start from the default final design
        from .torque_sensor import DEFAULTS

        d = DEFAULTS["final"]
        study.enqueue_trial(dict(link_width=d["link_width"], neck_ratio=d["neck_width"] / d["link_width"],
                                 r_link=d["r_link"], thickness=d["thickness"]))

    def objective(trial):
        params = {k: trial.suggest_float(k, lo, hi) for k, (lo, hi) in SPACE.items()}
        try:
            m = torque_sensor_analysis("final", torque=torque, mesh_size=search_mesh, stress_stiffening=False,
                                       **_dims(params)).metrics
        except ModelError as exc:
            trial.set_user_attr("error", str(exc))
            raise optuna.TrialPruned(str(exc)) from None
        viol = (max(0.0, m["gauge_strain"] / max_gauge_strain - 1) + max(0.0, safety / m["safety_factor"] - 1)
                + max(0.0, 1 - m["stiffness"] / min_stiffness))
        for k in ("gauge_strain", "max_von_mises", "safety_factor", "stiffness", "twist", "calibration_ccw", "mass"):
            trial.set_user_attr(k, float(m[k]))
        trial.set_user_attr("feasible", bool(viol == 0))
        return m["gauge_strain"] - 1e-3 * viol

    study.optimize(objective, n_trials=n_trials)
    hist = study.trials_dataframe()
    return study, hist


def best_feasible(study):
    """The best trial that meets all constraints (else the best overall)."""
    ok = [t for t in study.trials if t.value is not None and t.user_attrs.get("feasible")]
    pool = ok or [t for t in study.trials if t.value is not None]
    return max(pool, key=lambda t: t.value)


def _surface_figure(res, title):
    import matplotlib.pyplot as plt
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    m = res.model
    u = res.solutions[("A", "CCW")]
    vm = res.von_mises[("A", "CCW")].mean(axis=1)  # element mean [Pa]
    fb = m.mesh.boundary_facets()
    tri = m.mesh.facets[:, fb].T
    el = m.mesh.f2t[0, fb]
    disp = u[m.basis.nodal_dofs].T  # (nverts, 3)
    scale = 0.004 / max(np.abs(disp).max(), 1e-15)
    P = m.mesh.p.T + scale * disp
    fig = plt.figure(figsize=(6, 5))
    ax = fig.add_subplot(projection="3d")
    cmap = plt.get_cmap("jet")
    v = vm[el] / 1e6
    col = cmap(np.clip(v / max(v.max(), 1e-12), 0, 1))
    ax.add_collection3d(Poly3DCollection(P[tri] * 1e3, facecolors=col, edgecolor="none"))
    lim = np.abs(P).max() * 1e3
    ax.set_xlim(-lim, lim)
    ax.set_ylim(-lim, lim)
    ax.set_zlim(-lim, lim)
    ax.view_init(elev=60, azim=-60)
    ax.set_title(f"{title}\nvon Mises (max {v.max():.0f} MPa, element means), deformation x{scale:.0f}", fontsize=8)
    sm = plt.cm.ScalarMappable(cmap=cmap, norm=plt.Normalize(0, v.max()))
    fig.colorbar(sm, ax=ax, shrink=0.6, label="von Mises [MPa]")
    return fig


def _gauge_figure(results):
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 3.2))
    names = list(results)
    for k, (case, dr) in enumerate([("A", "CCW"), ("A", "CW"), ("B", "CCW"), ("B", "CW")]):
        vals = []
        for n in names:
            g = results[n].gauges
            vals.append(g.strain[(g.case == case) & (g.direction == dr)].abs().max() * 100)
        ax.bar(np.arange(len(names)) + 0.2 * k - 0.3, vals, 0.2, label=f"case {case}, {dr}")
    ax.axhline(0.06, color="k", ls="--", lw=0.8)
    ax.text(len(names) - 0.5, 0.062, "0.06 % limit", ha="right", fontsize=8)
    ax.set_xticks(range(len(names)), names)
    ax.set_ylabel("max |gauge strain| [%]")
    ax.legend(fontsize=7)
    fig.tight_layout()
    return fig


def run_torque_sensor_study(out_dir="results/torque-sensor-study", *, n_trials: int = 8,
                            convergence: bool = False) -> Path:
    """The four concepts side by side, then the optimised final design; HTML + Parquet/JSON."""
    from ..report.html import Report
    from .sensor_fe import mesh_convergence
    from .torque_sensor import DEFAULTS, ENVELOPE

    t0 = time.perf_counter()
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    results = {c: torque_sensor_analysis(c) for c in ("hollow", "spokes", "tension_links", "final")}
    study, hist = optimize_sensor(f"sqlite:///{(out / 'optuna.db').resolve()}", n_trials=n_trials)
    best = best_feasible(study)
    opt_dims = _dims(best.params)
    results["optimised"] = torque_sensor_analysis("final", **opt_dims)
    keys = ["stiffness", "twist", "max_von_mises", "max_von_mises_radius_mm", "safety_factor", "gauge_strain",
            "strain_in_range", "gauge_planar", "gauge_reachable", "gauge_clearance", "calibration_ccw",
            "calibration_cw", "calibration_mismatch", "case_mismatch", "reaction_torque_error", "mass", "n_dofs"]
    table = pd.DataFrame({n: {k: r.metrics[k] for k in keys} for n, r in results.items()}).T
    table.index.name = "design"
    table.astype({k: float for k in keys if k not in ("strain_in_range", "gauge_planar", "gauge_reachable")}) \
        .to_parquet(out / "designs.parquet")
    hist.to_parquet(out / "optuna_history.parquet")
    pd.concat([r.gauges.assign(design=n) for n, r in results.items()]).to_parquet(out / "gauges.parquet")
    conv = mesh_convergence("final", sizes=(0.006, 0.005, 0.004, 0.003), **opt_dims) if convergence else None
    if conv is not None:
        conv.to_parquet(out / "mesh_convergence.parquet")
    (out / "optimised.json").write_text(json.dumps({"dimensions_m": opt_dims, "trial": best.number,
                                                    "metrics": {k: (v if not isinstance(v, np.generic) else v.item())
                                                                for k, v in results["optimised"].metrics.items()}},
                                                   indent=2, default=str))
    rep = Report("HyQ torque sensor: four FE concepts and the optimised final design",
                 "seed 001 Problem 2 (Fig. 13); P2 tetrahedra, Ergal 7075-T6, 140 N m")
    rep.add_heading("Set-up")
    rep.add_text(
        f"Envelope (assumed, not printed in seed 001): a disc of outer radius <= {ENVELOPE['r_out'] * 1e3:g} mm and "
        f"thickness <= {ENVELOPE['thickness'] * 1e3:g} mm between the harmonic drive (outer face, r = r_out) and the "
        f"motor shaft (bore, r_bore >= {ENVELOPE['r_bore'] * 1e3:g} mm). Case A: harmonic-drive side fixed, 140 N m "
        "on the motor side; case B the reverse; CCW and CW. Stress stiffening (geometric stiffness of each "
        "direction's own stress) makes stretched and compressed tension links differ: the bidirectionality "
        "mismatch. Max von Mises excludes a 2 mm band at the idealised bolted faces. Gauge: 3 x 2 mm grid, "
        "full bridge, GF 2; planar = CAD face is a plane under the grid; reachable = 6 mm free in front of it.")
    rep.add_table(table.T, "Metrics per design (SI; stiffness N m/deg, twist deg, stress Pa, calibration mV/V per N m).",
                  float_format="{:.4g}")
    rep.add_figure(_gauge_figure(results), "Largest gauge strain per design, load case and direction.")
    for n, r in results.items():
        rep.add_figure(_surface_figure(r, n), f"{n}: deformed shape and von Mises on the surface (case A, CCW).")
    rep.add_heading("Optimisation (optuna TPE, each trial a real FE solve)")
    rep.add_text(f"Trials in the study: {len(study.trials)} (resumable: {out / 'optuna.db'}); best feasible trial "
                 f"{best.number}: " + ", ".join(f"{k} = {v * 1e3:.3g} mm" for k, v in opt_dims.items()) + ".")
    cols = [c for c in hist.columns if c.startswith(("params_", "user_attrs_")) or c in ("number", "value", "state")]
    rep.add_table(hist[cols], "Trial history.", float_format="{:.4g}")
    if conv is not None:
        rep.add_table(conv, "Mesh convergence of the optimised design (relative to the finest mesh).",
                      float_format="{:.4g}")
    rep.add_parameters([(f"{c}.{k}", v, "m" if isinstance(v, float) else "-", "chosen default")
                        for c, d in DEFAULTS.items() for k, v in d.items()], "Concept defaults")
    rep.add_key_values({"wall time [s]": f"{time.perf_counter() - t0:.1f}", "output": str(out)}, "Run")
    return rep.save(out / "torque_sensor_report.html")
