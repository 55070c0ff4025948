"""Lower-pair joints: degrees of freedom at a generic pose, screw and prismatic motion under
load, and joint reactions (formulation note §2, §5).
"""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import proleg as pl
from proleg.assembly.system import dof_report
from tolerances import CONSTRAINT_RESIDUAL

G = 9.81

# ---------------------------------------------------------------------------------------------
# DOF of one body on each joint type, at a generic pose
# ---------------------------------------------------------------------------------------------
R_GENERIC = Rotation.from_rotvec([0.3, -0.7, 0.4]).as_matrix()
AT = np.array([0.21, -0.13, 0.37])
AXIS = np.array([0.4, -0.5, 0.77]) / np.linalg.norm([0.4, -0.5, 0.77])
AXIS_J = np.cross(AXIS, [1.0, 0.0, 0.0])
AXIS_J /= np.linalg.norm(AXIS_J)

JOINTS = {
    "revolute": (lambda b, g: pl.Revolute("j", b, g, at=AT, axis=AXIS), 5),
    "spherical": (lambda b, g: pl.Spherical("j", b, g, at=AT), 3),
    "cylindrical": (lambda b, g: pl.Cylindrical("j", b, g, at=AT, axis=AXIS), 4),
    "prismatic": (lambda b, g: pl.Prismatic("j", b, g, at=AT, axis=AXIS), 5),
    "screw": (lambda b, g: pl.Screw("j", b, g, at=AT, axis=AXIS, pitch=0.02), 5),
    "planar": (lambda b, g: pl.Planar("j", b, g, at=AT, axis=AXIS), 3),
    "fixed": (lambda b, g: pl.Fixed("j", b, g, at=AT), 6),
    "universal": (lambda b, g: pl.Universal("j", b, g, at=AT, axis_i=AXIS, axis_j=AXIS_J), 4),
}


@pytest.mark.parametrize("kind", list(JOINTS))
def test_dof_of_single_body(kind):
    """One body, one joint to ground: DOF = 7 − rank Φ_q (with the normalization row) = 6 − #eq."""
    make, n_eq = JOINTS[kind]
    model = pl.Model(f"dof_{kind}", gravity=(0, 0, 0))
    body = model.add_part("body", mass=1.3, inertia=(0.02, 0.03, 0.04), position=(0.5, 0.4, -0.2), orientation=R_GENERIC)
    joint = model.add_joint(make(body, model.ground))
    assert joint.n_equations == n_eq
    system = pl.assemble(model)
    report = dof_report(system)
    assert report["rank"] == 6 - n_eq
    assert report["gruebler"] == 6 - n_eq
    assert report["redundant"] == []


# ---------------------------------------------------------------------------------------------
# Motion under load: four independent bodies in one model (compiled once)
# ---------------------------------------------------------------------------------------------
# Screw: horizontal axis, COM on the axis (gravity does no work along it), constant torque τ
# about the axis. Kinetic energy ½ (I_u + m ℓ²) θ̇² with ℓ = pitch / 2π, so
#     θ(t) = τ t² / (2 (I_u + m ℓ²)),  s(t) = ℓ θ(t).
SCREW_AXIS = np.array([np.cos(0.5), np.sin(0.5), 0.0])
SCREW_AT = np.array([0.0, 0.0, 1.0])
SCREW_M, SCREW_I, PITCH, TAU = 2.0, 0.05, 0.1, 0.2  # m ℓ² is 1 % of I_u
LEAD = PITCH / (2 * np.pi)
# Prismatic: axis at angle β to the downward vertical: s(t) = ½ g cos β t², a = g cos β u.
BETA = 0.6
PRISM_AXIS = np.array([np.sin(BETA) * np.cos(0.3), np.sin(BETA) * np.sin(0.3), -np.cos(BETA)])
PRISM_AT = np.array([2.0, 0.0, 0.0])
# Hanging bodies (3 kg) on a pin along y: "note" has its COM 0.2 m along the pin axis from the
# joint point (formulation note §5 (d)); "hang" in addition 0.1 m below (stable).
HANG_M = 3.0
PIN_NOTE, PIN_HANG = np.array([4.0, 0.0, 0.0]), np.array([6.0, 0.0, 0.0])
COM_NOTE = PIN_NOTE + np.array([0.0, 0.2, 0.0])
COM_HANG = PIN_HANG + np.array([0.0, 0.2, -0.1])
T_SIM = 1.0


def hanging_body(model, name, com, pin):
    body = model.add_part(name, mass=HANG_M, inertia=(0.02, 0.03, 0.04), position=com, orientation=R_GENERIC)
    model.add_joint(pl.Revolute(f"{name}_pin", body, model.ground, at=pin, axis=(0, 1, 0)))
    return body


@pytest.fixture(scope="module")
def motion():
    model = pl.Model("joint_motion", gravity=(0, 0, -G))
    screw = model.add_part("screw_body", mass=SCREW_M, inertia=(SCREW_I,) * 3, position=SCREW_AT, orientation=R_GENERIC)
    model.add_joint(pl.Screw("screw", screw, model.ground, at=SCREW_AT, axis=SCREW_AXIS, pitch=PITCH))
    model.add_force(pl.Torque("drive", screw, value=TAU * SCREW_AXIS))
    slider = model.add_part("slider", mass=0.7, inertia=(0.01, 0.02, 0.03), position=PRISM_AT, orientation=R_GENERIC)
    model.add_joint(pl.Prismatic("slide", slider, model.ground, at=PRISM_AT, axis=PRISM_AXIS))
    hanging_body(model, "note", COM_NOTE, PIN_NOTE)
    hanging_body(model, "hang", COM_HANG, PIN_HANG)
    system = pl.assemble(model)
    # the α-method named: these tests measure the joints' closure at every output (50 phi_tol), which
    # its projected outputs give; integrator="auto" runs this model (a screw row on the tree) with
    # Radau5, whose outputs between steps are interpolated (solvers/auto.py)
    return pl.simulate(system, t_end=T_SIM, dt_output=0.004, integrator=pl.GeneralizedAlpha())


def test_screw_translates_pitch_per_turn(motion):
    """Translation along the axis / rotation about it = pitch / 2π at every output (1e-9 m), and
    θ(t) = τ t² / (2 (I_u + m ℓ²)) within 1e-4 relative (the default-tolerance integration error,
    1.1e-5 measured: θ is quadratic in t, the Euler parameters are not), while dropping m ℓ² would
    be off by 1e-2."""
    j = motion.joint("screw")
    np.testing.assert_allclose(j.translation, LEAD * j.angle, rtol=0, atol=1e-9)
    theta = TAU * motion.t**2 / (2 * (SCREW_I + SCREW_M * LEAD**2))
    assert theta[-1] > 1.5  # turned well over a radian, less than π
    np.testing.assert_allclose(j.angle, theta, rtol=1e-4, atol=1e-12)
    # the COM (on the axis) moves along the axis only, by ℓ θ
    r = motion.part("screw_body").position
    np.testing.assert_allclose(r - SCREW_AT, np.outer(LEAD * j.angle, SCREW_AXIS), atol=1e-9)
    assert np.max(motion.constraint_residual()) < CONSTRAINT_RESIDUAL  # tests/tolerances.py: 50 phi_tol


def test_prismatic_slides_with_g_cos_angle(motion):
    """s(t) = ½ g cos β t² along the axis; acceleration g cos β u (Newmark-type schemes are exact
    for constant acceleration, so 1e-9)."""
    j = motion.joint("slide")
    a = G * np.cos(BETA)
    np.testing.assert_allclose(j.translation, 0.5 * a * motion.t**2, rtol=0, atol=1e-9)
    part = motion.part("slider")
    np.testing.assert_allclose(part.position - PRISM_AT, np.outer(0.5 * a * motion.t**2, PRISM_AXIS), atol=1e-9)
    np.testing.assert_allclose(part.acceleration, np.tile(a * PRISM_AXIS, (len(motion.t), 1)), atol=1e-9)
    # round-off; 2.2e-10 at outputs between steps (dense output of the Newton-level noise in q̈)
    np.testing.assert_allclose(part.angular_velocity, 0.0, atol=1e-9)


def _check_hanging_reaction(joint_result, com, pin):
    """Reaction on the body at the pin: F = m g ẑ, T = −(r_com − r_pin) × m g, |T| = m g · 0.2."""
    w = np.array([0.0, 0.0, -HANG_M * G])
    F, T = joint_result.force, joint_result.torque
    np.testing.assert_allclose(np.linalg.norm(F, axis=-1), HANG_M * G, rtol=0, atol=1e-9)
    np.testing.assert_allclose(np.linalg.norm(T, axis=-1), HANG_M * G * 0.2, rtol=0, atol=1e-9)
    np.testing.assert_allclose(F, np.broadcast_to(-w, F.shape), atol=1e-9)
    np.testing.assert_allclose(T, np.broadcast_to(-np.cross(com - pin, w), T.shape), atol=1e-9)


@pytest.mark.parametrize("name", ["note", "hang"])
def test_reaction_of_hanging_body_during_simulation(motion, name):
    """At rest under gravity for 1 s: joint force m g = 29.43 N, moment m g 0.2 = 5.886 N m at
    every output, and the body does not move."""
    com, pin = (COM_NOTE, PIN_NOTE) if name == "note" else (COM_HANG, PIN_HANG)
    _check_hanging_reaction(motion.joint(f"{name}_pin"), com, pin)
    part = motion.part(name)
    np.testing.assert_allclose(part.position, np.broadcast_to(com, part.position.shape), atol=1e-12)
    assert motion.t[-1] == pytest.approx(T_SIM)


def test_reaction_of_hanging_body_at_equilibrium():
    """Static equilibrium of the stable variant (COM 0.2 m along the pin and 0.1 m below it; the
    vertical offset is parallel to gravity and adds no moment). The note's variant, with the COM on
    the pin axis, is a neutral equilibrium that solve_equilibrium rejects as not statically
    determinate, so it is checked in the simulation only."""
    model = pl.Model("hanging", gravity=(0, 0, -G))
    hanging_body(model, "hang", COM_HANG, PIN_HANG)
    eq = pl.solve_equilibrium(pl.assemble(model))
    np.testing.assert_allclose(eq.q[:3], COM_HANG, atol=1e-12)
    _check_hanging_reaction(eq.result().joint("hang_pin"), COM_HANG, PIN_HANG)
