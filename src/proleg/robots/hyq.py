"""The whole HyQ quadruped from its URDF (IIT-DLSLab ``hyq_description``, as shipped by the
``example-robot-data`` package): 13 parts (trunk + 3 per leg, feet merged), 12 revolute joints
with the URDF's limits as stops and damping 0.1 N m s/rad, four foot spheres (r = 0.02175 m)
on the ground with friction, and a PD servo on every joint (seed 000: P = 300 N m/rad "high
gain", D = 6 N m s/rad; sampled at 1 kHz). Total mass 86.8 kg ("~80 kg", seed 001).

Its drop-and-settle scenario, ``proleg run hyq-stand``, is in :mod:`proleg.papers.hyq_stand`,
with the weight share and static closed forms (:func:`weight_share`, :func:`static_torques`)
kept here for any model built by :func:`hyq`.

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
