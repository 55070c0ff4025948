"""Battery–amplifier–DC motor–gear drive of Scout II (seed 003, §4.1, Eqs. 3–14, Table 3).

Chain: battery (ideal source V_nom behind R_s, Eq. 9) → PWM amplifier in current mode
(i = k_amp V_in, peak current i_max, Eq. 10) → brushed DC motor (τ_m = K_T i,
V_t = R_a i + K_ω ω_m, inductance neglected, Eq. 12) → planetary gearbox and belt/pulley
(combined speed ratio β, torque ratio with losses α, Eq. 5) → leg.

Sign convention: leg torque τ and leg speed φ̇ are positive in the same sense (seed 003,
Fig. 3: positive torque moves the leg forward). Stance-retraction runs in the third quadrant
(τ < 0, φ̇ < 0), flight mostly in the first; both are *motoring* (power flows to the leg).
Quadrants 2 and 4 are *back-driven*: the leg drives the motor (braking/regeneration).

Losses: when the motor drives the leg, the leg gets α K_T i = (β η) K_T i with η = α/β the
combined efficiency (Eq. 5). When the leg back-drives the motor we apply the efficiency the
other way: the leg feels (β/η) K_T i = (β²/α) K_T i (friction always takes power out; see
:class:`~proleg.drives.gears.GearTrain`). In the motoring quadrants every formula below
reduces exactly to the paper's Eqs. 3–4, 6, 11, 13–14. Seed 003 itself uses α in all
quadrants ("the maximum gearbox efficiency was used to command and estimate torques").

Saturation (Eqs. 10–14) in closed form: the delivered motor current is the commanded one,
clipped first by the amplifier peak current (|i| ≤ i_max, Eq. 6) and then by the voltage
limit. In saturation the amplifier is an ideal conductor between battery and motor (seed 003,
Fig. 8 right), so V_nom − |i| R_s = ±(R_a i + K_ω ω_m) and::

    i_v,max = ( V_nom − K_ω ω_m) / (R_a + R_s)      (full forward voltage)
    i_v,min = (−V_nom − K_ω ω_m) / (R_a + R_s)      (full reverse voltage)

With ``battery=False`` the supply is the fixed V = 36 V of Eq. 4 (R_s = 0), which gives the
paper's torque–speed line τ = −τ_max + A φ̇ in the third quadrant (Eq. 3–4, 13).

Electrical power: the amplifier is lossless, so the battery delivers the power into the motor
terminals, ``P_el = V_t i = R_a i² + K_ω ω_m i`` (copper loss + converted power); the battery
current is i_s = P_el / V_s with V_s = V_nom − i_s R_s (root of V_s² − V_nom V_s + R_s P_el
= 0), which equals |i| in saturation (consistent with the limits above). P_el is the
"product of battery current and voltage" of seed 003 (footnote 2) used for the electrical
specific resistance.
"""

from __future__ import annotations

import dataclasses
from typing import NamedTuple

import jax
import jax.numpy as jnp

from ..units import g_gravity
from .belt import BeltLoss, belt_input_torque, belt_output_torque
from .gears import GearTrain

__all__ = [
    "DCMotorDrive",
    "DRIVE_NUMBERS",
    "DriveOutput",
    "torque_speed_line",
    "torque_speed_limits",
    "delivered_torque",
    "specific_resistance",
]


@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class DCMotorDrive:
    """Parameters of one Scout II hip drive (seed 003, Table 3 and §4.1); a frozen pytree.

    All fields are leaves (differentiable, vmappable, identifiable); derived quantities are
    properties. Use ``dataclasses.replace(drive, R_a=1.5)`` for a variant. On a
    :class:`~proleg.JointActuator` of an assembled model the fields are parameters,
    ``joint_actuator_drive_<field>`` (:data:`DRIVE_NUMBERS`; the belt stage's
    ``joint_actuator_belt_<field>``), one entry per actuator: the law reads them from
    ``System.params``, so models with other drives share their compiled functions (issue 42).

    Parameters
    ----------
    K_T : float [N m/A]        torque constant, 0.0389 (Table 3)
    K_omega : float [V s/rad]  speed constant, 0.0389. **Interpreted**: printed "6.7810*"
        V/(deg/s) in Table 3, read as 6.78e-4 V/(deg/s) = 0.03885 V s/rad, and the value of
        K_T (SI motor, K_ω = K_T) is used (MODEL_DATA §4).
    R_a : float [Ω]            armature resistance, 1.23
    belt_ratio : float [-]     belt and pulley ratio n_p, 48/34
    belt_efficiency : float [-]  η_p, 0.96
    gear_ratio : float [-]     planetary gearbox ratio n_g, 72.38
    gear_efficiency : float [-]  η_g (maximum efficiency of the gearbox), 0.68
    V_supply : float [V]       average motor voltage of Eq. 4, 36 (used with ``battery=False``)
    i_max : float [A]          amplifier peak current, 20
    k_amp : float [A/V]        amplifier gain i = k_amp V_in (Eq. 10). **Interpreted**: printed
        "43 A/V", read as 4.3 A/V; irrelevant when a torque (current) is commanded.
    V_nom : float [V]          battery open-circuit voltage, 37.17 (Eq. 9, least-squares fit)
    R_s : float [Ω]            battery series resistance, 0.13 (Eq. 9)
    gear_drag : float [N m]    no-load (Coulomb) drag of motor and gearbox at the motor shaft,
        default 0 (the paper's constant-efficiency drive). With it the efficiency depends on
        the load: see :meth:`efficiency_at`.
    gear_viscous : float [N m s/rad]  speed-proportional drag at the motor shaft (churning,
        seals), default 0: the efficiency then falls with speed.
    drag_speed : float [rad/s]  motor speed over which the Coulomb drag is smoothed (tanh), 1.0
    belt : :class:`~proleg.drives.belt.BeltLoss` or None (default)
        None: the belt stage is the constant ``belt_efficiency`` of Table 3, folded into α.
        Given: the belt stage's load- and speed-dependent losses replace ``belt_efficiency`` in
        the delivered torque (the planetary keeps η_g and its drag); ``alpha``, ``tau_max`` and
        ``A`` (the controller's Eqs. 3–5) keep the paper's constant 96 %.

    Transmission law (Pelchen, Schweiger & Otter 2002, "Modeling and simulating the efficiency
    of gearboxes and of planetary gearboxes", the form of Modelica's LossyGear and of Adams
    Machinery's gear efficiency): the drag τ_d(ω_m) = gear_drag tanh(ω_m / drag_speed) +
    gear_viscous ω_m is taken off the motor torque K_T i before the mesh; the mesh torque
    τ_g = K_T i − τ_d then reaches the leg as β η τ_g when power flows to the leg
    (τ_g ω_m ≥ 0) and as (β / η) τ_g when the leg back-drives the motor, η = η_g η_p.
    The effective efficiency τ φ̇ / (K_T i ω_m) = η (1 − τ_d / K_T i) (forward) grows with the
    load towards η (the catalogue's "maximum efficiency", seed 003 §5.3) and falls with speed.
    """

    K_T: float = 0.0389
    K_omega: float = 0.0389
    R_a: float = 1.23
    belt_ratio: float = 48.0 / 34.0
    belt_efficiency: float = 0.96
    gear_ratio: float = 72.38
    gear_efficiency: float = 0.68
    V_supply: float = 36.0
    i_max: float = 20.0
    k_amp: float = 4.3
    V_nom: float = 37.17
    R_s: float = 0.13
    gear_drag: float = 0.0
    gear_viscous: float = 0.0
    drag_speed: float = 1.0
    belt: BeltLoss | None = None

    def drag_torque(self, motor_speed):
        """τ_d(ω_m) [N m]: no-load drag at the motor shaft (see the class docstring)."""
        return self.gear_drag * jnp.tanh(motor_speed / self.drag_speed) + self.gear_viscous * motor_speed

    def efficiency_at(self, motor_torque, motor_speed):
        """Effective transmission efficiency [-] at motor torque K_T i [N m] and speed ω_m [rad/s]:
        leg power over motor shaft power when the motor drives (η (1 − τ_d/τ_m)); shaft power
        over leg power when the leg drives the motor. Depends on load, speed and power flow."""
        tau_g = motor_torque - self.drag_torque(motor_speed)
        fwd = tau_g * motor_speed >= 0.0
        p_leg = jnp.where(fwd, self.efficiency * tau_g, tau_g / self.efficiency) * motor_speed
        p_shaft = motor_torque * motor_speed
        return jnp.where(fwd, p_leg / p_shaft, p_shaft / p_leg)

    @property
    def alpha(self):
        """α = (n_g η_g)(n_p η_p) [-]: leg torque per motor torque, motoring (Eq. 5)."""
        return (self.gear_ratio * self.gear_efficiency) * (self.belt_ratio * self.belt_efficiency)

    @property
    def beta(self):
        """β = n_g n_p [-]: motor speed per leg speed (Eq. 5)."""
        return self.gear_ratio * self.belt_ratio

    @property
    def efficiency(self):
        """Combined transmission efficiency η = α/β = η_g η_p [-]."""
        return self.gear_efficiency * self.belt_efficiency

    @property
    def transmission(self) -> GearTrain:
        """The gearbox + belt as one :class:`GearTrain` (ratio β, efficiency α/β both ways)."""
        return GearTrain(self.beta, self.efficiency, self.efficiency)

    @property
    def tau_max(self):
        """τ_max = α K_T V / R_a [N m]: stall torque at the leg at V = V_supply (Eq. 4)."""
        return self.alpha * self.K_T * self.V_supply / self.R_a

    @property
    def A(self):
        """A = −β α K_T K_ω / R_a [N m s/rad]: slope of the leg torque–speed line (Eq. 4)."""
        return -self.beta * self.alpha * self.K_T * self.K_omega / self.R_a

    @property
    def tau_current_limit(self):
        """α K_T i_max [N m]: leg torque at the amplifier peak current, motoring (Eq. 6)."""
        return self.alpha * self.K_T * self.i_max

    @property
    def no_load_speed(self):
        """V / (β K_ω) [rad/s]: leg speed at which the torque–speed line reaches 0 (V = V_supply)."""
        return self.V_supply / (self.beta * self.K_omega)


#: The fields of :class:`DCMotorDrive` that are numbers of its law: every field but ``belt``
#: (whether a belt stage is modelled is structure; its numbers are :data:`~proleg.drives.belt.BELT_NUMBERS`).
#: An assembled model carries them as parameters ``joint_actuator_drive_<field>`` (one entry per
#: joint actuator), so that a drive with another gear ratio or motor is a new argument of the
#: compiled model, not a new compile (issue 42).
DRIVE_NUMBERS = tuple(f.name for f in dataclasses.fields(DCMotorDrive) if f.name != "belt")


def _source(drive: DCMotorDrive, battery: bool):
    """(open-circuit voltage, series resistance) of the supply."""
    if battery:
        return drive.V_nom, drive.R_s
    return drive.V_supply, 0.0


def _leg_torque(drive: DCMotorDrive, current, leg_speed):
    """Leg torque [N m] for a motor current: β η τ_g motoring (τ_g φ̇ ≥ 0), (β / η) τ_g
    back-driven, with the mesh torque τ_g = K_T i − τ_d(β φ̇) (no drag: α K_T i, (β²/α) K_T i).
    With a ``belt`` (:class:`~proleg.drives.belt.BeltLoss`): the planetary's β η_g τ_g (or
    β τ_g / η_g) enters the belt stage, whose law gives the leg torque."""
    tau_g = drive.K_T * current - drive.drag_torque(drive.beta * leg_speed)
    motoring = tau_g * leg_speed >= 0.0
    if drive.belt is None:
        return tau_g * jnp.where(motoring, drive.alpha, drive.beta**2 / drive.alpha)
    eta_g = drive.gear_efficiency
    tau_in = tau_g * drive.beta * jnp.where(motoring, eta_g, 1.0 / eta_g)
    return belt_output_torque(drive.belt, tau_in, leg_speed)


def _current(drive: DCMotorDrive, tau, leg_speed):
    """Motor current [A] that delivers leg torque τ (inverse of :func:`_leg_torque`: the map is
    monotone, and the mesh torque has the sign of τ, or of τ + the belt drag with a belt)."""
    if drive.belt is None:
        motoring = tau * leg_speed >= 0.0
        tau_g = tau / jnp.where(motoring, drive.alpha, drive.beta**2 / drive.alpha)
    else:
        tau_in = belt_input_torque(drive.belt, tau, leg_speed)
        eta_g = drive.gear_efficiency
        tau_g = tau_in / (drive.beta * jnp.where(tau_in * leg_speed >= 0.0, eta_g, 1.0 / eta_g))
    return (tau_g + drive.drag_torque(drive.beta * leg_speed)) / drive.K_T


def torque_speed_line(drive: DCMotorDrive, leg_speed, V=None):
    """Commanded stance-retraction torque on the saturation line, Eq. 3: −τ_max + A φ̇ [N m].

    τ_max and A of Eq. 4 evaluated at the voltage V [V] (default ``drive.V_supply`` = 36 V).
    This is the third-quadrant voltage limit of :func:`torque_speed_limits` without the
    current limit or battery sag. ``leg_speed`` φ̇ [rad/s].
    """
    V = drive.V_supply if V is None else V
    tau_max = drive.alpha * drive.K_T * V / drive.R_a
    return -tau_max + drive.A * leg_speed


def _current_limits(drive, motor_speed, V_src, R_src):
    r = drive.R_a + R_src
    iv_hi = (V_src - drive.K_omega * motor_speed) / r
    iv_lo = (-V_src - drive.K_omega * motor_speed) / r
    # current limit first, then voltage limit: above the speed where even full reverse voltage
    # cannot hold |i| ≤ i_max, the voltage limit wins (the amplifier cannot prevent it).
    i_hi = jnp.clip(drive.i_max, iv_lo, iv_hi)
    i_lo = jnp.clip(-drive.i_max, iv_lo, iv_hi)
    return i_lo, i_hi


def torque_speed_limits(drive: DCMotorDrive, leg_speed, V=None, battery=False):
    """Four-quadrant torque–speed envelope at the leg: (τ_min, τ_max) [N m] at speed φ̇.

    The motor current is limited by the amplifier (|i| ≤ i_max, Eq. 6) and by the supply
    voltage (|R_a i + K_ω ω_m| ≤ V_s, Eqs. 11–12), ω_m = β φ̇. Currents are turned into leg
    torques with α K_T where the motor drives the leg and (β²/α) K_T where the leg back-drives
    it (see module docstring). In the third quadrant (motoring, φ̇ < 0) and with
    ``battery=False``::

        τ_min = max(−α K_T i_max, −τ_max + A φ̇)                     (Eqs. 3–4, 6, 13–14)

    Parameters
    ----------
    drive : DCMotorDrive
    leg_speed : array_like [rad/s]   φ̇
    V : array_like [V], optional     supply voltage (default ``drive.V_supply``); only with
                                     ``battery=False``
    battery : bool (static), default False
        True: supply is the battery model of Eq. 9 (V_nom behind R_s), solved in closed form
        for the saturated current i = (±V_nom − K_ω ω_m)/(R_a + R_s).

    Returns
    -------
    (tau_min, tau_max) : tuple of Array [N m]
    """
    if battery and V is not None:
        raise ValueError("torque_speed_limits: pass either V (fixed supply) or battery=True, not both.")
    V_src, R_src = _source(drive, battery)
    if V is not None:
        V_src = V
    w_m = drive.beta * leg_speed
    i_lo, i_hi = _current_limits(drive, w_m, V_src, R_src)
    tau_lo = _leg_torque(drive, i_lo, leg_speed)
    tau_hi = _leg_torque(drive, i_hi, leg_speed)
    return tau_lo, tau_hi


class DriveOutput(NamedTuple):
    """Result of :func:`delivered_torque` (a pytree of arrays)."""

    torque: jnp.ndarray  # [N m] torque delivered at the leg
    current: jnp.ndarray  # [A] motor (armature) current
    motor_speed: jnp.ndarray  # [rad/s] ω_m = β φ̇
    terminal_voltage: jnp.ndarray  # [V] V_t = R_a i + K_ω ω_m
    supply_voltage: jnp.ndarray  # [V] battery terminal voltage V_s (V_supply if no battery)
    supply_current: jnp.ndarray  # [A] battery current i_s = P_el / V_s
    electrical_power: jnp.ndarray  # [W] P_el = V_t i = R_a i² + K_ω ω_m i = V_s i_s
    mechanical_power: jnp.ndarray  # [W] τ φ̇ at the leg
    saturated: jnp.ndarray  # bool: the command was clipped (current or voltage limit)


def delivered_torque(drive: DCMotorDrive, tau_command, leg_speed, battery=True, V=None) -> DriveOutput:
    """Leg torque the drive actually delivers for a commanded leg torque (seed 003, Eqs. 6–14).

    ``τ = clip(τ_cmd, τ_min(φ̇), τ_max(φ̇))`` with the envelope of :func:`torque_speed_limits`
    (current limit and voltage limit with battery sag). The leg-torque ↔ current map is
    monotone (slope α K_T motoring, (β²/α) K_T back-driven), so clipping the torque is clipping
    the current; the current is then ``i = τ / (α K_T)`` (or ``τ α / (β² K_T)``), and the
    electrical quantities follow (see module docstring).

    Eq. 7 (τ_des > 0 clipped to 0 during stance-retraction) is a controller rule and is not
    applied here.

    Parameters
    ----------
    drive : DCMotorDrive
    tau_command : array_like [N m]   commanded leg torque
    leg_speed : array_like [rad/s]   φ̇
    battery : bool (static), default True   battery model (Eq. 9) or fixed V_supply
    V : array_like [V], optional
        A given supply voltage at the amplifier (overrides ``battery``): the terminal voltage of
        a battery shared by several drives, solved by :func:`proleg.drives.battery.shared_supply`.

    Returns
    -------
    :class:`DriveOutput`
    """
    if V is not None:
        battery = False
    V_src, R_src = _source(drive, battery)
    if V is not None:
        V_src = V
    w_m = drive.beta * leg_speed
    tau_lo, tau_hi = torque_speed_limits(drive, leg_speed, V=V, battery=battery)
    tau = jnp.clip(tau_command, tau_lo, tau_hi)
    i = _current(drive, tau, leg_speed)
    v_t = drive.R_a * i + drive.K_omega * w_m
    p_el = v_t * i
    if battery:
        disc = V_src * V_src - 4.0 * R_src * p_el
        disc_pos = disc > 0.0
        v_s = 0.5 * (V_src + jnp.sqrt(jnp.where(disc_pos, disc, 1.0)) * disc_pos)
    else:
        v_s = jnp.broadcast_to(jnp.asarray(V_src, dtype=p_el.dtype), p_el.shape)
    i_s = p_el / v_s
    return DriveOutput(
        torque=tau,
        current=i,
        motor_speed=w_m,
        terminal_voltage=v_t,
        supply_voltage=v_s,
        supply_current=i_s,
        electrical_power=p_el,
        mechanical_power=tau * leg_speed,
        saturated=tau != tau_command,
    )


def specific_resistance(power, mass, speed, g=g_gravity):
    """Specific resistance ε = P / (m g v) [-] (seed 003, Eq. 8; Gabrielli–von Kármán).

    Parameters
    ----------
    power : array_like [W]     average power (mechanical output or electrical input)
    mass : array_like [kg]     vehicle mass
    speed : array_like [m/s]   average forward speed
    g : float [m/s²]           gravitational acceleration, default 9.80665

    Scout II (seed 003): 0.47 mechanical and ≈ 1.4 electrical at 1.3 m/s.
    """
    return power / (mass * g * speed)
