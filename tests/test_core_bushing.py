"""Six-component bushing (Adams convention, formulation note §3): static deflection under known
loads, and the stiff-bushing limit of a revolute joint.

Convention under test: the bushing force on marker I is f = −K_t d, t = −K_r (a, b, c) with d
the translation of I relative to J and (a, b, c) = (AX, AY, AZ) its projected rotation angles,
all in J axes; F = R_J f, T = R_J t in ground.
"""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import proleg as pl
from proleg.spatial.rotation import frame_from_axis
from tolerances import CONSTRAINT_RESIDUAL

# ---------------------------------------------------------------------------------------------
# Statics: two parts, each held only by a bushing to ground, loaded by a Force and a Torque.
# ---------------------------------------------------------------------------------------------
K_DIAG = np.array([2.0e4, 5.0e4, 1.0e5, 300.0, 500.0, 800.0])  # [N/m ×3, N m/rad ×3]
R_J = Rotation.from_rotvec([0.3, -0.5, 0.7]).as_matrix()  # J axes (generic, ground-fixed)
R_PART = Rotation.from_rotvec([-0.2, 0.4, 0.1]).as_matrix()
F_A = np.array([12.0, -30.0, 45.0])  # [N] ground
T_A = 0.4 * R_J[:, 2]  # [N m] ground, about z_J only: AZ is then exact
T_B = np.array([1.0e-4, -2.0e-4, 1.5e-4])  # [N m] ground, general direction, rotation ~1e-7 rad


@pytest.fixture(scope="module")
def static_eq():
    model = pl.Model("bushing_statics", gravity=(0, 0, 0))
    out = {}
    for name, x0, F, T in (("a", np.array([0.0, 0, 0]), F_A, T_A), ("b", np.array([1.0, 0, 0]), None, T_B)):
        part = model.add_part(name, mass=1.0, inertia=(0.01, 0.02, 0.025), position=x0, orientation=R_PART)
        mi = model.add_marker(part, f"{name}_I", position=x0, orientation=R_J)  # at the COM
        mj = model.add_marker(model.ground, f"{name}_J", position=x0, orientation=R_J)
        model.add_force(pl.Bushing(f"bush_{name}", mi, mj, stiffness=K_DIAG))
        if F is not None:
            model.add_force(pl.Force(f"force_{name}", part, value=F))
        model.add_force(pl.Torque(f"torque_{name}", part, value=T))
        out[name] = x0
    system = pl.assemble(model)
    eq = pl.solve_equilibrium(system)
    return system, eq, out


def _rotvec(eq, b):
    """Rotation vector (ground) of body b relative to its modelled orientation."""
    p = eq.q[7 * b + 3 : 7 * b + 7]
    R = Rotation.from_quat([p[1], p[2], p[3], p[0]]).as_matrix()
    return Rotation.from_matrix(R @ R_PART.T).as_rotvec()


def test_static_translation_and_single_axis_rotation(static_eq):
    """Part a: F at the COM (= marker I) ⇒ d = K_t⁻¹ R_Jᵀ F (in J axes); T about z_J only ⇒ the
    part turns about z_J by exactly |T| / K_c (AZ is exact for a rotation about one J axis)."""
    system, eq, x0 = static_eq
    r = eq.q[0:3]
    d_expected = (R_J.T @ F_A) / K_DIAG[:3]
    # rtol 1e-9 governs (no component is near zero: R_J is generic); atol 1e-15 is only a floor
    np.testing.assert_allclose(R_J.T @ (r - x0["a"]), d_expected, rtol=1e-9, atol=1e-15)
    np.testing.assert_allclose(_rotvec(eq, 0), (0.4 / K_DIAG[5]) * R_J[:, 2], rtol=1e-9, atol=1e-15)
    # the element's own outputs agree, in J axes and in ground
    out = eq.result().element("bush_a")
    np.testing.assert_allclose(out.deformation[0], d_expected, rtol=1e-9)
    np.testing.assert_allclose(out.force[0], -F_A, rtol=1e-9)
    np.testing.assert_allclose(out.torque[0], -T_A, rtol=1e-9, atol=1e-12)


def test_static_small_angle_rotation(static_eq):
    """Part b: a torque T in a general direction ⇒ (AX, AY, AZ) = K_r⁻¹ R_Jᵀ T exactly (the bushing
    law), and the physical rotation vector equals it up to the small-angle error O(θ) relative;
    θ ≈ 1e-6 rad here, so 1e-6 relative covers it."""
    system, eq, x0 = static_eq
    theta_expected = (R_J.T @ T_B) / K_DIAG[3:]
    out = eq.result().element("bush_b")
    np.testing.assert_allclose(out.rotation[0], theta_expected, rtol=1e-9)
    np.testing.assert_allclose(R_J.T @ _rotvec(eq, 1), theta_expected, rtol=1e-6)
    # no force, so no translation
    # round-off only: 64 eps of the 1 m position (the Newton increments in x are ~eps × the 1e-7 rad rotation)
    np.testing.assert_allclose(eq.q[7:10], x0["b"], atol=64 * np.finfo(float).eps * 1.0)


# ---------------------------------------------------------------------------------------------
# Dynamics: a pendulum on a Revolute and a twin on a stiff Bushing, in one model.
# ---------------------------------------------------------------------------------------------
AXIS = np.array([0.3, 1.0, 0.2]) / np.linalg.norm([0.3, 1.0, 0.2])  # tilted pin
J_FULL = np.array([[0.02, 0.001, -0.002], [0.001, 0.03, 0.0005], [-0.002, 0.0005, 0.025]])
OFFSET = np.array([0.0, 0.0, -0.4]) + 0.1 * AXIS  # COM relative to the pin (0.1 m along it)
W0 = 5.0  # initial angular speed about the pin [rad/s]; swing ≈ ±1.13 rad


@pytest.fixture(scope="module")
def twin_pendulums():
    model = pl.Model("revolute_vs_bushing", gravity=(0, 0, -9.81))
    w = W0 * AXIS
    a = model.add_part("rev_body", 1.5, J_FULL, OFFSET, angular_velocity=w, velocity=np.cross(w, OFFSET))
    model.add_joint(pl.Revolute("pin", a, model.ground, at=(0, 0, 0), axis=AXIS))
    base = np.array([2.0, 0.0, 0.0])
    b = model.add_part("bush_body", 1.5, J_FULL, base + OFFSET, angular_velocity=w, velocity=np.cross(w, OFFSET))
    R = frame_from_axis(AXIS)
    mi = model.add_marker(b, "hinge_I", position=base, orientation=R)
    mj = model.add_marker(model.ground, "hinge_J", position=base, orientation=R)
    # 1e9 N/m, 1e9 N m/rad on the two tilts, 0 about the hinge axis (formulation note §3, §7)
    model.add_force(pl.Bushing("hinge", mi, mj, stiffness=(1e9, 1e9, 1e9, 1e9, 1e9, 0.0)))
    system = pl.assemble(model)
    return pl.simulate(system, t_end=1.0, dt_output=0.002)  # default tolerances


def test_stiff_bushing_matches_revolute(twin_pendulums):
    """Angle about the pin of the revolute pendulum vs AZ of the bushing pendulum: the bushing
    deflects by m g / k ≈ 1.5e-8 (m, rad), so the two agree to the integration error (3.8e-6 rad
    measured at the default tolerances), asserted at 1e-5 rad over 1 s."""
    res = twin_pendulums
    a_rev = res.joint("pin").angle
    a_bush = res.element("hinge").rotation[:, 2]
    assert np.max(np.abs(a_rev)) > 1.0  # a real swing, not a small oscillation
    assert np.max(np.abs(a_rev - a_bush)) < 1e-5
    tilt = res.element("hinge").rotation[:, :2]
    assert np.max(np.abs(tilt)) < 1e-7
    # the physical deflection is 1.5e-8 m; the rest is the integration error at atol = 1e-7 m,
    # read between steps from the dense output (measured 1.1e-7 m; 1e-7 held at step ends)
    assert np.max(np.abs(res.element("hinge").deformation)) < 2e-7
    assert np.max(res.constraint_residual()) < CONSTRAINT_RESIDUAL  # tests/tolerances.py: 50 phi_tol
