"""Scout II bounding quadruped in the sagittal plane (seed 003; MODEL_DATA §4).

:func:`scout2` builds the planar model of seed 003 §2.3 (Fig. 3) with proleg elements:

- **body**: one part (Table 6: 20.865 kg, 1.3 kg m²), held in the sagittal x–z plane by a
  ``Planar`` joint to ground (x forward, z up, pitch about −y: positive nose-up).
- **virtual legs** back and front at ∓0.276 m (half hip spacing), each an *upper leg* on a hip
  ``Revolute`` (axis −y, so a positive leg angle φ swings the toe forward, seed 003 Fig. 3) and
  a *lower leg* on a ``Prismatic`` joint along the leg, the leg spring-damper between hip and
  toe (free length = nominal length 0.323 m), a ``JointStop`` at the nominal length (the leg
  extension stop), and a toe ``SphereContact`` on the ground with Coulomb friction μ.
  Table 6's leg values (mass, inertia, spring, damping) are a virtual leg's (``per="virtual"``,
  the default; scout2_data quotes the sentences of seed 003 §2.3, Table 2 and §5.1 that decide
  it). The leg mass and inertia are split between upper and lower leg by
  ``lower_mass_fraction`` (default 0.3: the telescoping lower tube and toe), with the COMs at
  ``upper_com`` and ``lower_com`` from the hip (0.12 m and 0.27 m: the leg's COM at 0.165 m,
  half-way down the leg's upper part where the spring housing is), the inertia split in the
  same proportion. The paper's one-body leg does not say; these are parameters.
- **drives**: one equivalent virtual motor per virtual leg (two physical motors in parallel:
  same K_T and K_ω, half R_a, twice the peak current; scout2_data), the DC motor + amplifier
  (current mode, 20 A peak per motor) + planetary 72.38 (68 %) + belt 48/34 (96 %) of
  :class:`proleg.drives.DCMotorDrive`, all on one shared ``Battery`` (37.17 V, 0.13 Ω; Eq. 9
  with the total current).
- **Model I**: the delivered leg torque acts at the hip joint directly.
  **Model II** (§4.2, Fig. 10, Table 5): per virtual leg a *drive gear* part (motor side) and a
  *driven gear* part on revolute joints to the body at the hip, a ``Coupler`` of ratio
  β = n_g n_p = 102.2 between them (the gear constraint), the drive on the drive-gear joint
  (``motor_side``: the motor speed is the drive gear's), joint stiction and damping on the hip
  (``JointFriction``), and the belt + backlash as a ``RotationalSpringDamper`` between driven
  gear and leg (7.0 N m/deg: 7.4° at the 51.9 N m full torque of one motor). Model II also
  carries the dissipation the paper blames but does not model (§5.2–5.3): stick–slip friction
  in each telescopic leg growing with the leg's side load (``SlideFriction``: the toe's ground
  reaction normal to the leg and its bending moment over the bushing overlap) and a gearbox
  drag that makes the transmission efficiency depend on load, speed and the direction of power
  flow (``DCMotorDrive.gear_drag``/``gear_viscous``), and a belt stage whose losses depend on
  the transmitted torque and speed (``DCMotorDrive.belt``, :mod:`proleg.drives.belt`: Table 3's
  96 % at full torque, less at part load). Their values are estimates with ranges
  (scout2_data); they are not calibrated. The one calibrated quantity is the leg damping
  (issue 44, :mod:`proleg.papers.scout2_reading`: fitted on the robot's measured speed).

Leg geometry: Table 6's leg length 0.323 m (Table 2 "l0 nominal leg length") is the hip-to-ground
length of the fully extended leg: the toe sphere's centre sits ``toe_radius`` up the leg from
the toe's ground point (the contact marker ``{leg}_toe_centre``; ``{leg}_toe`` is the ground
point, where the leg spring ends).

Initial condition (both models): at rest in the standing posture, legs vertical, released
``height − leg_length`` (3 cm) above touching; the controller must bring the robot into the
bound. Seed 003 prints no start-up procedure, and its controller cannot start from rest by
itself: stance-brake is left only at lift-off (§3.1, Fig. 4), so a robot standing at rest on
both braked legs stays there (the *stance-brake stall*, :func:`proleg.papers.scout2_bound.stance_brake_stall`).
The small drop is this model's start (an interpretation, kept as the ``height`` parameter): the
controllers start in flight, servo the legs to the touchdown angles and land on both.

The controller (§3.1, Table 4) is a :class:`proleg.StateMachine` per virtual leg at 1 kHz, see
:func:`bounding_controller`. Every number is a keyword argument (names in
:class:`Scout2Params`); :func:`scout2` returns the Model with ``model.scout2`` = the
:class:`Scout2Info` (the parameters, derived values and a parameter table with sources).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import jax.numpy as jnp
import numpy as np

from ..drives.belt import scout2_belt
from ..drives.dcmotor import DCMotorDrive
from ..errors import ModelError
from ..model.contacts import SphereContact
from ..model.control import Battery, JointActuator, StateMachine
from ..model.couplers import Coupler, JointFriction, JointStop
from ..model.forces import RotationalSpringDamper, SpringDamper
from ..model.friction import SlideFriction
from ..model.joints import Planar, Prismatic, Revolute
from ..model.model import Model
from ..units import deg
from . import scout2_data as D

__all__ = ["scout2", "Scout2Params", "Scout2Info", "bounding_controller", "LEG_STATES", "LEGS"]

LEGS = ("back", "front")
LEG_STATES = ("flight", "retraction", "brake")  # StateMachine state index 0, 1, 2
HIP_AXIS = (0.0, -1.0, 0.0)  # positive leg angle and pitch: toe forward, nose up


@dataclass
class Scout2Params:
    """Every parameter of :func:`scout2` (SI; angles in rad). Defaults: seed 003 (scout2_data).

    Designs and compiles (issue 42): every number here reaches the compiled model as an entry of
    ``System.params`` (masses, geometry, springs, contact, the drive's fields as
    ``joint_actuator_drive_*`` and its belt stage's as ``joint_actuator_belt_*``, the controller's
    gains, set points, thresholds and retraction-law numbers as design variables), so two designs
    that differ only in numbers share one trace (``proleg.analyses.structure.numbers_read`` of the
    assembled model is empty). Structure, where a change compiles anew: the model ("I"/"II"),
    ``angle_sensor`` (which joint the controller reads), ``control_period`` (the controllers'
    clock), whether ``leg_mu`` is positive (Model II: the leg friction elements exist or not) and
    whether the drive models its belt stage (``drive.belt`` given, or Model II). Numbers the
    builder derives (the virtual motor of ``motors_per_leg`` motors, the belt stage's drag, the
    retraction law's τ_max, A, α K_T i_max) are computed at build time: a new design is a new
    ``scout2(...)`` call, not a ``with_params`` of the drive's entries.
    """

    body_mass: float = D.BODY_MASS
    body_inertia: float = D.BODY_INERTIA
    leg_mass: float = D.LEG_MASS
    leg_inertia: float = D.LEG_INERTIA
    leg_stiffness: float = D.LEG_STIFFNESS
    leg_damping: float = D.LEG_DAMPING  # N s/m, Table 6 as printed (per virtual leg by default, see ``per``)
    half_hip_spacing: float = D.HIP_SEPARATION / 2
    leg_length: float = D.LEG_LENGTH
    lower_mass_fraction: float = 0.3
    upper_com: float = 0.12
    lower_com: float = 0.27
    toe_radius: float = 0.02
    contact_stiffness: float = 1e6  # N/m^1.5
    contact_exponent: float = 1.5
    contact_damping: float = 2e3
    contact_penetration: float = 1e-3
    mu: float = 0.8  # toe–ground friction (unknown in the paper: §5.2 blames it for part of the error)
    v_stiction: float = 0.02
    v_friction: float = 0.05
    stop_stiffness: float = 2e5  # N/m, leg extension stop (per physical leg)
    stop_damping: float = 200.0  # N s/m
    # drives (Table 3) and battery (Eq. 9)
    drive: DCMotorDrive = field(default_factory=DCMotorDrive)
    motors_per_leg: int = 2
    V_nom: float = 37.17
    R_s: float = 0.13
    # controller (Table 4, per physical leg; the virtual leg's gains are motors_per_leg times)
    touchdown_back: float = D.TOUCHDOWN_BACK
    touchdown_front: float = D.TOUCHDOWN_FRONT
    sweep_back: float = D.SWEEP_LIMIT_BACK
    sweep_front: float = D.SWEEP_LIMIT_FRONT
    flight_kp: float = D.FLIGHT_KP
    flight_kd: float = D.FLIGHT_KD
    brake_kp: float = D.BRAKE_KP
    brake_kd: float = D.BRAKE_KD
    control_period: float = D.CONTROL_PERIOD
    touchdown_compression: float = 0.005  # m, leg compression that signals touchdown (potentiometer)
    liftoff_compression: float = 0.003  # m, compression below which the leg has lifted off
    # Model II hip unit (Table 5, per physical leg)
    drive_gear_inertia: float = D.DRIVE_GEAR_INERTIA
    driven_gear_inertia: float = D.DRIVEN_GEAR_INERTIA
    joint_stiction: float = D.JOINT_STICTION
    joint_damping: float = D.JOINT_DAMPING
    belt_stiffness: float = D.BELT_STIFFNESS
    belt_damping: float = D.BELT_DAMPING
    angle_sensor: str = "motor"  # Model II: leg angle from the motor encoder ("motor") or at the leg ("leg")
    # Model II dissipation the paper blames but does not model (§5.2, §5.3; ranges in scout2_data)
    leg_mu: float = D.LEG_MU  # sliding friction coefficient of the telescopic leg's bushings
    leg_mu_static_ratio: float = D.LEG_MU_STATIC_RATIO  # μ_s / μ_d
    leg_overlap: float = D.LEG_OVERLAP  # m, bushing overlap (bending moment arm)
    leg_bearing: float = D.LEG_BEARING  # m, bushing centre below the hip
    leg_v_stiction: float = 1e-3  # m/s
    leg_v_friction: float = 5e-3  # m/s
    gear_drag: float = D.GEAR_DRAG  # N m at the motor shaft, per motor
    gear_viscous: float = D.GEAR_VISCOUS  # N m s/rad at the motor shaft, per motor
    belt_no_load: float = D.BELT_NO_LOAD  # -, belt no-load drag / full leg torque (Model II, proleg.drives.belt)
    # initial condition: at rest in the standing posture (legs vertical, no speed, no pitch),
    # released ``drop`` above the height where the toes touch; the controller starts in flight
    # and brings the robot into the bound (the same start for both models)
    height: float = D.LEG_LENGTH + 0.03  # m, body COM above ground at t = 0 (leg length l0 to the toe's ground point + 3 cm drop)
    speed: float = 0.0  # m/s forward
    pitch: float = 0.0  # rad, nose-up positive
    pitch_rate: float = 0.0  # rad/s, nose-up positive
    leg_angle_back: float = 0.0  # rad, leg angles relative to the body at t = 0
    leg_angle_front: float = 0.0


@dataclass
class Scout2Info:
    """What :func:`scout2` built: ``variant`` ("I"/"II"), ``per``, ``params``, the virtual
    ``drive``, ``leg_joints`` / ``hip_joints`` / ``angle_joints`` (name per leg), and
    ``parameters``: rows (name, value, unit, source) for the report."""

    variant: str
    per: str
    params: Scout2Params
    drive: DCMotorDrive
    hip_joints: dict
    leg_joints: dict
    angle_joints: dict
    motors: dict
    parameters: list = field(default_factory=list)


def _check(p: Scout2Params, variant, per):
    if variant not in ("I", "II"):
        raise ModelError(f"scout2: model must be 'I' or 'II', got {variant!r}.")
    if per not in ("physical", "virtual"):
        raise ModelError(f"scout2: per must be 'physical' or 'virtual' (how Table 6's leg values are read), got {per!r}.")
    for name in ("body_mass", "body_inertia", "leg_mass", "leg_inertia", "leg_stiffness", "leg_length", "half_hip_spacing", "V_nom", "toe_radius", "contact_stiffness", "control_period"):
        v = getattr(p, name)
        if not np.isfinite(v) or v <= 0:
            raise ModelError(f"scout2: {name} must be positive and finite, got {v!r}.")
    for name in ("leg_damping", "R_s", "mu", "joint_stiction", "joint_damping", "belt_damping", "drive_gear_inertia", "driven_gear_inertia", "belt_stiffness",
                 "leg_mu", "gear_drag", "gear_viscous", "belt_no_load"):
        v = getattr(p, name)
        if not np.isfinite(v) or v < 0:
            raise ModelError(f"scout2: {name} must be non-negative, got {v!r}.")
    if variant == "II" and (p.drive_gear_inertia <= 0 or p.driven_gear_inertia <= 0 or p.belt_stiffness <= 0):
        raise ModelError("scout2: Model II needs positive gear inertias and belt stiffness (Table 5).")
    for leg in LEGS:
        td, sw = getattr(p, f"touchdown_{leg}"), getattr(p, f"sweep_{leg}")
        if not -60 * deg < td < 60 * deg:
            raise ModelError(
                f"scout2: touchdown_{leg} = {td / deg:.1f}° is outside the leg's range (−60°, 60°) relative to the body; "
                "seed 003 Table 4 uses 19° (back) and 21° (front). Give radians (proleg.units.deg)."
            )
        if not sw < td:
            raise ModelError(f"scout2: sweep_{leg} ({sw / deg:.1f}°) must be below touchdown_{leg} ({td / deg:.1f}°): stance sweeps the leg back.")
    if not 0 < p.lower_mass_fraction < 1:
        raise ModelError(f"scout2: lower_mass_fraction must be in (0, 1), got {p.lower_mass_fraction}.")
    if not 0 < p.toe_radius < 0.5 * p.leg_length:
        raise ModelError(f"scout2: toe_radius {p.toe_radius} m must be positive and below half the leg length {p.leg_length} m (the sphere sits inside the leg's length).")
    if p.height - p.leg_length < -0.05 * p.leg_length:
        raise ModelError(f"scout2: initial height {p.height} m puts the toes {p.leg_length - p.height:.3f} m into the ground.")
    if p.angle_sensor not in ("motor", "leg"):
        raise ModelError(f"scout2: angle_sensor must be 'motor' or 'leg', got {p.angle_sensor!r}.")


def virtual_drive(p: Scout2Params, losses: bool = False) -> DCMotorDrive:
    """The equivalent virtual motor of ``motors_per_leg`` motors in parallel (same speed):
    K_T and K_ω unchanged, R_a / n, i_max · n, so torque and current scale by n (scout2_data).
    ``losses``: with the load- and speed-dependent gearbox drag of Model II (``gear_drag``,
    ``gear_viscous`` per motor, n of them) and the belt stage's losses
    (:func:`proleg.drives.belt.scout2_belt`: Table 3's 96 % at the virtual leg's current-limit
    torque, ``belt_no_load`` of it as no-load drag); otherwise the paper's constant efficiency."""
    n = p.motors_per_leg
    d = dataclasses.replace(p.drive, R_a=p.drive.R_a / n, i_max=p.drive.i_max * n, V_nom=p.V_nom, R_s=p.R_s,
                            gear_drag=p.gear_drag * n if losses else 0.0, gear_viscous=p.gear_viscous * n if losses else 0.0)
    if losses:
        d = dataclasses.replace(d, belt=scout2_belt(float(d.tau_current_limit), float(d.belt_efficiency), p.belt_no_load))
    return d


def scout2(model: str = "I", *, per: str = D.TABLE6_READING, **params) -> Model:
    """The Scout II sagittal model (seed 003), Model I or Model II; see the module docstring.

    Parameters
    ----------
    model : "I" (torque at the hip) or "II" (gears, coupler, belt spring-damper, joint friction)
    per : "virtual" (default) or "physical": how Table 6's leg values (leg mass, leg inertia,
        spring, damping) are read. "virtual": as printed for each virtual leg, the reading seed
        003 supports (§2.3 and Table 2 define k_i, b_i for i = b, f, the virtual legs; §5.1
        "These models, whose parameters are listed in Table 6"; scout2_data quotes them);
        "physical": per physical leg, a virtual leg twice each (the alternative, for comparison).
        Tables 4 and 5 are per physical leg in both readings (the paper says so).
    **params : any field of :class:`Scout2Params` (angles in rad: ``touchdown_front=20 * deg``)

    Returns
    -------
    Model, with ``model.scout2`` a :class:`Scout2Info`.
    """
    unknown = set(params) - {f.name for f in dataclasses.fields(Scout2Params)}
    if unknown:
        raise ModelError(f"scout2: unknown parameter(s) {sorted(unknown)}. Valid: {[f.name for f in dataclasses.fields(Scout2Params)]}")
    p = Scout2Params(**params)
    _check(p, model, per)
    n_leg = 2.0 if per == "physical" else 1.0  # physical legs per virtual leg for Table 6 values
    n_mot = float(p.motors_per_leg)  # Table 4/5 values are per physical leg in both readings
    drive = virtual_drive(p, losses=model == "II")

    mdl = Model(f"scout2_model_{model}", gravity=(0.0, 0.0, -9.81))
    # Table 4 gains are per physical leg: the virtual leg's are n_mot times (two legs in parallel).
    for k in ("flight_kp", "flight_kd", "brake_kp", "brake_kd"):
        mdl.add_variable(k, n_mot * getattr(p, k), "N m/rad" if k.endswith("kp") else "N m s/rad", "Table 4, virtual leg")
    mdl.add_variable("touchdown_compression", p.touchdown_compression, "m")
    mdl.add_variable("liftoff_compression", p.liftoff_compression, "m")
    # the retraction law's Eq. 4 and Eq. 6 numbers for the virtual motor (the controller's model of
    # the drive, derived here from the drive's data): params, so that a design with another gear
    # ratio or motor shares the compiled model (issue 42)
    mdl.add_variable("retraction_tau_max", float(drive.tau_max), "N m", "Eq. 4: α K_T V / R_a at V = 36 V, virtual motor")
    mdl.add_variable("retraction_A", float(drive.A), "N m s/rad", "Eq. 4: −β α K_T K_ω / R_a, virtual motor")
    mdl.add_variable("retraction_tau_limit", float(drive.tau_current_limit), "N m", "Eq. 6: α K_T i_max, virtual motor")
    h = p.height
    cp, sp = np.cos(p.pitch), np.sin(p.pitch)
    Rb = np.array([[cp, 0, -sp], [0, 1, 0], [sp, 0, cp]])  # rotation about −y by the pitch
    wb = np.array([0.0, -p.pitch_rate, 0.0])
    vb = np.array([p.speed, 0.0, 0.0])
    Ib = p.body_inertia
    body = mdl.add_part("body", mass=p.body_mass, inertia=(Ib, Ib, Ib), position=(0, 0, h), orientation=Rb, velocity=vb, angular_velocity=wb)
    mdl.add_joint(Planar("sagittal", body, mdl.ground, at=(0, 0, h), axis=(0, 1, 0)))
    battery = Battery("battery", V_nom=p.V_nom, R_s=p.R_s)

    def at(local):  # ground position of a point given in the body frame at the initial pose
        return np.array([0, 0, h]) + Rb @ np.asarray(local, float)

    def vel(local):
        return vb + np.cross(wb, Rb @ np.asarray(local, float))

    m_leg, I_leg = p.leg_mass * n_leg, p.leg_inertia * n_leg
    f = p.lower_mass_fraction
    hips, legs, angles, motors = {}, {}, {}, {}
    for leg, sx in (("back", -1.0), ("front", 1.0)):
        xh = sx * p.half_hip_spacing
        hip = at((xh, 0, 0))
        ax = Rb @ np.array([0.0, 0.0, -1.0])  # leg axis, hip → toe
        mu_, ml_ = (1 - f) * m_leg, f * m_leg
        Iu, Il = (1 - f) * I_leg, f * I_leg
        upper = mdl.add_part(f"{leg}_upper", mass=mu_, inertia=(Iu, Iu, Iu), position=at((xh, 0, -p.upper_com)), orientation=Rb, velocity=vel((xh, 0, -p.upper_com)), angular_velocity=wb)
        lower = mdl.add_part(f"{leg}_lower", mass=ml_, inertia=(Il, Il, Il), position=at((xh, 0, -p.lower_com)), orientation=Rb, velocity=vel((xh, 0, -p.lower_com)), angular_velocity=wb)
        hj = mdl.add_joint(Revolute(f"{leg}_hip", upper, body, at=hip, axis=Rb @ np.array(HIP_AXIS)))
        lj = mdl.add_joint(Prismatic(f"{leg}_leg", lower, upper, at=hip, axis=ax))
        toe = at((xh, 0, -p.leg_length))  # the toe's ground point at full extension (Table 6 leg length)
        m_hip = mdl.add_marker(upper, f"{leg}_spring_top", hip)
        m_toe = mdl.add_marker(lower, f"{leg}_toe", toe)
        # the toe sphere's centre sits one radius up the leg, so that at the extension stop the
        # hip-to-ground distance of a vertical leg is the nominal leg length l0 (seed 003 Table 2
        # "l0 Nominal leg length", Table 6 0.323 m), not l0 + radius
        m_toe_c = mdl.add_marker(lower, f"{leg}_toe_centre", at((xh, 0, -(p.leg_length - p.toe_radius))))
        mdl.add_force(SpringDamper(f"{leg}_spring", m_toe, m_hip, stiffness=p.leg_stiffness * n_leg, damping=p.leg_damping * n_leg, free_length=p.leg_length))
        mdl.add_force(JointStop(f"{leg}_stop", lj, upper=0.0, stiffness=p.stop_stiffness * n_leg, damping=p.stop_damping * n_leg, penetration=1e-3))
        mdl.add_contact(SphereContact(
            f"{leg}_toe_contact", m_toe_c, radius=p.toe_radius, stiffness=p.contact_stiffness, exponent=p.contact_exponent,
            damping=p.contact_damping, penetration=p.contact_penetration, mu_static=p.mu, mu_dynamic=p.mu,
            v_stiction=p.v_stiction, v_friction=p.v_friction,
        ))
        hips[leg], legs[leg], angles[leg] = hj.name, lj.name, hj.name
        if model == "I":
            act = JointActuator(f"{leg}_motor", hj, drive=drive, battery=battery)
        else:
            Jd, Jn = p.drive_gear_inertia * n_mot, p.driven_gear_inertia * n_mot
            ha = Rb @ np.array(HIP_AXIS)
            dg = mdl.add_part(f"{leg}_drive_gear", mass=1e-3, inertia=(Jd, Jd, Jd), position=hip, orientation=Rb, velocity=vel((xh, 0, 0)), angular_velocity=wb)
            ng = mdl.add_part(f"{leg}_driven_gear", mass=1e-3, inertia=(Jn, Jn, Jn), position=hip, orientation=Rb, velocity=vel((xh, 0, 0)), angular_velocity=wb)
            dj = mdl.add_joint(Revolute(f"{leg}_motor_shaft", dg, body, at=hip, axis=ha))
            nj = mdl.add_joint(Revolute(f"{leg}_pulley", ng, body, at=hip, axis=ha))
            mdl.add_coupler(Coupler(f"{leg}_gearbox", dj, nj, ratio=drive.beta))
            bi = mdl.add_marker(upper, f"{leg}_belt_leg", hip, orientation=hj.marker_i.orientation)
            bj = mdl.add_marker(ng, f"{leg}_belt_pulley", hip, orientation=hj.marker_i.orientation)
            mdl.add_force(RotationalSpringDamper(f"{leg}_belt", bi, bj, stiffness=p.belt_stiffness * n_mot, damping=p.belt_damping * n_mot))
            mdl.add_force(JointFriction(f"{leg}_hip_friction", hj, friction=p.joint_stiction * n_mot, damping=p.joint_damping * n_mot))
            act = JointActuator(f"{leg}_motor", dj, drive=drive, battery=battery, motor_side=True)
            if p.leg_mu > 0:
                mdl.add_force(SlideFriction(
                    f"{leg}_leg_friction", lj, mu_static=p.leg_mu * p.leg_mu_static_ratio, mu_dynamic=p.leg_mu,
                    v_stiction=p.leg_v_stiction, v_friction=p.leg_v_friction, overlap=p.leg_overlap, bearing_offset=p.leg_bearing,
                ))
            if p.angle_sensor == "motor":
                angles[leg] = nj.name
        mdl.add_actuator(act)
        motors[leg] = act.name
        mdl.add_variable(f"touchdown_{leg}", getattr(p, f"touchdown_{leg}"), "rad", "Table 4 touchdown angle")
        mdl.add_variable(f"sweep_{leg}", getattr(p, f"sweep_{leg}"), "rad", "Table 4 sweep limit")
        mdl.add_controller(bounding_controller(leg, p, angle_joint=angles[leg], leg_joint=lj.name, actuator=act.name))
        _swing(mdl, leg, hip, Rb @ np.array(HIP_AXIS), getattr(p, f"leg_angle_{leg}"), drive.beta if model == "II" else None)
    mdl.scout2 = Scout2Info(model, per, p, drive, hips, legs, angles, motors, _parameter_table(p, model, per, drive))
    return mdl


def _rotation(axis, angle):
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


def _swing(mdl, leg, hip, axis, angle, beta):
    """Start a leg at ``angle`` [rad] from its modelled (vertical) pose about the hip axis.

    The markers, joint zeros, Coupler offsets and stop limits were made at the vertical pose,
    so only the parts' initial positions move (joint coordinates then read ``angle``); in
    Model II the driven gear turns with the leg and the drive gear β times as far, so the belt
    is unstretched and the gear constraint holds. Velocities stay the body's at that point.
    """
    if angle == 0.0:
        return
    R = _rotation(axis, angle)
    parts = {f"{leg}_upper": R, f"{leg}_lower": R}
    if beta is not None:
        parts[f"{leg}_driven_gear"] = R
        parts[f"{leg}_drive_gear"] = _rotation(axis, float(beta) * angle)
    for name, Rk in parts.items():
        part = mdl.part(name)
        body = mdl.part("body")
        part.position = hip + Rk @ (part.position - hip)
        part.orientation = Rk @ part.orientation
        part.velocity = body.velocity + np.cross(body.angular_velocity, part.position - body.position)


def bounding_controller(leg: str, p: Scout2Params, *, angle_joint: str, leg_joint: str, actuator: str) -> StateMachine:
    """The constant-touchdown-angle bounding controller of one virtual leg (seed 003 §3.1).

    States (``LEG_STATES``, the index in ``result.controller(name).state[:, 0]``):

    - **flight** (0): PD to the touchdown angle relative to the body,
      τ = k_p (φ_td − φ) − k_d φ̇ (Table 4: (250, 5) per physical leg, N m/rad and N m s/rad);
    - **retraction** (1): the saturated sweep torque of Eq. 3, τ = −τ_max + A φ̇ with τ_max and
      A of Eq. 4 at V = 36 V for the virtual motor, clipped to −α K_T i_max (Eq. 6) and to ≤ 0
      (Eq. 7);
    - **brake** (2): PD (300, 5) holding the sweep limit.

    Transitions: flight → retraction at touchdown (leg compression > ``touchdown_compression``,
    the potentiometer); retraction → brake when φ ≤ the sweep limit; retraction or brake →
    flight at lift-off (compression < ``liftoff_compression``). φ and φ̇ are the leg angle
    relative to the body from ``angle_joint`` (the hip in Model I; the motor encoder, i.e. the
    driven gear, in Model II). No body-state feedback.

    The set points, gains and thresholds are design variables of the model (``touchdown_back``,
    ``touchdown_front``, ``sweep_back``, ``sweep_front`` [rad]; ``flight_kp``, ``flight_kd``,
    ``brake_kp``, ``brake_kd`` for the virtual leg; ``touchdown_compression``,
    ``liftoff_compression`` [m]; added by :func:`scout2`), so
    ``system.with_params(touchdown_front=...)`` changes them without recompiling. So are the
    retraction law's drive numbers (``retraction_tau_max`` τ_max [N m], ``retraction_A`` A
    [N m s/rad], ``retraction_tau_limit`` α K_T i_max [N m]): :func:`scout2` derives them from
    the virtual drive; they are the controller's model of the drive, so changing the drive's
    parameters (``joint_actuator_drive_*``) with ``with_params`` leaves them as they are. A
    design with another drive is ``scout2(..., drive=...)``, which shares the compiled model.
    The sample period is structure (the controller's clock).
    """
    def phi(s):
        return s.joint_angle(angle_joint), s.joint_rate(angle_joint)

    def compression(s):
        return -s.joint_translation(leg_joint)

    def flight(t, s, mem):
        a, ad = phi(s)
        return {actuator: s.variable("flight_kp") * (s.variable(f"touchdown_{leg}") - a) - s.variable("flight_kd") * ad}

    def retraction(t, s, mem):
        a, ad = phi(s)
        tau = -s.variable("retraction_tau_max") + s.variable("retraction_A") * ad  # Eq. 3
        tau = jnp.maximum(tau, -s.variable("retraction_tau_limit"))  # Eq. 6
        return {actuator: jnp.minimum(tau, 0.0)}  # Eq. 7

    def brake(t, s, mem):
        a, ad = phi(s)
        return {actuator: s.variable("brake_kp") * (s.variable(f"sweep_{leg}") - a) - s.variable("brake_kd") * ad}

    touchdown = lambda t, s, mem: compression(s) > s.variable("touchdown_compression")
    liftoff = lambda t, s, mem: compression(s) < s.variable("liftoff_compression")
    swept = lambda t, s, mem: phi(s)[0] <= s.variable(f"sweep_{leg}")
    return StateMachine(
        f"{leg}_controller",
        states={"flight": flight, "retraction": retraction, "brake": brake},
        transitions=[
            ("flight", "retraction", touchdown),
            ("retraction", "flight", liftoff),
            ("retraction", "brake", swept),
            ("brake", "flight", liftoff),
        ],
        initial="flight",
        outputs=[actuator],
        period=p.control_period,
    )


def _parameter_table(p: Scout2Params, variant, per, drive):
    d = p.drive
    rows = [
        ("model", variant, "-", "seed 003 §5.1: I torque at the hip, II hip unit of Fig. 10"),
        ("Table 6 leg values read per", per, "-", "per virtual leg: §2.3, Table 2 (k_i, b_i, i = b, f), §5.1; scout2_data quotes them"),
        ("body mass", p.body_mass, "kg", "Table 6"),
        ("body pitch inertia", p.body_inertia, "kg m²", "Table 6"),
        (f"leg mass (per {per} leg)", p.leg_mass, "kg", "Table 6"),
        (f"leg inertia (per {per} leg)", p.leg_inertia, "kg m²", "Table 6"),
        (f"leg spring (per {per} leg)", p.leg_stiffness, "N/m", "Table 6 (Table 2: k_i)"),
        (f"leg damping (per {per} leg)", p.leg_damping, "N s/m", "Table 6 (Table 2: b_i) as printed by default; the scout2-bound report calibrates it in 0.3–1.0 × Table 6 on the measured speed (scout2_reading)"),
        ("half hip spacing", p.half_hip_spacing, "m", "Table 6 (0.552 / 2)"),
        ("nominal leg length (extension stop)", p.leg_length, "m", "Table 6"),
        ("lower-leg mass fraction", p.lower_mass_fraction, "-", "chosen (paper: one leg body)"),
        ("upper / lower leg COM from hip", f"{p.upper_com} / {p.lower_com}", "m", "chosen"),
        ("toe radius", p.toe_radius, "m", "chosen"),
        ("toe contact k, e, c", f"{p.contact_stiffness:g}, {p.contact_exponent:g}, {p.contact_damping:g}", "N/m^e, -, N s/m", "chosen (IMPACT, seed 002)"),
        ("toe friction μ", p.mu, "-", "unknown in the paper (§5.2); chosen"),
        ("torque constant K_T", d.K_T, "N m/A", "Table 3"),
        ("speed constant K_ω", d.K_omega, "V s/rad", "Table 3, interpreted 6.78e-4 V/(deg/s)"),
        ("armature resistance R_a (one motor)", d.R_a, "Ω", "Table 3"),
        ("planetary ratio / efficiency", f"{d.gear_ratio} / {d.gear_efficiency}", "-", "Table 3"),
        ("belt ratio / efficiency", f"{d.belt_ratio:.4f} / {d.belt_efficiency}", "-", "Table 3 (48/34)"),
        ("α, β", f"{float(d.alpha):.2f}, {float(d.beta):.2f}", "-", "Eq. 5"),
        ("peak current (one motor)", d.i_max, "A", "§4.1"),
        ("motors per virtual leg", p.motors_per_leg, "-", "§2.2: one per physical leg"),
        ("virtual-leg stall torque τ_max (36 V)", float(drive.tau_max), "N m", "Eq. 4"),
        ("virtual-leg torque slope A", float(drive.A), "N m s/rad", "Eq. 4"),
        ("virtual-leg current-limit torque", float(drive.tau_current_limit), "N m", "Eq. 6"),
        ("battery V_nom, R_s", f"{p.V_nom}, {p.R_s}", "V, Ω", "Eq. 9 fit"),
        ("touchdown angle back / front", f"{p.touchdown_back / deg:g} / {p.touchdown_front / deg:g}", "deg", "Table 4"),
        ("sweep limit back / front", f"{p.sweep_back / deg:g} / {p.sweep_front / deg:g}", "deg", "Table 4"),
        ("flight PD (per physical leg)", f"({p.flight_kp:g}, {p.flight_kd:g})", "N m/rad, N m s/rad", "Table 4, read SI per rad"),
        ("stance-brake PD (per physical leg)", f"({p.brake_kp:g}, {p.brake_kd:g})", "N m/rad, N m s/rad", "Table 4, read SI per rad"),
        ("control period", p.control_period, "s", "§2.2 (1 kHz)"),
        ("touchdown / lift-off compression", f"{p.touchdown_compression} / {p.liftoff_compression}", "m", "chosen (potentiometer threshold)"),
    ]
    if variant == "II":
        rows += [
            ("drive gear inertia (per motor)", p.drive_gear_inertia, "kg m²", "Table 5, exponent interpreted (scout2_data)"),
            ("driven gear inertia (per motor)", p.driven_gear_inertia, "kg m²", "Table 5, exponent interpreted"),
            ("joint stiction", p.joint_stiction, "N m", "Table 5"),
            ("joint damping", p.joint_damping, "N m s/rad", "Table 5, 6.2e-4 N m/(deg/s) interpreted"),
            ("belt spring", p.belt_stiffness, "N m/rad", "Table 5 (7.0 N m/deg)"),
            ("belt damper", p.belt_damping, "N m s/rad", "Table 5, 4.0e-2 N m s/deg interpreted"),
            ("leg angle sensor", p.angle_sensor, "-", "§3.1: motor encoders"),
            ("leg bushing friction μ_d (μ_s / μ_d)", f"{p.leg_mu:g} ({p.leg_mu_static_ratio:g})", "-", "estimate, range 0.03–0.3 (scout2_data); not calibrated"),
            ("leg bushing overlap / centre below hip", f"{p.leg_overlap:g} / {p.leg_bearing:g}", "m", "estimate, ranges in scout2_data"),
            ("leg stiction / sliding transition speeds", f"{p.leg_v_stiction:g} / {p.leg_v_friction:g}", "m/s", "regularisation (Adams FRICTION)"),
            ("gear drag, Coulomb / viscous (per motor, motor shaft)", f"{p.gear_drag:g} / {p.gear_viscous:g}", "N m, N m s/rad", "estimate, ranges in scout2_data"),
            ("belt stage: η at full torque / tension part / no-load drag", f"{p.drive.belt_efficiency:g} / {float(drive.belt.efficiency):g} / {float(drive.belt.drag):.3g} N m",
             "-, -, N m at the virtual leg", "Table 3 (96 %) at full torque; split: estimate, range 0–2 % no-load (proleg.drives.belt)"),
        ]
    rows += [
        ("initial height / speed", f"{p.height:g} / {p.speed:g}", "m, m/s", "standing posture released from a small drop (same for both models)"),
        ("initial pitch / pitch rate", f"{p.pitch / deg:g} / {p.pitch_rate:g}", "deg, rad/s", "at rest"),
    ]
    return rows
