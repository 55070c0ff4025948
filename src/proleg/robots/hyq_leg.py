"""HyQ hydraulic leg on the HAL test bench (seeds 000 and 001): the multibody model.

>>> import proleg as pl
>>> model = pl.robots.hyq_leg(joints="bushings8", gain="high", actuators="drop")
>>> result = pl.simulate(pl.assemble(model), t_end=1.2, dt_output=1e-3)

Seven rigid bodies (seed 000 §2.1, seed 001 Fig. 2): slider, upper leg, lower leg, hip
cylinder, hip rod ("hip beam"), knee cylinder, knee rod ("knee beam"). The slider runs on a
vertical prismatic joint to ground; the foot sphere touches the force plate (ground plane z = 0).

Frames and angles
-----------------
Sagittal plane x-z, z up, every pin axis along ground +y. URDF link frames (hyq-description:
x along the link, z the joint axis) map to ground as x_link = R_y(θ)(0, 0, −1), z_link = +y,
y_link = z × x (:func:`hyq_data.urdf_link_frame`), so the URDF COM offsets and inertia tensors
are used as printed, in part axes. θ1 (HFE) and θ2 (KFE) are HyQ's joint coordinates about +y:
θ1 = 0 upper leg vertical, θ2 = 0 straight knee. The bench angles of seed 000 Fig. 3d are
SU = θ1 (vertical → upper leg; the slider stays vertical) and UL = θ2 (upper → lower leg).

Cylinder attachment points (derived from MODEL_DATA §1)
--------------------------------------------------------
c1(θ1) = √(a1² + b1² − 2 a1 b1 cos(π/2 + θ1 + ε11)) is the law of cosines in the triangle
(HFE axis O, cylinder pin A1, rod pin B1) with |OA1| = a1, |OB1| = b1 and included angle
π/2 + θ1 + ε11. A1 is put on the upper-leg axis, A1 = O + a1 R_y(θ1)(0, 0, −1); the included
angle then fixes B1 = O + b1 R_y(−π/2 − ε11)(0, 0, −1) on the slider (45 mm ahead of and
slightly above the hip axis). Knee: A2 = K − a2 R_y(θ1)(0, 0, −1) on the upper-leg axis
(towards the hip) and B2 = K + b2 R_y(θ1 + θ2 + ε21 + ε22)(0, 0, −1) on the lower leg, giving
the included angle π − θ2 − ε21 − ε22. The lever arm l = a sin(∠OAB) is the distance from the
joint axis to the cylinder line, and equals |dc/dθ|: the hip cylinder lengthens with θ1
(dc1/dθ1 = +l1), the knee cylinder shortens with θ2 (dc2/dθ2 = −l2). Only distances and the
included angle are fixed by the formula; putting A on the segment axis is a choice.

Pins (seed 001 Fig. 2a numbering, interpreted)
-----------------------------------------------
==== ============================================ ============ ==================
pin  connects                                     rigid joint  bushings4 / 8
==== ============================================ ============ ==================
1    slider – upper leg (hip, HFE)                Revolute     bushing / bushing
2    hip rod – slider (hip lever)                 Universal    bushing / bushing
3    hip cylinder – upper leg                     Universal    bushing / bushing
4    upper leg – lower leg (knee, KFE)            Revolute     joint / 2 bushings
5    knee rod – lower leg (knee lever)            Universal    joint / 2 bushings
6    knee cylinder – upper leg                    Universal    bushing / bushing
==== ============================================ ============ ==================

Seed 001 prints only "4 bushings (1, 2, 3, 6)", "8 bushings (1–6, 4 and 5 double because the
connection has two sides)", that the 4-bushing model changes only the hip force "because its
behaviour mostly depends on the flexibility of the connection pins between this structure
[the hip actuator] and ... upperleg from one side, slider from the other", and that the knee
force needs, besides its actuator pins, "the stiffness of the connections between these two
mechanical parts [upper and lower leg]". Hence 1–3 are the pins of the hip-actuator loop, 4 the
knee pin, 5 the knee-actuator pin that goes with it, 6 the remaining knee-actuator pin (on the
upper leg). The figure itself is not in the text: this mapping is an interpretation.
Cylinder and rod always slide on a Cylindrical joint (the actuator, not a pin).

Rigid model without redundant constraints: a closed spatial loop with joint freedoms f_k has
mobility Σf_k − 6. Each cylinder loop (main Revolute 1 + Universal 2 + Cylindrical 2 +
Universal 2 = 7) has mobility 1, its joint angle, with no free spin of barrel or rod; the
slider Prismatic, hip and knee Revolutes and the two loops leave 42 − 39 = 3 DOF (slider
height, θ1, θ2), with Φ_q of full rank.

Actuators and servo
-------------------
Each cylinder is a :class:`proleg.HydraulicActuator` between rod pin (I) and cylinder pin (J):
f = −k (ℓ − ℓ0) − c ℓ̇ + F_cmd, positive extending, ℓ0 the modelled length, k and c from seed
000 Table 2 for ``actuators`` (test condition) and ``gain``. F_cmd comes from the joint servo
(seed 000: P = 150 or 300 N m/rad, D = 6 N m s/rad, 1 kHz): u = P (θ_set − θ) − D θ̇,
F_cmd = u / (dc/dθ). With a Revolute at the joint it is a :class:`proleg.PID`; where the pin is
a bushing (no joint to read) a :class:`proleg.DiscreteController` applies the same law to the
angle of the pin's I and J markers (about z_J), as the encoder on the real pin does.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import jax.numpy as jnp
import numpy as np

from ..errors import ModelError
from ..model.contacts import SphereContact
from ..model.control import PID, DiscreteController, HydraulicActuator, TranslationalActuator
from ..model.forces import Bushing
from ..model.joints import Cylindrical, Prismatic, Revolute, Universal
from ..model.model import Model
from ..units import deg
from . import hyq_data as D

__all__ = ["hyq_leg", "HyQInfo", "joint_angles", "cylinder_forces", "bushing_vector"]

PIN_NAMES = {
    1: "slider – upper leg (hip, HFE)",
    2: "hip rod – slider (hip lever)",
    3: "hip cylinder – upper leg",
    4: "upper leg – lower leg (knee, KFE)",
    5: "knee rod – lower leg (knee lever)",
    6: "knee cylinder – upper leg",
}
BUSHING_PINS = {"rigid": (), "bushings4": (1, 2, 3, 6), "bushings8": (1, 2, 3, 4, 5, 6)}
DOUBLE_PINS = (4, 5)


@dataclass
class HyQInfo:
    """What :func:`hyq_leg` built: the choices, the derived values and the parameter table.

    ``parameters`` rows are (name, value, unit, source), for :meth:`proleg.report.Report.add_parameters`.
    """

    joints: str
    gain: str
    actuators: str
    payload: float
    drop_height: float
    hip_angle: float  # [rad] θ1 setpoint / modelled
    knee_angle: float  # [rad] θ2
    coefficients: dict  # hip_k, hip_c, knee_k, knee_c
    kp: float
    kd: float
    bushing_stiffness: np.ndarray  # (6,)
    bushing_damping: np.ndarray  # (6,)
    bushing_pins: tuple
    total_mass: float
    slider_height: float  # [m] hip axis height at the modelled pose
    parameters: list = field(default_factory=list)


def _choice(what, value, valid):
    if value not in valid:
        raise ModelError(f"hyq_leg: unknown {what} {value!r}; valid choices are {list(valid)}.")
    return value


def bushing_vector(value, what: str) -> np.ndarray:
    """(6,) bushing diagonal from a radial value [N/m or N s/m] or a full (6,) vector.

    Scalar k → (k, k, r k, k s²/4, k s²/4, 0): radial x, y; axial z = ``BUSHING_AXIAL_RATIO`` ×
    radial; tilt of a pin on two bearings ``BEARING_SPAN`` = s apart, each carrying half the
    radial stiffness; free rotation about the pin axis (z).
    """
    arr = np.asarray(value, dtype=float)
    if arr.shape == ():
        k = float(arr)
        if not np.isfinite(k) or k < 0:
            raise ModelError(f"hyq_leg: {what} must be a finite value ≥ 0, got {k}.")
        s2 = D.BEARING_SPAN**2 / 4.0
        return np.array([k, k, D.BUSHING_AXIAL_RATIO * k, k * s2, k * s2, 0.0])
    if arr.shape != (6,) or not np.all(np.isfinite(arr)) or np.any(arr < 0):
        raise ModelError(
            f"hyq_leg: {what} must be a radial value or a (6,) vector ≥ 0 [N/m ×3, N m/rad ×3] "
            f"(or damping [N s/m ×3, N m s/rad ×3]), got {value!r}."
        )
    return arr


def _Ry(theta):
    c, s = np.cos(theta), np.sin(theta)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


_DOWN = np.array([0.0, 0.0, -1.0])
_Y = np.array([0.0, 1.0, 0.0])


def _slender(m, length, radius):
    """Inertia of a slender cylinder about its COM, axis along part z [kg m²]."""
    t = m * (3 * radius**2 + length**2) / 12.0
    return np.array([t, t, 0.5 * m * radius**2])


def _axis_frame(e):
    """Part frame with z along e (in the x-z plane), y = ground y."""
    x = np.cross(_Y, e)
    return np.column_stack([x, _Y, e])


def _geometry(th1, th2, z_hip, cyl):
    """Pin and body positions at the pose (θ1, θ2) with the hip axis at height z_hip."""
    O = np.array([0.0, 0.0, z_hip])
    u1 = _Ry(th1) @ _DOWN
    u2 = _Ry(th1 + th2) @ _DOWN
    K = O + D.UPPER_LEG_LENGTH * u1
    F = K + D.LOWER_LEG_LENGTH * u2
    A1 = O + D.HIP_A * u1
    B1 = O + D.HIP_B * (_Ry(-np.pi / 2 - D.HIP_EPS) @ _DOWN)
    A2 = K - D.KNEE_A * u1
    B2 = K + D.KNEE_B * (_Ry(th1 + th2 + D.KNEE_EPS1 + D.KNEE_EPS2) @ _DOWN)
    g = dict(O=O, K=K, F=F, u1=u1, u2=u2, A1=A1, B1=B1, A2=A2, B2=B2)
    for side, A, B in (("hip", A1, B1), ("knee", A2, B2)):
        e = (B - A) / np.linalg.norm(B - A)
        g[f"{side}_e"] = e
        g[f"{side}_cyl_com"] = A + 0.5 * cyl["cylinder_length"] * e
        g[f"{side}_rod_com"] = B - 0.5 * cyl["rod_length"] * e
        g[f"{side}_slide"] = A + cyl["cylinder_length"] * e  # barrel mouth: cylinder–rod joint
    return g


def _upper_leg_residual(cyl):
    """Upper-leg structure mass, COM (link frame) and inertia so that structure + both cylinders
    + both rods reproduce the URDF upper-leg mass properties at the nominal pose (θ1 = −30°,
    θ2 = 60°), all expressed in the upper-leg link frame (pose independent)."""
    th1, th2 = D.NOMINAL_HFE, D.NOMINAL_KFE
    g = _geometry(th1, th2, 0.0, cyl)
    R1 = D.urdf_link_frame(th1)
    m_tot = D.UPPER_LEG_MASS
    c_tot = np.array(D.UPPER_LEG_COM)
    J_tot = np.array(D.UPPER_LEG_INERTIA)
    bodies = []
    for side in ("hip", "knee"):
        Rc = R1.T @ _axis_frame(g[f"{side}_e"])
        for what, m, L, r in (("cyl", cyl["cylinder_mass"], cyl["cylinder_length"], D.CYLINDER_RADIUS), ("rod", cyl["rod_mass"], cyl["rod_length"], D.ROD_RADIUS)):
            pos = R1.T @ (g[f"{side}_{what}_com"] - g["O"])
            bodies.append((m, pos, Rc @ np.diag(_slender(m, L, r)) @ Rc.T))
    m_s = m_tot - sum(b[0] for b in bodies)
    if m_s <= 0.2 * m_tot:
        raise ModelError(
            f"hyq_leg: cylinder and rod masses ({sum(b[0] for b in bodies):.3g} kg in all) leave too little of the "
            f"URDF upper-leg mass {m_tot} kg for the leg structure; reduce cylinder_mass / rod_mass."
        )
    c_s = (m_tot * c_tot - sum(m * p for m, p, _ in bodies)) / m_s

    def shift(m, d):  # parallel-axis term
        return m * (d @ d * np.eye(3) - np.outer(d, d))

    J_s = J_tot + shift(m_tot, c_tot - c_s) - sum(J + shift(m, p - c_s) for m, p, J in bodies)
    J_s = 0.5 * (J_s + J_s.T)
    if np.linalg.eigvalsh(J_s).min() <= 0:
        raise ModelError("hyq_leg: cylinder/rod mass properties exceed the URDF upper-leg inertia; reduce their masses or lengths.")
    return m_s, c_s, J_s


def hyq_leg(
    joints: str = "rigid",
    gain: str = "high",
    actuators: str = "drop",
    payload: float = 0.0,
    drop_height: float = 0.05,
    bushing_stiffness=D.BUSHING_RADIAL_STIFFNESS,
    bushing_damping=None,
    *,
    hip_angle: float = D.NOMINAL_HFE,
    knee_angle: float = D.NOMINAL_KFE,
    slider_mass: float = D.HIP_ASSEMBLY_MASS,
    cylinder_mass: float = D.CYLINDER_MASS,
    rod_mass: float = D.ROD_MASS,
    cylinder_length: float = D.CYLINDER_LENGTH,
    rod_length: float = D.ROD_LENGTH,
    actuator_coefficients: dict | None = None,
    kp: float | None = None,
    kd: float = D.D_GAIN,
    servo_period: float = D.SERVO_PERIOD,
    servo: bool = True,
    contact: bool = True,
    foot_stiffness: float | None = None,
    foot_damping: float = D.FOOT_DAMPING,
    foot_penetration: float = D.FOOT_PENETRATION,
    mu_static: float = D.MU_STATIC,
    mu_dynamic: float = D.MU_DYNAMIC,
    v_stiction: float = D.V_STICTION,
    v_friction: float = D.V_FRICTION,
    gravity: float = 9.81,
    name: str | None = None,
    cylinders: str = "spring-damper",
    hydraulics: dict | None = None,
) -> Model:
    """The HyQ leg test bench as a proleg Model (module docstring: frames, pins, cylinder geometry).

    Parameters
    ----------
    joints : {"rigid", "bushings4", "bushings8"}
        seed 000 RCM (ideal lower pairs), seed 001 FCP with bushings at pins 1, 2, 3, 6, or at
        all pins with 4 and 5 double-sided (8 bushings).
    gain : {"low", "high"}
        servo P = 150 or 300 N m/rad (seed 000 §3); also selects the Table 2 row.
    actuators : {"quasi-static", "drop"}
        test condition of the Table 2 row (actuator k [N/m] and c [N s/m]).
    payload : float [kg], ≥ 0
        mass added to the slider (seed 000 static test: 0, 3, 7 kg).
    drop_height : float [m], ≥ 0
        height of the foot sphere's lowest point above the plate at the modelled pose (0: touching).
    bushing_stiffness : float [N/m] or (6,) [N/m ×3, N m/rad ×3], default 1e8 (radial)
        per bushing; a scalar is the radial value, expanded by :func:`bushing_vector`.
    bushing_damping : float [N s/m] or (6,), optional
        default ``BUSHING_DAMPING_BETA`` × stiffness (stiffness-proportional, 1e-5 s).
    hip_angle, knee_angle : float [rad]
        θ1 (HFE) and θ2 (KFE) of the modelled pose, also the servo setpoints (default −30°, 60°:
        foot under the hip).
    slider_mass : float [kg], default 2.93 (URDF hip assembly, MODEL_DATA §1; the 2010
        prototype leg weighed 4.5 kg in all)
    cylinder_mass, rod_mass, cylinder_length, rod_length : assumed barrel/rod data [kg, m]
        split off the URDF upper-leg mass properties (see ``hyq_data``).
    actuator_coefficients : dict, optional
        overrides of ``hip_k, hip_c, knee_k, knee_c`` (Table 2 otherwise).
    kp, kd : servo gains [N m/rad, N m s/rad]; kp defaults to P of ``gain``.
    servo : bool
        add the joint servos (False: passive actuators only).
    contact : bool
        add the foot–plate contact.
    foot_stiffness : float [N/m^1.5], optional
        default Hertz value of the assumed rubber foot on steel (``hyq_data.foot_stiffness``).
    foot_damping [N s/m], foot_penetration [m], mu_static, mu_dynamic, v_stiction [m/s],
    v_friction [m/s] : contact law parameters (IMPACT + Coulomb with stiction), assumed.
    gravity : float [m/s²]
    cylinders : {"spring-damper", "pressure"}
        the actuator's fidelity: seed 000's spring-damper with a commanded force
        (:class:`proleg.HydraulicActuator`, k and c of Table 2), or a valve-controlled cylinder
        with its two chamber pressures as states (:mod:`proleg.drives.hydraulics`) acting along
        the same pin line, driven by HyQ's pressure force loop under the same joint PD
        (:func:`proleg.control.hydraulic.hydraulic_servo`; result: ``hydraulic_outputs(result,
        "hip_servo")``), with the seal friction and end-of-stroke stops on the cylinder's slide.
        The piston sits at c(θ) − c_min + margin, the triangle's travel over the joint range
        centred in the stroke. Rigid pins only (``joints="rigid"``).
    hydraulics : dict, optional, ``cylinder``, ``valve``, ``supply`` (drives.hydraulics objects)
        and ``force_gain`` for ``cylinders="pressure"``

    Returns
    -------
    Model, with ``model.hyq`` (:class:`HyQInfo`) describing what was built.

    Raises
    ------
    ModelError
        unknown ``joints``/``gain``/``actuators``, negative payload or drop height, bad values.
    """
    _choice("joints", joints, D.JOINTS)
    _choice("gain", gain, D.GAINS)
    _choice("actuators", actuators, D.ACTUATOR_TESTS)
    payload = float(payload)
    if not np.isfinite(payload) or payload < 0:
        raise ModelError(f"hyq_leg: payload must be ≥ 0 kg (seed 000 static test: 0, 3, 7 kg), got {payload}.")
    drop_height = float(drop_height)
    if not np.isfinite(drop_height) or drop_height < 0:
        raise ModelError(
            f"hyq_leg: drop_height {drop_height} m puts the foot below the force plate; give the height of the "
            "foot's lowest point above the plate, ≥ 0 (seed 000 drop test: 0.05 m)."
        )
    th1, th2 = float(hip_angle), float(knee_angle)
    for what, th, (lo, hi) in (("hip_angle", th1, D.HFE_RANGE_DEG), ("knee_angle", th2, D.KFE_RANGE_DEG)):
        if not lo * deg <= th <= hi * deg:
            raise ModelError(f"hyq_leg: {what} = {th / deg:.4g}° is outside HyQ's range {lo}…{hi}° (MODEL_DATA §1); give radians.")
    coef = D.actuator_coefficients(actuators, gain)
    for k_, v_ in (actuator_coefficients or {}).items():
        if k_ not in coef:
            raise ModelError(f"hyq_leg: actuator_coefficients key {k_!r} unknown; valid keys are {sorted(coef)}.")
        coef[k_] = float(v_)
    kp = D.P_GAIN[gain] if kp is None else float(kp)
    kb = bushing_vector(bushing_stiffness, "bushing_stiffness")
    cb = D.BUSHING_DAMPING_BETA * kb if bushing_damping is None else bushing_vector(bushing_damping, "bushing_damping")
    cyl = dict(cylinder_mass=cylinder_mass, rod_mass=rod_mass, cylinder_length=cylinder_length, rod_length=rod_length)
    for k_, v_ in cyl.items():
        if not (np.isfinite(v_) and v_ > 0):
            raise ModelError(f"hyq_leg: {k_} must be positive, got {v_}.")

    z_hip = drop_height + D.FOOT_RADIUS + D.UPPER_LEG_LENGTH * np.cos(th1) + D.LOWER_LEG_LENGTH * np.cos(th1 + th2)
    g = _geometry(th1, th2, z_hip, cyl)
    R1, R2 = D.urdf_link_frame(th1), D.urdf_link_frame(th1 + th2)
    R0 = D.urdf_link_frame(0.0)

    model = Model(name or f"hyq_leg_{joints}", gravity=(0.0, 0.0, -float(gravity)))
    # -- parts -------------------------------------------------------------------------------
    slider = model.add_part("slider", slider_mass + payload, D.SLIDER_INERTIA, g["O"])
    m_u, c_u, J_u = _upper_leg_residual(cyl)
    upper = model.add_part("upper_leg", m_u, J_u, g["O"] + R1 @ c_u, R1)
    lower = model.add_part("lower_leg", D.LOWER_LEG_MASS, np.array(D.LOWER_LEG_INERTIA), g["K"] + R2 @ np.array(D.LOWER_LEG_COM), R2)
    parts = {}
    for side in ("hip", "knee"):
        Rc = _axis_frame(g[f"{side}_e"])
        parts[f"{side}_cylinder"] = model.add_part(
            f"{side}_cylinder", cylinder_mass, _slender(cylinder_mass, cylinder_length, D.CYLINDER_RADIUS), g[f"{side}_cyl_com"], Rc
        )
        parts[f"{side}_rod"] = model.add_part(f"{side}_rod", rod_mass, _slender(rod_mass, rod_length, D.ROD_RADIUS), g[f"{side}_rod_com"], Rc)

    # -- slider on its vertical bar ----------------------------------------------------------
    model.add_joint(Prismatic("slider", slider, model.ground, at=g["O"], axis=(0.0, 0.0, 1.0)))

    # -- angle markers at the hip and knee axes (joint markers or encoder markers) -------------
    hip_i = model.add_marker(upper, "hip.I", g["O"], R1)
    hip_j = model.add_marker(slider, "hip.J", g["O"], R0)
    knee_i = model.add_marker(lower, "knee.I", g["K"], R2)
    knee_j = model.add_marker(upper, "knee.J", g["K"], R1)

    # -- pins: (number, I part, J part, location) ---------------------------------------------
    pins = {
        1: (upper, slider, g["O"]),
        2: (parts["hip_rod"], slider, g["B1"]),
        3: (parts["hip_cylinder"], upper, g["A1"]),
        4: (lower, upper, g["K"]),
        5: (parts["knee_rod"], lower, g["B2"]),
        6: (parts["knee_cylinder"], upper, g["A2"]),
    }
    cyl_axis = {2: g["hip_e"], 3: g["hip_e"], 5: g["knee_e"], 6: g["knee_e"]}
    bpins = BUSHING_PINS[joints]
    Rpin = D.urdf_link_frame(0.0)  # z along the pin axis (+y)
    for n, (pi, pj, at) in pins.items():
        if n in bpins:
            offsets = (-0.5 * D.DOUBLE_PIN_SPAN, 0.5 * D.DOUBLE_PIN_SPAN) if (n in DOUBLE_PINS) else (0.0,)
            for s, dy in zip("ab" if len(offsets) == 2 else ("",), offsets):
                p = at + dy * _Y
                mi = model.add_marker(pi, f"pin{n}{s}.I", p, Rpin)
                mj = model.add_marker(pj, f"pin{n}{s}.J", p, Rpin)
                model.add_force(Bushing(f"pin{n}{s}", mi, mj, stiffness=kb, damping=cb))
        elif n == 1:
            model.add_joint(Revolute("hip", hip_i, hip_j))
        elif n == 4:
            model.add_joint(Revolute("knee", knee_i, knee_j))
        else:
            model.add_joint(Universal(f"pin{n}", pi, pj, at=at, axis_i=np.cross(_Y, cyl_axis[n]), axis_j=_Y))

    # -- cylinders: sliding pair and hydraulic spring-damper ----------------------------------
    if cylinders not in ("spring-damper", "pressure"):
        raise ModelError(f"hyq_leg: unknown cylinders {cylinders!r}; valid choices are ['spring-damper', 'pressure'].")
    if cylinders == "pressure" and joints != "rigid":
        raise ModelError("hyq_leg: cylinders='pressure' needs joints='rigid' (its servo reads the hip and knee Revolutes).")
    for side, A, B in (("hip", g["A1"], g["B1"]), ("knee", g["A2"], g["B2"])):
        rod, barrel = parts[f"{side}_rod"], parts[f"{side}_cylinder"]
        model.add_joint(Cylindrical(f"{side}_slide", rod, barrel, at=g[f"{side}_slide"], axis=g[f"{side}_e"]))
        mi = model.add_marker(rod, f"{side}_actuator.I", B)
        mj = model.add_marker(barrel, f"{side}_actuator.J", A)
        if cylinders == "pressure":
            model.add_actuator(TranslationalActuator(f"{side}_actuator", mi, mj))
        else:
            model.add_actuator(HydraulicActuator(f"{side}_actuator", mi, mj, stiffness=coef[f"{side}_k"], damping=coef[f"{side}_c"]))

    # -- joint servos ------------------------------------------------------------------------
    if servo and cylinders == "pressure":
        _pressure_servos(model, th1, th2, kp, kd, servo_period, hydraulics or {})
    elif servo:
        levers = {"hip": D.hip_signed_lever, "knee": D.knee_signed_lever}
        setpoints = {"hip": th1, "knee": th2}
        for side, (mi, mj), pin in (("hip", (hip_i, hip_j), 1), ("knee", (knee_i, knee_j), 4)):
            if pin in bpins:
                model.add_controller(_pin_servo(model, f"{side}_servo", mi, mj, kp, kd, setpoints[side], servo_period, f"{side}_actuator", levers[side]))
            else:
                model.add_controller(
                    PID(f"{side}_servo", joint=side, kp=kp, kd=kd, setpoint=setpoints[side], period=servo_period,
                        actuator=f"{side}_actuator", lever_arm=levers[side])
                )

    # -- foot on the force plate -------------------------------------------------------------
    if contact:
        foot = model.add_marker(lower, "foot", g["F"])
        model.add_contact(
            SphereContact(
                "foot", foot, radius=D.FOOT_RADIUS,
                stiffness=D.foot_stiffness() if foot_stiffness is None else foot_stiffness,
                exponent=1.5, damping=foot_damping, penetration=foot_penetration,
                mu_static=mu_static, mu_dynamic=mu_dynamic, v_stiction=v_stiction, v_friction=v_friction,
            )
        )

    total = sum(p.mass for p in model.parts)
    params = D.sources() + [
        ("joints", joints, "-", "seed 000 RCM / seed 001 FCP"),
        ("gain", f"{gain} (P = {kp:g})", "N m/rad", "seed 000 §3"),
        ("actuator row", actuators, "-", "seed 000 Table 2"),
        ("payload", payload, "kg", "seed 000 static test"),
        ("drop height", drop_height, "m", "seed 000 drop test: 0.05 m"),
        ("hip / knee setpoint θ1, θ2", [th1 / deg, th2 / deg], "deg", "assumed bench pose (foot under the hip)"),
        ("bushing stiffness (6,)", kb.tolist(), "N/m ×3, N m/rad ×3", "see bushing rows"),
        ("bushing damping (6,)", cb.tolist(), "N s/m ×3, N m s/rad ×3", "see bushing rows"),
        ("upper-leg structure mass (URDF minus cylinders)", m_u, "kg", "derived"),
        ("total moving mass", total, "kg", "sum of all parts"),
    ]
    model.hyq = HyQInfo(
        joints=joints, gain=gain, actuators=actuators, payload=payload, drop_height=drop_height,
        hip_angle=th1, knee_angle=th2, coefficients=coef, kp=kp, kd=kd, bushing_stiffness=kb,
        bushing_damping=cb, bushing_pins=bpins, total_mass=total, slider_height=float(g["O"][2]),
        parameters=params,
    )
    return model


def _pressure_servos(model, th1, th2, kp, kd, period, hyd):
    """``cylinders="pressure"``: per side a hydraulic servo on the cylinder's slide (piston
    x = slide translation + x at the modelled pose), its force reference the seed 000 PD on the
    joint angle through the lever arm, F_ref = (kp (θ_set − θ) − kd θ̇) / (dc/dθ); seal friction
    and end-of-stroke stops as continuous forces on the slide."""
    from ..control.hydraulic import hydraulic_servo
    from ..drives import hydraulics as H
    from ..model.couplers import JointFriction, JointStop

    cyl = hyd.get("cylinder") or H.Cylinder()
    geo = {
        "hip": (D.hip_cylinder_length, D.hip_signed_lever, D.HFE_RANGE_DEG, th1),
        "knee": (D.knee_cylinder_length, D.knee_signed_lever, D.KFE_RANGE_DEG, th2),
    }
    for side, (length, lever, rng, th0) in geo.items():
        c = np.asarray(length(np.deg2rad(np.linspace(*rng, 241))))
        margin = 0.5 * (cyl.stroke - (c.max() - c.min()))
        if margin < 0:
            raise ModelError(f"hyq_leg: cylinder stroke {cyl.stroke} m is shorter than the {side} triangle's travel {c.max() - c.min():.4f} m.")
        x_mid = float(length(th0)) - c.min() + margin

        def piston(s, x_mid=x_mid):
            return s + x_mid, jnp.ones_like(s)

        def reference(t, state, s, sd, side=side, lever=lever, th0=th0):
            th, thd = state.joint_angle(side), state.joint_rate(side)
            return (kp * (th0 - th) - kd * thd) / lever(th)

        model.add_controller(hydraulic_servo(f"{side}_servo", [f"{side}_slide"], [f"{side}_actuator"], piston, cylinder=cyl,
                                             valve=hyd.get("valve"), supply=hyd.get("supply"), reference=reference, period=period,
                                             translation=True, x0=[0.0], force_gain=hyd.get("force_gain", 0.4)))
        model.add_force(JointFriction(f"{side}_seal", f"{side}_slide", friction=cyl.friction, damping=cyl.viscous, slip_rate=1e-3, dof="translation"))
        model.add_force(JointStop(f"{side}_end_stops", f"{side}_slide", lower=-x_mid, upper=cyl.stroke - x_mid, stiffness=1e8, damping=1e4,
                                  penetration=1e-4, dof="translation"))


def _pin_angle(RI, RJ):
    """Rotation of marker I relative to J about z_J: atan2(x_I·y_J, x_I·x_J) (joint convention)."""
    return jnp.arctan2(jnp.dot(RI[:, 0], RJ[:, 1]), jnp.dot(RI[:, 0], RJ[:, 0]))


def _pin_servo(model, name, mi, mj, kp, kd, setpoint, period, actuator, lever):
    """The seed 000 PD servo on the angle of a bushing pin (I relative to J about z_J).

    Same law and zero-order hold as :class:`proleg.PID`: u = kp (θ_set − θ) − kd θ̇ [N m],
    cylinder force command u / lever(θ) [N]. The controller state holds u (its output).
    Its gains and set point are design variables (``<name>_kp``, ``<name>_kd``,
    ``<name>_setpoint``) and the law closes over names only, so a leg with other numbers is
    the same structure and shares the compiled run (issue 42).
    """
    mi_name, mj_name, pi_name, pj_name = mi.name, mj.name, mi.part.name, mj.part.name
    v_kp = model.add_variable(f"{name}_kp", kp, "N m/rad", f"{name} proportional gain")
    v_kd = model.add_variable(f"{name}_kd", kd, "N m s/rad", f"{name} derivative gain")
    v_sp = model.add_variable(f"{name}_setpoint", setpoint, "rad", f"{name} set point")

    def update(t, state, z):
        RI, RJ = state.marker_orientation(mi_name), state.marker_orientation(mj_name)
        th = _pin_angle(RI, RJ)
        th_d = jnp.dot(RJ[:, 2], state.angular_velocity(pi_name) - state.angular_velocity(pj_name))
        u = state.variable(v_kp) * (state.variable(v_sp) - th) - state.variable(v_kd) * th_d
        return jnp.reshape(u, (1,)), {actuator: u / lever(th)}

    return DiscreteController(name, update, z0=[0.0], outputs=[actuator], period=period)


def joint_angles(result) -> tuple[np.ndarray, np.ndarray]:
    """θ1 = SU and θ2 = UL [rad] over a result, from the hip and knee angle markers (any variant)."""
    out = []
    for side in ("hip", "knee"):
        RI = np.asarray(result.marker(f"{side}.I").orientation)
        RJ = np.asarray(result.marker(f"{side}.J").orientation)
        out.append(np.arctan2(np.einsum("ni,ni->n", RI[:, :, 0], RJ[:, :, 1]), np.einsum("ni,ni->n", RI[:, :, 0], RJ[:, :, 0])))
    return out[0], out[1]


def cylinder_forces(result) -> tuple[np.ndarray, np.ndarray]:
    """Hip and knee actuator axial forces [N] (positive = pushing, extending the cylinder)."""
    return (np.asarray(result.element("hip_actuator").axial_force), np.asarray(result.element("knee_actuator").axial_force))
