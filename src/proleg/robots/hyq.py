"""The whole HyQ quadruped from its URDF (IIT-DLSLab ``hyq_description``, as shipped by the
``example-robot-data`` package): 13 parts (trunk + 3 per leg, feet merged), 12 revolute joints
with the URDF's limits as stops and damping 0.1 N m s/rad, four foot spheres (r = 0.02175 m)
on the ground with friction, and a PD servo on every joint (seed 000: P = 300 N m/rad "high
gain", D = 6 N m s/rad; sampled at 1 kHz). Total mass 86.8 kg ("~80 kg", seed 001).

Scenario ``proleg run hyq-stand`` (:func:`run_stand`): dropped from 10 cm above the ground in
its stance, HyQ lands on four feet and settles; the report compares

* the static vertical ground reaction per foot with its weight share: the forces F_i with
  Σ F_i = W, Σ x_i F_i = x_c W, Σ y_i F_i = y_c W of least norm (feet at their settled
  positions, COM x_c, y_c) — the four-foot stance is statically indeterminate, and this is the
  exact share for a rigid trunk on four equal legs (a rectangle's twist mode carries no load);
* every servo torque with the static closed form τ_k = −a_k · Σ_distal (r − p_k) × F (the
  moment, about joint k's axis a_k through its origin p_k, of the gravity of every part beyond
  the joint and of the foot's ground reaction).

Choosing values (profiled on ``proleg run hyq-stand``, 1.5 s):

* foot friction μ_s 0.9, μ_d 0.7 with the stiction and friction transition velocities of MSC
  Adams' contact defaults, 0.1 and 1 m/s. With v_stiction = 1 mm/s a stuck foot is a tangential
  damper of μ_s F_n / v_s ≈ 3e5 N s/m on a sub-kilogram lower leg, and between 1 and 10 mm/s the
  friction falls with speed (negative damping): after touchdown the run took 2,511 steps,
  960 rejected, 13,624 Newton iterations for 10 ms of simulated time. With 0.1 / 1 m/s the whole
  run takes ~1,600 steps (the 1 kHz servo sampling bounds the step at 1 ms). The price is creep:
  a foot carrying a tangential load F_t slides at about v_s F_t / (μ_s F_n) — here ~1 cm/s under
  the ~35 N with which the splayed legs push outward, slow enough for the static checks (the
  GRF and torque tables are read at one instant; the joint rates it causes are ~0.03 rad/s).
* servo D = 30 N m s/rad (P = 300 N m/rad, seed 000's high gain): with seed 000's D = 6 the
  trunk bounces on its four legs at ~2 Hz with a damping ratio of ~0.1 (the legs' vertical
  stiffness ~P/l² and damping ~D/l², l ≈ 0.3 m) and still rocks by ±15 N per foot at 1.5 s;
  D = 30 damps that mode near critically and is still stable at 1 kHz on the lightest link
  (D T / J ≈ 0.8 for the lower leg about the knee; proleg warns about unstable servos).
* ``jacobian_reuse`` (modified Newton): 132 Newton-matrix builds instead of ~1,600, the same
  1 % results.
"""

from __future__ import annotations

import sys
import warnings
from pathlib import Path

import numpy as np

from ..errors import ModelError

LEGS = ("lf", "rf", "lh", "rh")
# Stance (URDF joint positions) [rad]: feet under the hips, legs bent, body ~0.63 m above ground.
STANCE = {"haa": -0.1, "hfe": 0.7, "kfe": -1.4}
FOOT_RADIUS = 0.02175  # [m] hyq_no_sensors.urdf <sphere radius>


def hyq_urdf_path() -> Path:
    """``hyq_no_sensors.urdf`` from the installed example-robot-data package."""
    for base in sys.path:
        p = Path(base) / "cmeel.prefix" / "share" / "example-robot-data" / "robots" / "hyq_description" / "robots" / "hyq_no_sensors.urdf"
        if p.is_file():
            return p
    raise ModelError("HyQ's URDF comes with the example-robot-data package: pip install 'proleg[robots]'.")


def stance_positions(haa=STANCE["haa"], hfe=STANCE["hfe"], kfe=STANCE["kfe"]) -> dict:
    """URDF joint positions of the symmetric stance: front legs (hfe, kfe), hind legs mirrored (−hfe, −kfe)."""
    q = {}
    for leg in LEGS:
        s = 1.0 if leg[1] == "f" else -1.0
        q[f"{leg}_haa_joint"], q[f"{leg}_hfe_joint"], q[f"{leg}_kfe_joint"] = haa, s * hfe, s * kfe
    return q


def hyq(
    *, drop: float = 0.10, stance: dict | None = None, kp: float = 300.0, kd: float = 30.0, servo_period: float = 1e-3,
    contact: dict | None = None, urdf=None, servos: bool = True,
):
    """The HyQ quadruped model, standing ``drop`` [m] above the ground (feet clear by ``drop``).

    Parameters
    ----------
    drop : float [m], foot-sphere clearance at t = 0
    stance : dict joint → URDF position [rad], default :func:`stance_positions`; also the servo setpoints
    kp, kd : PD gains [N m/rad, N m s/rad] (seed 000 high gain P = 300; D = 30 for the whole
        robot, module docstring)
    servo_period : float [s] (1 kHz)
    contact : dict of :class:`proleg.SphereContact` keywords; default Hertz k = 2e6 N/m^1.5
        (≈ 2.4 mm at a quarter of the weight), damping 4e3 N s/m over 1 mm, μ_s 0.9, μ_d 0.7,
        transition velocities v_stiction 0.1 m/s, v_friction 1 m/s (module docstring)
    urdf : path of the URDF (default: example-robot-data's hyq_no_sensors.urdf)
    servos : bool, add the 12 PD servos (False: no controllers, e.g. for :func:`proleg.robots.hyq_trot`)
    """
    from ..io.urdf import UrdfWarning, load_urdf
    from ..model.control import PID

    q0 = stance_positions() if stance is None else dict(stance)
    c = dict(stiffness=2e6, exponent=1.5, damping=4e3, penetration=1e-3, mu_static=0.9, mu_dynamic=0.7, v_stiction=0.1, v_friction=1.0)
    c.update(contact or {})
    path = hyq_urdf_path() if urdf is None else Path(urdf)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UrdfWarning)  # the notes stay in model.urdf.notes
        probe = load_urdf(path, initial_positions=q0, feet=())
        lowest = min(probe.marker(f"{leg}_foot").position[2] for leg in LEGS)  # foot-sphere centres (the foot link frames)
        model = load_urdf(path, initial_positions=q0, base_position=(0.0, 0.0, FOOT_RADIUS + drop - lowest), contact=c)
    for name in model.urdf.joint_names() if servos else ():
        model.add_controller(PID(f"{name}.servo", name, kp=kp, kd=kd, setpoint=q0[name], period=servo_period))
    return model


def weight_share(feet_xy, com_xy, weight):
    """Least-norm vertical foot forces [N] carrying ``weight`` [N] with the COM at ``com_xy`` [m]."""
    A = np.vstack([np.ones(len(feet_xy)), feet_xy[:, 0], feet_xy[:, 1]])
    b = weight * np.array([1.0, com_xy[0], com_xy[1]])
    return np.linalg.pinv(A) @ b


def static_torques(result, k: int = -1, feet: dict | None = None):
    """Static closed-form joint torques [N m] at output ``k`` (module docstring), per URDF joint.

    ``feet``: optional {leg: (force (3,) [N], point (3,) [m])} in place of the result's foot
    contact forces (used to check the closed form against Pinocchio without a simulation)."""
    model = result.system.topo.model
    g = np.asarray(model.gravity)
    info = model.urdf
    parts = {p.name: p for p in model.parts}
    out = {}
    for leg in LEGS:
        names = [f"{leg}_haa_joint", f"{leg}_hfe_joint", f"{leg}_kfe_joint"]
        chain = [f"{leg}_hipassembly", f"{leg}_upperleg", f"{leg}_lowerleg"]
        if feet is not None:
            F_foot, r_foot = (np.asarray(x, float) for x in feet[leg])
        else:
            grf = result.contact(f"{leg}_foot.contact")
            F_foot, r_foot = np.asarray(grf["force"])[k], np.asarray(grf["point"])[k]
        for i, jn in enumerate(names):
            p = result.marker(f"{jn}.J").position[k]
            a = result.marker(f"{jn}.J").orientation[k][:, 2]
            m = np.cross(r_foot - p, F_foot)
            for part in chain[i:]:
                m = m + np.cross(result.part(part).position[k] - p, parts[part].mass * g)
            out[jn] = -float(a @ m)
    assert set(out) == set(info.joint_names())
    return out


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
    feet.to_csv(out / "feet.csv", index=False)
    joints.to_csv(out / "joints.csv", index=False)
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
