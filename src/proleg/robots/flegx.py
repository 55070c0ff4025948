"""FLEGX flexible jumping leg (seed 002): the multibody model in three link fidelities.

>>> import proleg as pl
>>> model = pl.robots.flegx(configuration=4, link_case=2, link_model="cb")
>>> system = pl.assemble(model)            # removes the tendons' redundant constraint rows

Bodies (seed 002 §II, Fig. 1; sagittal plane x-z, pins along +y; angles in ``flegx_data``):

- ``guide``: the linear-guide plate (carbon plate, bearings, and the motors it carries) on a
  vertical :class:`~proleg.Prismatic` to ground; the hip axis is at its origin.
- ``upper_leg``: hip :class:`~proleg.Revolute` to the guide (motor torque between them).
- ``knee_flange``: knee :class:`~proleg.Revolute` to the upper leg; the strip is clamped to it
  (a :class:`~proleg.Fixed` joint ``link.clamp`` whose reaction moment gives the clamp stress).
- Configuration No. 4 only: ``knee_wheel`` (the floating worm wheel with its crank, revolute
  about the hip axis to the guide) and two tendon rods ``tendon_a``/``tendon_b`` (Ø7 × 266 mm)
  with :class:`~proleg.Spherical` joints at both ends to the wheel crank and to the knee-flange
  lever. Crank, lever, tendons and the hip-knee line form two parallel parallelograms, so the
  wheel turns with the lower leg's absolute angle θ1 + θ2. The second tendon duplicates the
  first one's distance constraint: :func:`proleg.assemble` removes that redundant row (as
  Adams does) and warns. Each rod keeps a free spin about its own axis (spherical ends).
  Configurations 1-3 carry the knee motor on the upper leg and drive the knee joint directly.
- The lower leg (the AISI 304 strip, link case 1-6), ``link_model``:

  * ``"rigid"``: one rigid box ``link``.
  * ``"prbm"``: the dynamic PRB 1R link of Eqs. 8-11 (:func:`proleg.flex.dynamic_prbm`:
    γ, K_t, C_t solved per case with P = 30 N and the elastica deflection, ξ = 0.015): two
    rigid segments ``link.base``/``link.tip``, pivot revolute with a torsion spring-damper.
  * ``"cb"``: a Craig-Bampton modal body ``link`` (Eqs. 12-15) from an Euler-Bernoulli beam FE
    model of the strip (``cb_elements`` elements; interface nodes: the clamped end, frame node,
    and the free end, where the foot sits; ``cb_modes`` fixed-interface modes, modal damping
    ``cb_damping``), with stress recovery at the clamped end: σ_xx = E (ε − z κ) at the two
    surfaces z = ±t/2 of the root section (von Mises = |σ_xx|; transverse shear is zero at the
    surfaces). A beam, not the scikit-fem P2-tet solid: the modal body needs 6-DOF interface
    nodes, which the tet mesh lacks.

- ``gears="worm"``: each drive is a worm set in the dynamics (:func:`add_worm_drive`): the worm's
  rotation is a slider ``<drive>_worm`` on a :class:`~proleg.Prismatic` to the housing (the
  guide; the upper leg for the knee of No. 1-3) whose travel is the worm's pitch-circle arc
  s = r1 φ_w and whose mass is the rotor inertia J/r1² (taken from the housing's mass, so the
  totals stay Table I's), and a compliant mesh with sliding friction between it and the wheel
  (:func:`proleg.drives.gears.worm_mesh`: Eqs. 16-17 with f = 0.14 static / 0.13 dynamic as the
  model variables ``worm_f_static``/``worm_f_dynamic``): back-drivable or self-locking as the
  friction gives. The motion laws then drive the worms (s = n r1 Δθ); ``gears="ideal"`` drives
  the wheels directly (a lossless, rigid transmission).
- Foot: a massless rigid cylinder (axis y, radius ``FOOT_RADIUS``) fixed to the strip's free
  end (CB: its lower interface node), :class:`~proleg.CylinderContact` with the IMPACT law
  against the ground z = 0, frictionless by default (the guide carries the horizontal loads).

The modelled (initial) pose is the standing pose (θ1, θ2) = ``stand`` with the foot's lowest
point ``clearance`` above the ground. Joint motions (:func:`proleg.papers.flegx_jump`) are
imposed relative to this pose, on the wheels (ideal gears) or on the worms (worm gears).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import ModelError
from ..model.contacts import CylinderContact
from ..model.joints import Fixed, Prismatic, Revolute, Spherical
from ..model.model import Model
from ..units import deg
from . import flegx_data as D

__all__ = ["flegx", "FlegxInfo", "leg_geometry", "add_link", "add_worm_drive", "strip_reduced", "LINK_MODELS", "GEARS"]

LINK_MODELS = ("rigid", "prbm", "cb")
GEARS = ("ideal", "worm")
_Y = np.array([0.0, 1.0, 0.0])
_DOWN = np.array([0.0, 0.0, -1.0])


def _Ry(theta):
    c, s = math.cos(theta), math.sin(theta)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


@dataclass
class FlegxInfo:
    """What :func:`flegx` built (``model.flegx``); ``parameters`` rows are (name, value, unit, source)."""

    configuration: int
    link_case: int | None
    link_geometry: tuple  # (L, W, t) [m]
    link_model: str
    gears: str
    stand: tuple  # (θ1, θ2) [rad] of the modelled pose
    hip_height: float  # [m] at the modelled pose
    masses: dict  # part group -> kg
    total_mass: float
    knee_drive: str  # "tendon" (No. 4) or "direct"
    prbm: object = None  # PRBMLink for link_model="prbm"
    cb: dict = field(default_factory=dict)  # beam, reduced, root/tip nodes for link_model="cb"
    EI: float = 0.0
    parameters: list = field(default_factory=list)

    @property
    def section_modulus(self) -> float:
        """W t² / 6 [m³] of the strip."""
        L, W, t = self.link_geometry
        return W * t * t / 6.0

    @property
    def area(self) -> float:
        L, W, t = self.link_geometry
        return W * t


def leg_geometry(theta1, theta2, hip_height, L_link):
    """Hip O, knee K, clamp C, foot centre F [m] and the unit vectors u1 (hip → knee), u2 (strip)."""
    O = np.array([0.0, 0.0, hip_height])
    u1 = _Ry(theta1) @ _DOWN
    u2 = _Ry(theta1 + theta2) @ _DOWN
    K = O + D.HIP_KNEE * u1
    C = K + D.FLANGE_OFFSET * u2
    F = C + L_link * u2
    return dict(O=O, K=K, C=C, F=F, u1=u1, u2=u2)


def _box_inertia(m, a, b, c):
    return m / 12.0 * np.array([b * b + c * c, a * a + c * c, a * a + b * b])


def _strip_frame(u2):
    """Strip axes in ground: x along the strip, y along its width (+y ground), z = thickness."""
    return np.column_stack([u2, _Y, np.cross(u2, _Y)])


def _check_choice(what, value, valid):
    if isinstance(value, bool) or value not in valid:
        raise ModelError(f"flegx: unknown {what} {value!r}; valid choices are {list(valid)}.")
    return value


def check_angles(theta1, theta2, where="pose"):
    """ModelError if θ1 or θ2 [rad] is outside the joint ranges of ``flegx_data``."""
    for what, th, (lo, hi) in (("hip angle θ1", theta1, D.HIP_RANGE_DEG), ("knee angle θ2", theta2, D.KNEE_RANGE_DEG)):
        th = np.asarray(th, float)
        if np.any(th < lo * deg - 1e-12) or np.any(th > hi * deg + 1e-12):
            bad = float(th.min() if np.any(th < lo * deg) else th.max())
            raise ModelError(
                f"flegx: the {where} drives the {what} to {bad / deg:.4g}°, outside its range {lo:g}…{hi:g}° "
                "(flegx_data.HIP_RANGE_DEG / KNEE_RANGE_DEG); give angles in radians within the range.")


def flegx(
    configuration: int = 4,
    link_case: int = 2,
    link_model: str = "rigid",
    gears: str = "ideal",
    *,
    link_geometry=None,
    E_scale: float = 1.0,
    stand=(-30.0 * deg, 60.0 * deg),
    clearance: float = 0.0,
    cb_elements: int = 10,
    cb_modes: int = 3,
    cb_damping: float = 0.015,
    prbm_load: float = D.PRBM_CALIBRATION_LOAD,
    prbm_damping: float = D.PRBM_DAMPING_RATIO,
    guide_mass: float | None = None,
    contact: bool = True,
    contact_stiffness: float = D.CONTACT_STIFFNESS,
    contact_damping: float = D.CONTACT_DAMPING,
    mu: float = 0.0,
    gravity: float = 9.81,
    name: str | None = None,
) -> Model:
    """The FLEGX leg on its linear guide as a proleg Model (module docstring: bodies and choices).

    Parameters
    ----------
    configuration : {1, 2, 3, 4}
        upper-leg design of seed 002 §IV / Fig. 2 (mass split: ``flegx_data`` docstring).
    link_case : {1, ..., 6}
        strip (L, W, t) of seed 002 §II; ignored when ``link_geometry`` is given.
    link_model : {"rigid", "prbm", "cb"}
    gears : {"ideal", "worm"}
        "ideal": the motion laws drive the wheels (lossless, rigid); "worm": worm sliders and
        compliant meshes with friction in the dynamics (:func:`add_worm_drive`), the laws drive
        the worms.
    link_geometry : (L, W, t) [m], optional
        a strip other than the six cases.
    E_scale : float [-]
        multiplies the strip's Young's modulus (E × 100 → the rigid limit; the PRBM and CB
        stiffness scale with it, the mass does not).
    stand : (θ1, θ2) [rad]
        modelled standing pose (default −30°, 60°).
    clearance : float [m], ≥ 0
        foot's lowest point above the ground at the modelled pose.
    cb_elements, cb_modes : int
        beam elements of the strip and fixed-interface normal modes kept (CB link).
    cb_damping : float [-]
        modal damping ratio of the CB link (default 0.015, the PRBM's ξ, seed 002 §III.A).
    prbm_load : float [N]      calibration load P of Eq. 8 (seed 002: 30 N).
    prbm_damping : float [-]   ξ of Eq. 11 (seed 002: 0.015).
    guide_mass : float [kg], optional
        default: Table I total minus the other parts (``flegx_data`` docstring).
    contact, contact_stiffness [N/m^1.5], contact_damping [N s/m], mu [-] :
        the foot's IMPACT contact (assumed values, ``flegx_data``).
    gravity : float [m/s²]

    Returns
    -------
    Model with ``model.flegx`` (:class:`FlegxInfo`).

    Raises
    ------
    ModelError
        unknown configuration / link case / link model / gears (naming the valid range), a
        non-positive strip dimension, a pose outside the joint ranges.
    """
    if isinstance(configuration, bool) or configuration not in D.CONFIGURATIONS:
        raise ModelError(f"flegx: unknown configuration {configuration!r}; valid configurations are 1-4 "
                         "(seed 002 §IV, Fig. 2: No. 1 HyQ-like, No. 2 Ø90 tube, No. 3 semimonocoque, No. 4 Ø75 tube).")
    _check_choice("link_model", link_model, LINK_MODELS)
    _check_choice("gears", gears, GEARS)
    if link_geometry is None:
        L, W, t = D.link_case(link_case)
        case = link_case
    else:
        try:
            L, W, t = (float(x) for x in link_geometry)
        except (TypeError, ValueError):
            raise ModelError(f"flegx: link_geometry must be (L, W, t) in m, got {link_geometry!r}.") from None
        case = None
    for what, v, lo, hi in (("length L", L, 0.05, 0.6), ("width W", W, 0.005, 0.2), ("thickness t", t, 1e-4, 0.02)):
        if not (math.isfinite(v) and lo <= v <= hi):
            raise ModelError(f"flegx: strip {what} = {v!r} m is outside the valid range {lo:g}…{hi:g} m "
                             "(seed 002 cases: L 0.2-0.3, W 0.05-0.07, t 0.002-0.003 m).")
    if not (math.isfinite(E_scale) and E_scale > 0):
        raise ModelError(f"flegx: E_scale must be > 0, got {E_scale!r}.")
    th1, th2 = (float(x) for x in stand)
    check_angles(th1, th2, "standing pose")
    if not (math.isfinite(clearance) and clearance >= 0):
        raise ModelError(f"flegx: clearance must be ≥ 0 m (foot above the ground), got {clearance!r}.")

    from ..fem.materials import Material, material

    base_mat = material(D.MATERIAL)
    mat = Material(f"{base_mat.name} (E x {E_scale:g})", base_mat.E * E_scale, base_mat.nu, base_mat.rho) if E_scale != 1.0 else base_mat
    EI = mat.E * W * t**3 / 12.0
    m_strip = mat.rho * L * W * t
    up = D.UPPER_LEG[configuration]
    tendon = up["knee_drive"] == "tendon"

    # -- mass split (flegx_data docstring) ------------------------------------------------------
    m_upper = up["structure"] + up["motors"] * D.MOTOR_UNIT_MASS
    m_tendon = D.tendon_mass()
    m_wheel = D.WHEEL_CRANK_MASS if tendon else 0.0
    m_strip_ref = base_mat.rho * float(np.prod(D.LINK_CASES[2]))
    others_ref = m_upper + D.FLANGE_MASS + m_wheel + (2 * m_tendon if tendon else 0.0) + m_strip_ref
    m_guide = D.TABLE_I[configuration][0] - others_ref if guide_mass is None else float(guide_mass)
    if not (math.isfinite(m_guide) and m_guide > 0):
        raise ModelError(f"flegx: guide_mass must be > 0 kg, got {m_guide!r}.")
    worm = None
    m_worm = 0.0
    if gears == "worm":  # the worm sliders' mass comes out of their housings (module docstring)
        from ..drives.gears import WormGear

        worm = WormGear(**D.WORM)
        m_worm = D.WORM_INERTIA / (0.5 * worm.worm_pitch_diameter) ** 2
        m_guide -= m_worm * (2 if tendon else 1)
        m_upper -= 0.0 if tendon else m_worm

    z_hip = clearance + D.FOOT_RADIUS - (leg_geometry(th1, th2, 0.0, L)["F"][2])
    g = leg_geometry(th1, th2, z_hip, L)
    O, K, C, F, u1, u2 = (g[k] for k in ("O", "K", "C", "F", "u1", "u2"))

    model = Model(name or f"flegx_no{configuration}_{link_model}", gravity=(0.0, 0.0, -float(gravity)))
    # guide plate: a 0.2 x 0.02 x 0.25 m box about the hip axis (inertia irrelevant on the guide)
    guide = model.add_part("guide", m_guide, _box_inertia(m_guide, 0.2, 0.02, 0.25), O)
    model.add_joint(Prismatic("guide", guide, model.ground, at=O, axis=(0.0, 0.0, 1.0)))

    # upper leg: structure as a thin tube along u1 between hip and knee + motor units as point masses
    R1 = np.column_stack([np.cross(_Y, u1), _Y, u1])  # z along the leg
    r_t = 0.5 * D.TUBE_NO4["outer"]
    pts = [(up["structure"], 0.5), *([(D.MOTOR_UNIT_MASS, up["motor_at"])] * up["motors"])]
    if m_worm and not tendon:  # the knee worm slider (at the knee motor) carries that much of the motor unit
        pts[-1] = (D.MOTOR_UNIT_MASS - m_worm, up["motor_at"])
    com_s = sum(m * s for m, s in pts) / m_upper
    Jzz = up["structure"] * r_t**2 + sum(m * 0.04**2 / 2 for m, _ in pts[1:])
    Jxx = up["structure"] * (D.HIP_KNEE**2 / 12 + r_t**2 / 2) + sum(m * ((s - com_s) * D.HIP_KNEE) ** 2 for m, s in pts)
    Jxx += sum(m * 0.04**2 / 4 for m, _ in pts[1:])  # motor units as Ø80 mm discs about their diameter
    upper = model.add_part("upper_leg", m_upper, np.array([Jxx, Jxx, Jzz]), O + com_s * D.HIP_KNEE * u1, R1)
    model.add_joint(Revolute("hip", upper, guide, at=O, axis=_Y))

    flange = model.add_part("knee_flange", D.FLANGE_MASS, _box_inertia(D.FLANGE_MASS, 0.05, 0.08, 0.05), K)
    model.add_joint(Revolute("knee", flange, upper, at=K, axis=_Y))

    if tendon:
        # crank on the wheel and lever on the flange: same vector a, at θ1 + θ2 + CRANK_ANGLE
        a = D.CRANK_RADIUS * (_Ry(th1 + th2 + D.CRANK_ANGLE) @ _DOWN)
        r_w = 0.5 * D.WORM["wheel_teeth"] * D.WORM["module"]
        wheel = model.add_part("knee_wheel", m_wheel, [0.25 * m_wheel * r_w**2, 0.5 * m_wheel * r_w**2, 0.25 * m_wheel * r_w**2], O)
        model.add_joint(Revolute("knee_wheel", wheel, guide, at=O, axis=_Y))
        e = (K - O) / np.linalg.norm(K - O)
        Rr = np.column_stack([np.cross(_Y, e), _Y, e])
        rr = 0.5 * D.TENDON_DIAMETER
        Jr = [m_tendon * (3 * rr**2 + D.TENDON_LENGTH**2) / 12] * 2 + [0.5 * m_tendon * rr**2]
        for s, dy in (("a", D.TENDON_SPAN), ("b", -D.TENDON_SPAN)):
            A, B = O + a + dy * _Y, K + a + dy * _Y
            rod = model.add_part(f"tendon_{s}", m_tendon, Jr, 0.5 * (A + B), Rr)
            model.add_joint(Spherical(f"tendon_{s}.wheel", rod, wheel, at=A))
            model.add_joint(Spherical(f"tendon_{s}.knee", rod, flange, at=B))

    # -- the strip -------------------------------------------------------------------------------
    link = add_link(model, flange, C, u2, link_model, (L, W, t), mat, base_material=base_mat, cb_elements=cb_elements,
                    cb_modes=cb_modes, cb_damping=cb_damping, prbm_load=prbm_load, prbm_damping=prbm_damping)
    tip_part, prbm, cb = link["tip_part"], link["prbm"], link["cb"]

    Rfoot = np.column_stack([np.array([1.0, 0.0, 0.0]), np.array([0.0, 0.0, -1.0]), _Y])  # cylinder axis z along +y
    if link_model == "cb":
        foot = model.add_marker(tip_part, "foot", node=cb["tip"], orientation=Rfoot)
    else:
        foot = model.add_marker(tip_part, "foot", F, Rfoot)
    if contact:
        model.add_contact(CylinderContact(
            "foot", foot, radius=D.FOOT_RADIUS, stiffness=contact_stiffness, exponent=D.CONTACT_EXPONENT,
            damping=contact_damping, penetration=D.CONTACT_PENETRATION, mu_static=mu, mu_dynamic=mu))

    if worm is not None:
        model.add_variable("worm_f_static", D.WORM_FRICTION_STATIC, "-", "worm mesh static friction coefficient (seed 002 §IV)")
        model.add_variable("worm_f_dynamic", D.WORM_FRICTION_DYNAMIC, "-", "worm mesh dynamic friction coefficient (seed 002 §IV)")
        add_worm_drive(model, "hip", "hip", upper, guide, O, worm, m_worm)
        if tendon:
            add_worm_drive(model, "knee", "knee_wheel", wheel, guide, O, worm, m_worm)
        else:
            add_worm_drive(model, "knee", "knee", flange, upper, O + up["motor_at"] * D.HIP_KNEE * u1, worm, m_worm)
    masses = {"guide": m_guide, "upper_leg": m_upper, "knee_flange": D.FLANGE_MASS, "knee_wheel": m_wheel,
              "tendons": 2 * m_tendon if tendon else 0.0, "strip": m_strip, "worms": 2 * m_worm}
    total = sum(masses.values())
    params = D.sources() + [
        ("configuration", configuration, "-", "seed 002 §IV"),
        ("link (L, W, t)", [L * 1e3, W * 1e3, t * 1e3], "mm", f"seed 002 §II case {case}" if case else "user"),
        ("link model", link_model, "-", "seed 002 §III"),
        ("E scale", E_scale, "-", "1 = AISI 304"),
        ("mass split", {k: round(v, 4) for k, v in masses.items()}, "kg", "flegx_data docstring"),
        ("total moving mass", total, "kg", f"Table I: {D.TABLE_I[configuration][0]} kg (case 2)"),
        ("standing pose θ1, θ2", [th1 / deg, th2 / deg], "deg", "assumed"),
    ]
    if prbm is not None:
        params.append(("PRBM γ, K_t, C_t, J", [prbm.gamma, prbm.K_t, prbm.C_t, prbm.J], "-, N m/rad, N m s/rad, kg m²",
                       "seed 002 Eqs. 8-11"))
    model.flegx = FlegxInfo(
        configuration=configuration, link_case=case, link_geometry=(L, W, t), link_model=link_model, gears=gears,
        stand=(th1, th2), hip_height=float(z_hip), masses=masses, total_mass=total,
        knee_drive=up["knee_drive"], prbm=prbm, cb=cb, EI=EI, parameters=params)
    return model


def add_worm_drive(model, name, joint, wheel, housing, at, worm, mass, *, stiffness=D.WORM_MESH_STIFFNESS,
                   damping=D.WORM_MESH_DAMPING, v_static=D.WORM_V_STATIC, v_dynamic=D.WORM_V_DYNAMIC):
    """A worm set driving the revolute ``joint`` (its part I ``wheel`` turns about z_J relative to
    ``housing``, its part J): the worm slider ``<name>_worm`` (mass ``mass`` [kg]) on a Prismatic
    to ``housing`` at ``at`` along ground x, and the :func:`~proleg.drives.gears.worm_mesh` loads
    between them (slider force F along the axis, reaction on the housing; wheel torque T about
    z_J, reaction on the housing), with the model variables ``worm_f_static``/``worm_f_dynamic``.
    ``stiffness`` [N m/rad] and ``damping`` [N m s/rad] are referred to the wheel."""
    import jax.numpy as jnp

    from ..drives.gears import worm_mesh
    from ..model.forces import Force, Torque

    r2c = 0.5 * worm.wheel_pitch_diameter * math.cos(worm.lead_angle)
    k, c = stiffness / r2c**2, damping / r2c**2
    slider = model.add_part(f"{name}_worm", mass, [1e-6] * 3, at)
    pj = model.add_joint(Prismatic(f"{name}_worm", slider, housing, at=at, axis=(1.0, 0.0, 0.0)))
    wj = next(j for j in model.joints if j.name == joint)

    def mesh(state):
        zs = state.marker_orientation(pj.marker_j)[:, 2]
        sd = jnp.dot(zs, state.marker_velocity(pj.marker_i) - state.marker_velocity(pj.marker_j))
        out = worm_mesh(worm, state.joint_translation(pj), sd, state.joint_angle(wj), state.joint_rate(wj), k, c,
                        state.variable("worm_f_static"), state.variable("worm_f_dynamic"), v_static, v_dynamic)
        return out, zs, state.marker_orientation(wj.marker_j)[:, 2]

    def on_worm(t, state):
        out, zs, _ = mesh(state)
        return out["worm_force"] * zs

    def on_wheel(t, state):
        out, _, zw = mesh(state)
        return out["wheel_torque"] * zw

    model.add_force(Force(f"{name}_mesh.worm", slider, on_worm))
    model.add_force(Force(f"{name}_mesh.worm_housing", housing, lambda t, state: -on_worm(t, state), at=at))
    model.add_force(Torque(f"{name}_mesh.wheel", wheel, on_wheel))
    model.add_force(Torque(f"{name}_mesh.wheel_housing", housing, lambda t, state: -on_wheel(t, state)))
    return dict(slider=slider, joint=pj, stiffness=k, damping=c, v_static=v_static, v_dynamic=v_dynamic)


def add_link(model, parent, at, direction, link_model, geometry, mat, *, base_material=None, cb_elements=10, cb_modes=3,
             cb_damping=0.015, prbm_load=D.PRBM_CALIBRATION_LOAD, prbm_damping=D.PRBM_DAMPING_RATIO, name="link"):
    """Clamp the strip (L, W, t) [m] of material ``mat`` to ``parent`` at ``at``, pointing along
    ``direction`` (in the x-z plane; width along +y), as ``link_model`` (module docstring).

    ``base_material`` is the material the PRBM is calibrated with (Eq. 8 with the elastica of
    that E); when ``mat`` differs (``E_scale``) the PRBM keeps γ and scales K_t, C_t with E.
    Returns dict(tip_part, prbm, cb) with ``cb`` = dict(beam, reduced, root, tip, body).
    """
    L, W, t = geometry
    u2 = np.asarray(direction, float)
    Rs = _strip_frame(u2)
    prbm, cb = None, {}
    base_material = base_material or mat
    if link_model == "rigid":
        m_strip = mat.rho * L * W * t
        link = model.add_part(name, m_strip, Rs @ np.diag(_box_inertia(m_strip, L, W, t)) @ Rs.T, at + 0.5 * L * u2)
        model.add_joint(Fixed(f"{name}.clamp", link, parent, at=at))
        tip_part = link
    elif link_model == "prbm":
        from ..flex.prbm import PRBMLink, dynamic_prbm

        prbm = dynamic_prbm(L, W, t, base_material, load=prbm_load, damping_ratio=prbm_damping)
        if mat.E != base_material.E:  # same γ, stiffness (and damping) scaled with E
            prbm = PRBMLink.from_gamma(prbm.gamma, L, W, t, mat, prbm_damping)
        parts = prbm.to_model(model, parent, at, _Y, u2, name=name)
        tip_part = parts["tip"]
    else:
        rb, beam, root, tip = strip_reduced(L, W, t, mat, cb_elements, cb_modes)
        n1 = beam.node_at((L / cb_elements, 0, 0))
        le, c, Em = L / cb_elements, 0.5 * t, mat.E

        def root_stress(u):
            """σ at (x = 0, z = ±t/2) of the root element: Hermite curvature + axial bar strain."""
            w0, t0 = u[beam.dof(root, "uz")], -u[beam.dof(root, "ry")]
            w1, t1 = u[beam.dof(n1, "uz")], -u[beam.dof(n1, "ry")]
            kappa = 6 * (w1 - w0) / le**2 - (4 * t0 + 2 * t1) / le
            eps = (u[beam.dof(n1, "ux")] - u[beam.dof(root, "ux")]) / le
            out = np.zeros((2, 3, 3))
            out[0, 0, 0] = Em * (eps - c * kappa)
            out[1, 0, 0] = Em * (eps + c * kappa)
            return out

        link = model.add_flexible_body(name, rb, frame_node=root, position=at, orientation=Rs,
                                       damping_ratio=cb_damping, stress=([(0, 0, c), (0, 0, -c)], root_stress))
        model.add_joint(Fixed(f"{name}.clamp", link, parent, at=at))
        cb = dict(beam=beam, reduced=rb, root=root, tip=tip, body=link)
        tip_part = link
    return dict(tip_part=tip_part, prbm=prbm, cb=cb)


def strip_reduced(L, W, t, mat, n_elements=10, n_modes=3):
    """Craig-Bampton reduction of the strip as Euler-Bernoulli beams along FE x (thickness along
    FE z): interface nodes root (x = 0) and tip (x = L), ``n_modes`` fixed-interface modes.
    Returns (ReducedBody, BeamModel, root node, tip node)."""
    from ..fem.beam import BeamModel, Section
    from ..fem.craig_bampton import craig_bampton

    beam = BeamModel.polyline([(0, 0, 0), (L, 0, 0)], int(n_elements), Section.rectangle(W, t), mat)
    root, tip = beam.node_at((0, 0, 0)), beam.node_at((L, 0, 0))
    B = np.concatenate([beam.node_dofs([root]), beam.node_dofs([tip])])
    rb = craig_bampton(beam.K, beam.M, B, int(n_modes), node_coordinates=beam.node_coordinates, node_dofs=beam.node_dof_table)
    return rb, beam, root, tip
