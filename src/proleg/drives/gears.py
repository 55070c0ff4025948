"""Gear trains with power-flow-dependent efficiency, and the worm gear of FLEGX (seed 002).

Convention: a gear train has an input (motor) side and an output (load) side; the input
turns ``ratio`` times faster than the output, ω_in = ratio · ω_out, in the same sense.
Torques are the torques the train exerts on the load (output) and receives from the motor
(input). Power flows forward (motor drives the load) when τ_in · ω_in > 0, backward (the load
back-drives the motor, e.g. a leg braked by the motor) when τ_in · ω_in < 0.

Sources: seed 002, Eqs. 16–17 (worm efficiency, normal pressure angle) and §II (gear data:
3-start worm, 29-tooth wheel, module 2.5 mm, pressure angle 15°, centre distance 53 mm);
back-driving efficiency: standard worm-gear theory (e.g. Shigley, *Mechanical Engineering
Design*, §13-14; Niemann & Winter).
"""

from __future__ import annotations

import dataclasses
import math

import jax
import jax.numpy as jnp

from ..fn import step

__all__ = ["GearTrain", "output_torque", "input_torque", "WormGear", "worm_mesh", "coulomb_coefficient"]


def _forward_weight(p, speed_eps):
    """1 for forward power flow (p ≥ 0), 0 for backward; blended over ±speed_eps if > 0."""
    eps_pos = speed_eps > 0.0
    eps_safe = jnp.where(eps_pos, speed_eps, 1.0)
    smooth = step(p, -eps_safe, 0.0, eps_safe, 1.0)
    hard = jnp.where(p >= 0.0, 1.0, 0.0)
    return jnp.where(eps_pos, smooth, hard)


@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class GearTrain:
    """Ideal-geometry gear train with Coulomb-type (power-flow-dependent) losses.

    Forward (input power τ_in ω_in ≥ 0, motor drives the load)::

        τ_out = ratio · efficiency · τ_in

    Backward (τ_in ω_in < 0, load back-drives the motor)::

        τ_out = ratio · τ_in / back_efficiency

    i.e. the power that arrives at the motor is back_efficiency times the power the load
    delivers: friction always takes power out. When braking, the load feels ratio/η times the
    motor torque (more than ratio·η). At exactly zero speed the forward branch is used.

    A pytree: ``ratio``, ``efficiency`` and ``back_efficiency`` are leaves (differentiable,
    vmappable).

    Parameters
    ----------
    ratio : float [-]            n = ω_in / ω_out (> 1 for a reduction)
    efficiency : float [-]       η in (0, 1], forward
    back_efficiency : float [-]  η_back in (0, 1] when back-driven; ``None`` (default) → η.
        A self-locking train (worm with η_back ≤ 0) cannot be represented by a torque law:
        it needs a constraint or a stiction element; :meth:`WormGear.gear_train` refuses it.
    """

    ratio: float
    efficiency: float = 1.0
    back_efficiency: float | None = None

    @property
    def eta_back(self):
        return self.efficiency if self.back_efficiency is None else self.back_efficiency


def output_torque(gear: GearTrain, input_torque, output_speed, speed_eps=0.0):
    """Torque on the load for a given motor-side torque (see :class:`GearTrain`).

    Parameters
    ----------
    gear : GearTrain
    input_torque : array_like [N m]      τ_in, motor-side torque
    output_speed : array_like [rad/s]    ω_out (ω_in = ratio · ω_out)
    speed_eps : array_like [rad/s], default 0
        0: hard switch between the branches on the sign of τ_in · ω_out (Coulomb-like, as the
        efficiency model implies). > 0: the efficiency factor is blended with a cubic STEP
        for |ω_out| < speed_eps (smooth; at zero speed the factor is the mean of η and 1/η_back).

    Returns
    -------
    Array [N m], τ_out.
    """
    w = _forward_weight(jnp.sign(input_torque) * output_speed, speed_eps)
    factor = w * gear.efficiency + (1.0 - w) / gear.eta_back
    return gear.ratio * factor * input_torque


def input_torque(gear: GearTrain, output_torque_, output_speed, speed_eps=0.0):
    """Motor-side torque that produces a given load torque (inverse of :func:`output_torque`).

    τ_in = τ_out / (ratio η) forward (τ_out ω_out ≥ 0), τ_in = τ_out η_back / ratio backward.
    Same arguments as :func:`output_torque` with ``output_torque_`` [N m] the load torque.
    """
    w = _forward_weight(jnp.sign(output_torque_) * output_speed, speed_eps)
    factor = w / gear.efficiency + (1.0 - w) * gear.eta_back
    return factor * output_torque_ / gear.ratio


@dataclasses.dataclass(frozen=True)
class WormGear:
    """Worm gear set from its geometry (defaults: FLEGX hip/knee worm drive, seed 002 §II).

    Geometry (axial module m, worm starts z1, wheel teeth z2, centre distance a)::

        d_wheel = z2 m,   d_worm = 2a − z2 m,   tan γ = z1 m / d_worm   (lead angle γ)
        ratio   = z2 / z1
        tan θ_n = tan θ cos γ                                          (seed 002, Eq. 17)

    Efficiency with friction coefficient f (seed 002, Eq. 16, worm driving; the paper calls
    the lead angle α)::

        η      = (cos θ_n − f tan γ) / (cos θ_n + f / tan γ)

    and, wheel driving (back-driving; standard theory, not printed in the seed)::

        η_back = (cos θ_n − f / tan γ) / (cos θ_n + f tan γ)

    The set is self-locking (cannot be back-driven) when η_back ≤ 0, i.e.
    ``f ≥ cos θ_n · tan γ``.

    FLEGX numbers: d_worm = 2·53 − 29·2.5 = 33.5 mm, tan γ = 7.5/33.5 → γ = 12.62°,
    θ_n = 14.65°, ratio 9.667. The f that gives η = 0.60 is 0.1330 (the paper rounds to
    ≈ 0.14; η(0.14) = 0.588), and η_back(0.133) = 0.37: not self-locking
    (self-locking from f = 0.2166).

    Parameters
    ----------
    starts : int                worm threads z1 (default 3)
    wheel_teeth : int           z2 (default 29)
    module : float [m]          axial module of the worm = transverse module of the wheel
                                (default 2.5e-3)
    centre_distance : float [m] a (default 53e-3)
    pressure_angle : float [rad]  θ, axial pressure angle (default 15°); Eq. 17 turns it into
                                the normal pressure angle θ_n
    """

    starts: int = 3
    wheel_teeth: int = 29
    module: float = 2.5e-3
    centre_distance: float = 53e-3
    pressure_angle: float = math.radians(15.0)

    @property
    def ratio(self) -> float:
        """Speed ratio z2 / z1 [-] (9.667 for FLEGX)."""
        return self.wheel_teeth / self.starts

    @property
    def wheel_pitch_diameter(self) -> float:
        """d_wheel = z2 m [m]."""
        return self.wheel_teeth * self.module

    @property
    def worm_pitch_diameter(self) -> float:
        """d_worm = 2a − z2 m [m] (33.5 mm for FLEGX)."""
        return 2.0 * self.centre_distance - self.wheel_pitch_diameter

    @property
    def lead_angle(self) -> float:
        """Lead angle γ [rad], tan γ = z1 m / d_worm (the α of seed 002, Eq. 16)."""
        return math.atan(self.starts * self.module / self.worm_pitch_diameter)

    @property
    def normal_pressure_angle(self) -> float:
        """θ_n [rad], tan θ_n = tan θ cos γ (seed 002, Eq. 17)."""
        return math.atan(math.tan(self.pressure_angle) * math.cos(self.lead_angle))

    def efficiency(self, friction):
        """Worm-driving efficiency η(f) (seed 002, Eq. 16). ``friction`` f [-], traceable."""
        cn, tg = math.cos(self.normal_pressure_angle), math.tan(self.lead_angle)
        return (cn - friction * tg) / (cn + friction / tg)

    def back_efficiency(self, friction):
        """Wheel-driving (back-driving) efficiency η_back(f); ≤ 0 means self-locking."""
        cn, tg = math.cos(self.normal_pressure_angle), math.tan(self.lead_angle)
        return (cn - friction / tg) / (cn + friction * tg)

    @property
    def self_locking_friction(self) -> float:
        """Friction coefficient above which the set is self-locking: f* = cos θ_n tan γ [-]."""
        return math.cos(self.normal_pressure_angle) * math.tan(self.lead_angle)

    def is_self_locking(self, friction):
        """True (array of bool) where η_back ≤ 0, i.e. f ≥ cos θ_n tan γ."""
        return jnp.asarray(friction) >= self.self_locking_friction

    def friction_for_efficiency(self, efficiency):
        """Friction coefficient f that gives the worm-driving efficiency η (inverse of Eq. 16).

        Closed form: ``f = cos θ_n (1 − η) / (tan γ + η / tan γ)``. For FLEGX and η = 0.60
        (seed 002: declared 0.64, assumed 0.60) this gives f = 0.1330.
        """
        cn, tg = math.cos(self.normal_pressure_angle), math.tan(self.lead_angle)
        return cn * (1.0 - efficiency) / (tg + efficiency / tg)

    def gear_train(self, friction) -> GearTrain:
        """A :class:`GearTrain` (ratio z2/z1, η(f), η_back(f)) for a concrete friction f.

        Raises ``ValueError`` if the set is self-locking at this f (a torque law cannot
        represent it; model the lock with a constraint or stiction element instead).
        """
        f = float(friction)
        if f >= self.self_locking_friction:
            raise ValueError(
                f"WormGear: friction f = {f:g} ≥ cos θ_n tan γ = {self.self_locking_friction:.4f}, so the "
                "worm is self-locking and cannot be back-driven; a GearTrain torque law cannot represent "
                "that. Use a lower f, or model the lock with a constraint/stiction element."
            )
        return GearTrain(self.ratio, float(self.efficiency(f)), float(self.back_efficiency(f)))


def coulomb_coefficient(v, f_static, f_dynamic, v_static, v_dynamic):
    """Signed, regularised Coulomb coefficient μ(v) [-] (the Adams friction law, cubic STEPs):
    μ = STEP(v, −v_s, −f_s, v_s, f_s) for |v| ≤ v_s, then sign(v)·STEP(|v|, v_s, f_s, v_d, f_d)
    up to v_d and f_d sign(v) beyond. ``v_static`` < ``v_dynamic`` [m/s], traceable."""
    a = jnp.abs(v)
    inner = step(v, -v_static, -f_static, v_static, f_static)
    outer = jnp.sign(v) * step(a, v_static, f_static, v_dynamic, f_dynamic)
    return jnp.where(a <= v_static, inner, outer)


def worm_mesh(worm: WormGear, s, s_dot, phi, phi_dot, stiffness, damping, f_static, f_dynamic, v_static, v_dynamic):
    """Compliant worm-wheel mesh with sliding friction: loads on the worm and the wheel.

    Kinematics. ``s`` [m] is the worm's rotation as arc length on its pitch circle (s = r1 φ_w),
    ``phi`` [rad] the wheel's rotation; both from the pose where the mesh is unloaded, in the
    senses where a positive worm turn drives the wheel positive (rigid mesh: s = n r1 φ). With
    the lead angle γ and the pitch radii r1 (worm), r2 (wheel), the tooth approach along the
    thread normal in the pitch plane and the sliding speed along the thread are::

        δ = s sin γ − r2 φ cos γ,          v_s = ṡ cos γ + r2 φ̇ sin γ

    Loads. Pitch-plane normal force P = k δ + c δ̇ (signed: which flank), tooth normal force
    W = |P| / cos θ_n (seed 002 Eq. 17 for θ_n), friction μ(v_s) W against the sliding with
    μ = :func:`coulomb_coefficient` (static f_s below v_static, dynamic f_d above v_dynamic)::

        torque on the wheel      T = r2 (P cos γ − μ W sin γ)
        force on the worm        F = −(P sin γ + μ W cos γ)     (tangential at r1; torque r1 F)

    The mesh's power is F ṡ + T φ̇ = −P δ̇ − μ W v_s: the spring-damper's power and the friction
    loss μ W v_s ≥ 0. Steady sliding (δ̇ = 0) with the worm driving gives T φ̇ = η · (−F ṡ) with
    η of Eq. 16 (:meth:`WormGear.efficiency`); with the wheel driving, η_back. With the worm
    free (F = 0) the wheel is held when f_s ≥ cos θ_n tan γ (self-locking): the regularised
    friction then lets it creep at |v_s| < v_static only.

    Parameters
    ----------
    worm : WormGear
    s, s_dot : [m], [m/s];  phi, phi_dot : [rad], [rad/s]   (traceable arrays)
    stiffness : [N/m], damping : [N s/m]   of the pitch-plane normal (torsional stiffness at the
        wheel k (r2 cos γ)²)
    f_static, f_dynamic : [-];  v_static, v_dynamic : [m/s]   friction law

    Returns
    -------
    dict: ``wheel_torque`` T [N m], ``worm_force`` F [N], ``normal_force`` W [N],
    ``pitch_force`` P [N], ``sliding_speed`` v_s [m/s], ``mu`` [-], ``friction_power`` μ W v_s
    [W], ``approach`` δ [m], ``approach_rate`` δ̇ [m/s], ``spring_energy`` k δ²/2 [J].
    """
    r1, r2 = 0.5 * worm.worm_pitch_diameter, 0.5 * worm.wheel_pitch_diameter
    sg, cg = math.sin(worm.lead_angle), math.cos(worm.lead_angle)
    cn = math.cos(worm.normal_pressure_angle)
    delta = s * sg - r2 * phi * cg
    ddelta = s_dot * sg - r2 * phi_dot * cg
    vs = s_dot * cg + r2 * phi_dot * sg
    P = stiffness * delta + damping * ddelta
    W = jnp.abs(P) / cn
    mu = coulomb_coefficient(vs, f_static, f_dynamic, v_static, v_dynamic)
    return dict(wheel_torque=r2 * (P * cg - mu * W * sg), worm_force=-(P * sg + mu * W * cg), normal_force=W, pitch_force=P,
                sliding_speed=vs, mu=mu, friction_power=mu * W * vs, approach=delta, approach_rate=ddelta,
                spring_energy=0.5 * stiffness * delta**2)
