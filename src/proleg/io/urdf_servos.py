"""PD servos for a robot imported from URDF, with default gains from its mass and legs.

:func:`add_servos` puts a :class:`proleg.PID` (P and D, sampled with zero-order hold, as the
HyQ model's servos, seed 000) on every moving joint, holding a stance. Without gains given it
chooses them so that **the robot's weight on its legs is a mass–spring–damper of natural
frequency f_n and damping ratio ζ** (defaults 4 Hz and 1, critically damped), and offsets the
setpoints so that the servos already carry the weight at the stance (gravity compensation):

* each leg's vertical stiffness under a joint stiffness kp is kp / S_f, the foot held by
  friction: a vertical motion δ of the body relative to the foot needs the joint motions
  δq = J⁺ e_z δ (J the foot position's Jacobian over the leg's joints, J⁺ its pseudo-inverse:
  the least joint motion, which the joint springs choose), storing kp |δq|² / 2, so
  1 / S_f = |J⁺ e_z|² (e_zᵀ (J Jᵀ)⁻¹ e_z for a three-joint leg). For the planar two-link leg of
  link length l bent ±30° with the foot under the hip, S_f = l² / 5. A straight leg has
  S_f → 0 (the joints cannot move the foot vertically): S_f is floored at (0.2 l_f)², l_f the
  leg length from the first joint of the leg to the foot;
* the legs stand in parallel under the robot's mass M, so the body's vertical frequency is
  ω_n² = kp Σ_f (1/S_f) / M, which gives kp = M ω_n² / Σ_f (1/S_f) and kd = 2 ζ kp / ω_n;
* gravity compensation: the ground carries the weight with the least-norm vertical foot forces
  through the COM, the joints the torques u that balance them and gravity at the stance
  (:func:`static_torques`), and each setpoint is the stance + u / kp. A PD servo then holds the
  stance itself (without it the stand would sag by g / ω_n², 1.6 cm at 4 Hz, and the load step
  of being put down would settle as (ω_n t − 1) e^(−ω_n t), 6 % of the weight after 0.2 s).

Choosing values: a higher f_n stiffens the stand but needs a larger D gain, and a D gain
sampled every T is stable only below 2 I / T on the lightest link it drives (I its effective
inertia; :mod:`proleg.control.servo`, which ``simulate`` checks and warns about). At 4 Hz Go1
gets kp = 52 N m/rad, kd = 4.1 N m s/rad (its calf: kd T / I = 1.0 at 1 kHz, I = 0.0043 kg m²),
and 0.2 s after being put down on its feet at its SRDF stance the ground carries its weight to
0.01 % (Solo12 likewise). Joints that are on no leg (arms, heads) get the same gains.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import ModelError

LEVER_FLOOR = 0.2  # [-] S_f ≥ (LEVER_FLOOR · leg length)²


@dataclass(frozen=True)
class ServoGains:
    """What :func:`add_servos` chose: gains and the numbers behind them."""

    kp: float  # [N m/rad] (N/m on prismatic joints)
    kd: float  # [N m s/rad]
    frequency: float  # [Hz] natural frequency of the body's weight on its legs
    damping_ratio: float  # [-]
    mass: float  # [kg] the robot's mass
    levers: dict  # foot link → sqrt(S_f) [m], the leg's effective vertical lever
    stance: dict  # joint → stance position [rad|m]
    offsets: dict  # joint → setpoint − stance [rad|m] (gravity compensation)


def _link_poses(info, q: dict):
    """Link frames (4, 4) in ground at joint positions ``q`` (numpy forward kinematics over info.tree)."""
    from .urdf import _joint_motion

    X = {info.tree[0][0]: np.asarray(info.base_pose, float)}
    for ln, parent, jn, typ, O, axis in info.tree[1:]:
        X[ln] = X[parent] @ np.asarray(O, float) @ _joint_motion(typ, axis, q.get(jn, 0.0))
    return X


def leg_levers(model, stance: dict, joints=None):
    """{foot link: (S_f [m²], leg length l_f [m], leg joints)} at ``stance`` (module docstring),
    over the servoed ``joints`` (default every moving joint) on each foot's path to the root."""
    info = model.urdf
    movable = set(info.joint_names() if joints is None else joints)
    row = {r[0]: r for r in info.tree}
    out = {}
    h = 1e-6
    for foot in info.feet:
        path, ln = [], foot
        while row[ln][1] is not None:
            _, parent, jn, typ, _, _ = row[ln]
            if jn in movable and typ in ("revolute", "continuous", "prismatic"):
                path.append((jn, ln))
            ln = parent
        if not path:
            continue
        J = np.zeros((3, len(path)))
        for k, (jn, _) in enumerate(path):
            pp = _link_poses(info, {**stance, jn: stance.get(jn, 0.0) + h})[foot][:3, 3]
            pm = _link_poses(info, {**stance, jn: stance.get(jn, 0.0) - h})[foot][:3, 3]
            J[:, k] = (pp - pm) / (2 * h)
        dq = np.linalg.pinv(J) @ np.array([0.0, 0.0, 1.0])  # least joint motion for a unit vertical foot motion
        reach = np.linalg.norm(J @ dq - [0.0, 0.0, 1.0]) < 0.5
        S = 1.0 / (dq @ dq) if reach and dq @ dq > 0 else 0.0
        X = _link_poses(info, stance)
        first = path[-1][1]  # the child link of the leg's first joint: the joint's origin is its frame
        length = float(np.linalg.norm(X[foot][:3, 3] - X[first][:3, 3]))
        out[foot] = (max(S, (LEVER_FLOOR * length) ** 2), length, [jn for jn, _ in reversed(path)])
    return out


def _part_coms(model, X):
    """Ground positions (nparts, 3) of the parts' COMs from link frames ``X`` (a part is named
    after its top link; ``link_frame`` is that link's frame in the part frame, COM origin)."""
    info = model.urdf
    out = []
    for part in model.parts:
        L = np.asarray(info.link_frame[part.name], float)
        out.append((X[part.name] @ np.linalg.inv(L))[:3, 3])
    return np.array(out)


def static_torques(model, stance: dict):
    """Joint torques [N m|N] that hold the robot still at ``stance`` with its weight on its feet.

    The ground carries the weight M g with the least-norm vertical foot forces whose resultant
    passes through the COM (as :func:`proleg.robots.hyq.weight_share`); with the base held, the
    joints then carry u = ∂V/∂q, V(q) = Σ_parts m g·(−p_com) − Σ_feet F_f·p_f, by central
    differences of the numpy forward kinematics. {} without feet."""
    info = model.urdf
    if not info.feet:
        return {}
    g = np.asarray(model.gravity, float)
    masses = np.array([p.mass for p in model.parts])
    X0 = _link_poses(info, stance)
    com = masses @ _part_coms(model, X0) / masses.sum()
    feet_xy = np.array([X0[f][:3, 3][:2] for f in info.feet])
    W = -masses.sum() * g[2]
    A = np.vstack([np.ones(len(feet_xy)), feet_xy[:, 0], feet_xy[:, 1]])
    Fz = np.linalg.pinv(A) @ (W * np.array([1.0, com[0], com[1]]))

    def V(q):
        X = _link_poses(info, q)
        return -(masses @ (_part_coms(model, X) @ g)) - sum(F * X[f][2, 3] for f, F in zip(info.feet, Fz))

    h = 1e-6
    return {j: (V({**stance, j: stance[j] + h}) - V({**stance, j: stance[j] - h})) / (2 * h) for j in info.joint_names()}


def add_servos(model, *, stance: dict | None = None, kp: float | None = None, kd: float | None = None,
               frequency: float = 4.0, damping_ratio: float = 1.0, period: float = 1e-3, joints=None,
               gravity_compensation: bool = True) -> ServoGains:
    """Add a PD servo on every moving joint of a URDF model, holding ``stance`` (module docstring).

    Parameters
    ----------
    model : Model from :func:`proleg.io.load_urdf` (with feet, for the default gains)
    stance : dict joint → setpoint [rad|m], URDF sign and zero; default the modelled pose
        (``load_urdf(initial_positions=...)``); joints not named hold their initial position
    kp, kd : float, optional [N m/rad, N m s/rad]; default from ``frequency`` and ``damping_ratio``
    frequency : float [Hz], default 4; natural frequency of the robot's weight on its legs
    damping_ratio : float [-], default 1 (critical)
    period : float [s], servo sample period (default 1e-3: 1 kHz)
    joints : list of joint names, default every moving URDF joint
    gravity_compensation : bool, default True; each setpoint is offset by u/kp, u the joint's
        share of holding the robot's weight at the stance (:func:`static_torques`), so that the
        PD law gives the static torque at the stance itself and the robot stands there instead
        of sagging by g/ω_n² (the offset is ``ServoGains.offsets``)

    Returns
    -------
    ServoGains : the gains and the numbers they come from. The servos are named
    ``'<joint>.servo'`` (``result.controller(name)``).
    """
    from ..model._validate import finite_scalar
    from ..model.control import PID

    info = getattr(model, "urdf", None)
    if info is None:
        raise ModelError(f"add_servos: model '{model.name}' was not imported with proleg.io.load_urdf. Add proleg.PID servos yourself.")
    names = info.joint_names()
    sel = names if joints is None else list(joints)
    for j in sel:
        if j not in names:
            raise ModelError(f"add_servos joints: '{j}' is not a moving joint of model '{model.name}'. Known: {names}")
    q = {n: info.initial_positions.get(n, 0.0) for n in names}
    for j, val in (stance or {}).items():
        if j not in names:
            raise ModelError(f"add_servos stance: '{j}' is not a moving joint of model '{model.name}'. Known: {names}")
        q[j] = finite_scalar(f"add_servos stance['{j}']", val, unit="rad or m")
    f = finite_scalar("add_servos frequency", frequency, positive=True, unit="Hz")
    zeta = finite_scalar("add_servos damping_ratio", damping_ratio, nonnegative=True)
    mass = float(sum(p.mass for p in model.parts))
    levers = {}
    if kp is None or kd is None:
        legs = leg_levers(model, q, sel)
        if not legs:
            raise ModelError(
                f"add_servos: model '{model.name}' has no feet, so no default gains (they come from the weight on the legs). "
                "Give kp= and kd=, or load it with feet (load_urdf(feet=[...]))."
            )
        levers = {ft: float(np.sqrt(S)) for ft, (S, _, _) in legs.items()}
        w = 2 * np.pi * f
        k_default = mass * w * w / sum(1.0 / S for S, _, _ in legs.values())
        kp = k_default if kp is None else kp
        kd = 2 * zeta * k_default / w if kd is None else kd
    kp = finite_scalar("add_servos kp", kp, nonnegative=True, unit="N m/rad")
    kd = finite_scalar("add_servos kd", kd, nonnegative=True, unit="N m s/rad")
    offsets = {j: 0.0 for j in sel}
    if gravity_compensation and kp > 0:
        u = static_torques(model, q)
        offsets = {j: u.get(j, 0.0) / kp for j in sel}
    for j in sel:
        model.add_controller(PID(f"{j}.servo", j, kp=kp, kd=kd, setpoint=q[j] + offsets[j], period=period))
    return ServoGains(kp=kp, kd=kd, frequency=f, damping_ratio=zeta, mass=mass, levers=levers, stance={j: q[j] for j in sel},
                      offsets=offsets)
