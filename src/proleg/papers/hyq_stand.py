"""``proleg run hyq-stand``: the whole HyQ (:func:`proleg.robots.hyq`) dropped from 10 cm onto
its four feet, as a self-contained HTML report with Parquet results.

Dropped from 10 cm above the ground in its stance, HyQ lands on four feet and settles; the
report compares

* the static vertical ground reaction per foot with its weight share: the forces F_i with
  Σ F_i = W, Σ x_i F_i = x_c W, Σ y_i F_i = y_c W of least norm (feet at their settled
  positions, COM x_c, y_c) — the four-foot stance is statically indeterminate, and this is the
  exact share for a rigid trunk on four equal legs (a rectangle's twist mode carries no load);
* every servo torque with the static closed form τ_k = −a_k · Σ_distal (r − p_k) × F (the
  moment, about joint k's axis a_k through its origin p_k, of the gravity of every part beyond
  the joint and of the foot's ground reaction).

The model's choices (foot friction, servo damping, modified Newton) are explained in
:mod:`proleg.robots.hyq`.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..robots.hyq import LEGS, hyq, hyq_urdf_path, static_torques, weight_share


def stand(t_end: float = 1.5, dt_output: float = 2e-3, progress: bool = False, simulate_kw: dict | None = None, **kw):
    """Simulate the drop-and-settle (``kw`` to :func:`hyq`, ``simulate_kw`` to
    :func:`proleg.simulate`, default modified Newton); returns (result, table of feet, table of
    joints, {"weight [N]", "com"})."""
    import dataclasses

    import pandas as pd

    from ..analyses.simulate import simulate
    from ..assembly.assemble import assemble
    from ..solvers.galpha import AbstractAlphaIntegrator, GeneralizedAlpha

    model = hyq(**kw)
    skw = dict(simulate_kw or {})
    integrator = skw.pop("integrator", None) or GeneralizedAlpha()
    if isinstance(integrator, AbstractAlphaIntegrator):  # modified Newton by default (flat keys in simulate_kw still override)
        integrator = dataclasses.replace(integrator, jacobian_reuse=True)
    res = simulate(assemble(model), t_end=t_end, dt_output=dt_output, progress=progress, integrator=integrator, **skw)
    W = -sum(p.mass for p in model.parts) * model.gravity[2]
    masses = np.array([p.mass for p in model.parts])
    com = masses @ np.stack([res.part(p.name).position[-1] for p in model.parts]) / masses.sum()
    pts = np.stack([np.asarray(res.contact(f"{leg}_foot.contact")["point"])[-1] for leg in LEGS])
    fz = np.array([np.asarray(res.contact(f"{leg}_foot.contact")["force"])[-1, 2] for leg in LEGS])
    share = weight_share(pts[:, :2], com[:2], W)
    feet = pd.DataFrame(
        {"foot": LEGS, "x [m]": pts[:, 0], "y [m]": pts[:, 1], "GRF z [N]": fz, "weight share [N]": share, "error [%]": 100 * (fz - share) / share}
    )
    tau_cf = static_torques(res)
    rows = []
    for jn in model.urdf.joint_names():
        tau = float(np.asarray(res.controller(f"{jn}.servo")["output"])[-1])
        rows.append({"joint": jn, "angle [rad]": float(res.joint(jn).angle[-1]), "servo torque [N m]": tau, "static closed form [N m]": tau_cf[jn], "difference [N m]": tau - tau_cf[jn]})
    return res, feet, pd.DataFrame(rows), {"weight [N]": W, "com": com}


def run_stand(out_dir="results/hyq-stand", progress: bool = True, *, t_end: float = 1.5) -> Path:
    """``proleg run hyq-stand``: Parquet, tables, figures, 3D animation and the HTML report."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from ..report import Report
    from ..report.animate import animation_iframe

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    res, feet, joints, extra = stand(t_end=t_end, progress=progress)
    res.to_parquet(out / "hyq_stand.parquet")
    for name, table in (("feet", feet), ("joints", joints)):
        table.to_csv(out / f"{name}.csv", index=False)
        table.to_parquet(out / f"{name}.parquet", index=False)
    rep = Report("HyQ stands: drop from 10 cm onto four feet", f"proleg.robots.hyq from {Path(hyq_urdf_path()).name}; weight {extra['weight [N]']:.1f} N")
    rep.add_text(
        "The whole HyQ (13 parts from the URDF, 12 PD-servoed joints, P = 300 N m/rad, D = 30 N m s/rad at 1 kHz; "
        "Hertz foot contacts with friction μ 0.9/0.7 and Adams' default transition velocities 0.1/1 m/s, so a loaded foot "
        "creeps at ~1 cm/s) is released with its feet 10 cm above the ground and settles. Weight share: least-norm vertical forces carrying the weight "
        "with the COM where it settled (exact for a rigid trunk on four equal legs). Static closed form: moment of the "
        "distal parts' gravity and the foot reaction about each joint axis."
    )
    rep.add_heading("3D animation")
    rep.add_html(animation_iframe(res, height=460, max_frames=400))
    fig, ax = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    for leg in LEGS:
        ax[0].plot(res.t, np.asarray(res.contact(f"{leg}_foot.contact")["force"])[:, 2], label=leg)
    ax[0].set_ylabel("GRF z [N]")
    ax[0].legend()
    ax[1].plot(res.t, res.part("base_link").position[:, 2])
    ax[1].set_ylabel("trunk COM z [m]")
    ax[1].set_xlabel("time [s]")
    rep.add_figure(fig, "Vertical ground reactions and trunk height")
    plt.close(fig)
    rep.add_table(feet, "Static vertical GRF per foot against its weight share (last output)")
    rep.add_table(joints, "Servo torques against the static closed form (last output)")
    st = res.stats
    rep.add_key_values({"steps": st["steps"], "rejected": st["rejected"], "Newton iterations": st["newton_iterations"], "Newton matrices": st["jacobians"]}, "Run (generalized-α, rtol 1e-6, modified Newton)")
    return rep.save(out / "report.html")
