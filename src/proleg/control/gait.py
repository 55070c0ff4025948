"""Trot gait generator and stance/swing laws for a quadruped (pure JAX functions of t and state).

A :class:`Trot` schedules diagonal pairs: pair 0 (left-front, right-hind) and pair 1 (right-
front, left-hind) half a stride apart; each foot is in stance for ``duty`` of the stride period
and swings for the rest. Before ``t_start`` all four feet stand; the commanded forward speed
ramps linearly from 0 at ``t_start`` to ``speed`` over ``ramp`` seconds, then holds.

Stance: a virtual model (Pratt et al., "Virtual model control", IJRR 2001) on the trunk: the
desired wrench on the trunk COM,

    F = m [k_v (v_cmd − v_x), −k_v v_y, g + ω_z² (z_d − z) − 2 ζ ω_z ż],
    M = −K_R φ − D_R ω     (φ the rotation vector of the trunk's attitude, level and heading +x),

is shared among the stance feet by least norm (Σ F_i = F, Σ r_i × F_i = M; moment rows scaled
by 1/``moment_arm`` and regularised, since a diagonal pair cannot produce a moment about its own
diagonal), each tangential force clipped into 0.6 μ F_z, F_z ≥ 0; a leg makes its ground force
F_i with the joint torques τ = −J_iᵀ F_i (J_i the foot-point Jacobian of the leg's joints).

Swing: a Cartesian PD of the foot on a trajectory from the nominal lift-off point (½ v_cmd T_st
behind the hip's nominal foot point) to the Raibert touchdown point ½ v T_st + k_r (v − v_cmd) ahead
(Raibert, *Legged Robots That Balance*, 1986), smoothstep in the horizontal, h sin(π s) in
height: τ = Jᵀ (K_sw (p_d − p) + D_sw (v_d − v)).
"""

from __future__ import annotations

import dataclasses

import jax.numpy as jnp
import numpy as np

from ..spatial.rotation import skew


@dataclasses.dataclass(frozen=True)
class Trot:
    """Trot schedule and gains (defaults for HyQ, 87 kg; chosen, not fitted to a result).

    Parameters
    ----------
    speed : float [m/s], commanded forward speed after the ramp
    period : float [s], stride period (0.5 s: HyQ's trot ~2 Hz)
    duty : float [-], stance fraction of the stride (> 0.5: both pairs stand briefly)
    step_height : float [m]
    t_start, ramp : float [s], standing time before stepping, speed ramp duration
    raibert_gain : float [s], k_r
    kv : float [1/s], forward/lateral velocity gain of the VMC
    height : float [m], trunk COM height z_d (None: the builder's standing height)
    omega_z, zeta_z : vertical VMC natural frequency [rad/s] and damping ratio
    k_att, d_att : attitude stiffness [N m/rad] and damping [N m s/rad]
    k_swing, d_swing : swing foot PD [N/m, N s/m]
    mu : float, friction coefficient used to clip the stance forces
    moment_arm : float [m], the scale of the moment rows in the force distribution
    """

    speed: float = 1.0
    period: float = 0.5
    duty: float = 0.6
    step_height: float = 0.08
    t_start: float = 0.3
    ramp: float = 1.5
    raibert_gain: float = 0.05
    kv: float = 4.0
    height: float | None = None
    omega_z: float = 9.0
    zeta_z: float = 0.8
    k_att: float = 1500.0
    d_att: float = 150.0
    k_swing: float = 1500.0
    d_swing: float = 40.0
    mu: float = 0.7
    moment_arm: float = 0.3

    def commanded_speed(self, t):
        return self.speed * jnp.clip((t - self.t_start) / self.ramp, 0.0, 1.0)

    def phase(self, t, offset):
        """(in stance, stance progress, swing progress) of a foot whose pair is ``offset`` strides late."""
        s = jnp.mod((t - self.t_start) / self.period + offset, 1.0)
        walking = t >= self.t_start
        stance = (~walking) | (s < self.duty)
        return stance, jnp.clip(s / self.duty, 0, 1), jnp.clip((s - self.duty) / (1 - self.duty), 0, 1)


LEG_OFFSET = {"lf": 0.0, "rh": 0.0, "rf": 0.5, "lh": 0.5}


def foot_jacobian(state, foot, leg_joints):
    """(p, o_1, J) of one leg: the foot marker's position, its first joint's origin and J (3, n),
    the foot's velocity per joint rate (each joint a revolute about the z axis of its J marker)."""
    p = state.marker_position(foot)
    o = [state.marker_position(f"{j}.J") for j in leg_joints]
    a = [state.marker_orientation(f"{j}.J")[:, 2] for j in leg_joints]
    return p, o[0], jnp.stack([jnp.cross(ak, p - ok) for ak, ok in zip(a, o)], axis=1)


def stance_forces(F, M, r_b, feet_p, *, moment_arm, mu, weights=None):
    """The ground forces, one (3,) per foot at ``feet_p``, that carry the trunk wrench (F, M)
    about the trunk position ``r_b``: the least-norm split among the feet whose ``weights`` are 1
    (in stance; default all), the moment scaled by ``moment_arm`` [m] so forces and moments
    weigh alike, then each foot's tangential part clipped to 0.6 ``mu`` f_z (f_z ≥ 0)."""
    A = jnp.concatenate([jnp.concatenate([jnp.eye(3), skew(p - r_b) / moment_arm], axis=0) for p in feet_p], axis=1)  # (6, 3n)
    W = jnp.repeat(jnp.ones(len(feet_p)) if weights is None else weights, 3)
    b = jnp.concatenate([F, M / moment_arm])
    AW = A * W[None, :]
    f_all = W * (AW.T @ jnp.linalg.solve(AW @ A.T + 1e-6 * jnp.eye(6), b))
    out = []
    for k in range(len(feet_p)):
        f = f_all[3 * k : 3 * k + 3]
        fz = jnp.maximum(f[2], 0.0)
        nt = jnp.sqrt(f[:2] @ f[:2] + 1e-12)
        out.append(jnp.concatenate([f[:2] * jnp.minimum(1.0, 0.6 * mu * fz / nt), fz[None]]))
    return out


def quadruped_torques(gait: Trot, t, state, *, legs, joints, feet, base, mass, nominal, foot_height, g=9.81, z_d=None):
    """Joint torques [N m] of the trot law for every joint in ``joints`` (dict leg → 3 joint names).

    ``feet``: leg → foot marker (sphere centre); ``base``: trunk part; ``mass``: total [kg];
    ``nominal``: leg → (2,) horizontal foot offset from its first joint in the trunk's x-y [m];
    ``z_d``: trunk height [m]; ``foot_height``: height of the foot marker standing on the ground
    [m] (a sphere's radius). Returns (dict joint → torque, dict leg → in-stance flag)."""
    r_b, v_b, R, w = state.position(base), state.velocity(base), state.orientation(base), state.angular_velocity(base)
    v_cmd = gait.commanded_speed(t)
    z_d = gait.height if gait.height is not None else z_d
    phi = 0.5 * jnp.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])  # small-angle rotation vector
    F = mass * jnp.array([gait.kv * (v_cmd - v_b[0]), -gait.kv * v_b[1],
                          g + gait.omega_z**2 * (z_d - r_b[2]) - 2 * gait.zeta_z * gait.omega_z * v_b[2]])
    M = -gait.k_att * phi - gait.d_att * w
    info = {}
    for leg in legs:
        p, hip, J = foot_jacobian(state, feet[leg], joints[leg])
        stance, s_st, s_sw = gait.phase(t, LEG_OFFSET[leg])
        info[leg] = dict(p=p, v=state.marker_velocity(feet[leg]), J=J, hip=hip, stance=stance, s_sw=s_sw)
    forces = stance_forces(F, M, r_b, [info[leg]["p"] for leg in legs], moment_arm=gait.moment_arm, mu=gait.mu,
                           weights=jnp.stack([info[leg]["stance"].astype(jnp.float64) for leg in legs]))
    T_st = gait.duty * gait.period
    T_sw = (1 - gait.duty) * gait.period
    tau = {}
    for k, leg in enumerate(legs):
        d = info[leg]
        tau_st = -d["J"].T @ forces[k]
        # swing trajectory
        s = d["s_sw"]
        c, cd = 3 * s**2 - 2 * s**3, 6 * s * (1 - s)
        x_lo = -0.5 * v_cmd * T_st
        x_td = 0.5 * v_b[0] * T_st + gait.raibert_gain * (v_b[0] - v_cmd)
        y_td = 0.5 * v_b[1] * T_st + gait.raibert_gain * v_b[1]
        base_xy = d["hip"][:2] + nominal[leg]
        p_d = jnp.array([base_xy[0] + x_lo + c * (x_td - x_lo), base_xy[1] + c * y_td, foot_height + gait.step_height * jnp.sin(jnp.pi * s)])
        v_d = jnp.array([v_b[0] + cd * (x_td - x_lo) / T_sw, v_b[1] + cd * y_td / T_sw, gait.step_height * jnp.pi * jnp.cos(jnp.pi * s) / T_sw])
        F_sw = gait.k_swing * (p_d - d["p"]) + gait.d_swing * (v_d - d["v"])
        tau_sw = d["J"].T @ F_sw
        tv = jnp.where(d["stance"], tau_st, tau_sw)
        for j, jn in enumerate(joints[leg]):
            tau[jn] = tv[j]
    return tau, {leg: info[leg]["stance"] for leg in legs}


def nominal_offsets(model, legs, joints, feet):
    """leg → (2,) foot offset from its first joint in x-y at the modelled pose [m] (numpy)."""
    return {leg: np.asarray(model.marker(feet[leg]).position[:2] - model.marker(f"{joints[leg][0]}.J").position[:2], float) for leg in legs}
