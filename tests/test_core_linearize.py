"""Linearisation about a static equilibrium and modal analysis, against closed forms.

One model holds three mechanically independent subsystems (so that the equilibrium and the
linearisation are computed, and compiled, once): its modes are the union of theirs, with
frequencies chosen well apart.

1. Pendulum: a bob (m = 1 kg, isotropic J_c = 1e-6 kg m²) 1 m below a pin along y:
   ω² = m g L / (J_c + m L²).
2. Two-mass chain on prismatic joints along x: ground –k1– m1 –k2– m2 (springs at free length in
   the modelled pose): M = diag(m1, m2), K = [[k1 + k2, −k2], [−k2, k2]], and det(K − ω² M) = 0
   ⇔ m1 m2 ω⁴ − (m1 k2 + m2 (k1 + k2)) ω² + k1 k2 = 0; mode shape x2/x1 = (k1 + k2 − ω² m1)/k2.
3. Damped oscillator on a prismatic joint: ω_n = sqrt(k/m), ζ = c / (2 sqrt(k m)),
   ω_d = ω_n sqrt(1 − ζ²).
"""

import numpy as np
import pytest

import proleg as pl

# pl.linearize evaluates its Jacobians eagerly (op by op, not under jit), which costs 30-60 s of
# dispatch and per-primitive compilation on the 2-core machine: over the suite's budget, hence slow.
pytestmark = pytest.mark.slow

G = 9.81
BOB_M, BOB_L, BOB_J = 1.0, 1.0, 1e-6
M1, M2, K1, K2 = 1.0, 2.0, 100.0, 200.0
OSC_M, OSC_K, OSC_ZETA = 1.0, 900.0, 0.05
OSC_C = 2 * OSC_ZETA * np.sqrt(OSC_K * OSC_M)

W_PEND = np.sqrt(BOB_M * G * BOB_L / (BOB_J + BOB_M * BOB_L**2))
_b = M1 * K2 + M2 * (K1 + K2)
W2_CHAIN = (_b + np.array([-1.0, 1.0]) * np.sqrt(_b**2 - 4 * M1 * M2 * K1 * K2)) / (2 * M1 * M2)
W_OSC = np.sqrt(OSC_K / OSC_M)


@pytest.fixture(scope="module")
def linear():
    model = pl.Model("modal_bench", gravity=(0, 0, -G))
    # 1. pendulum at y = 0
    bob = model.add_part("bob", mass=BOB_M, inertia=(BOB_J,) * 3, position=(0, 0, -BOB_L))
    model.add_joint(pl.Revolute("pin", bob, model.ground, at=(0, 0, 0), axis=(0, 1, 0)))
    # 2. chain at y = 1: anchor x = −1, m1 at x = 0, m2 at x = 1
    y = 1.0
    m1 = model.add_part("m1", mass=M1, inertia=(0.01, 0.01, 0.01), position=(0, y, 0))
    m2 = model.add_part("m2", mass=M2, inertia=(0.01, 0.01, 0.01), position=(1, y, 0))
    for name, part, x in (("rail1", m1, 0.0), ("rail2", m2, 1.0)):
        model.add_joint(pl.Prismatic(name, part, model.ground, at=(x, y, 0), axis=(1, 0, 0)))
    a0 = model.add_marker(model.ground, "chain_anchor", position=(-1, y, 0))
    a1 = model.add_marker(m1, "m1_mk", position=(0, y, 0))
    a2 = model.add_marker(m2, "m2_mk", position=(1, y, 0))
    model.add_force(pl.SpringDamper("k1", a1, a0, stiffness=K1, free_length=1.0))
    model.add_force(pl.SpringDamper("k2", a2, a1, stiffness=K2, free_length=1.0))
    # 3. damped oscillator at y = 2
    y = 2.0
    osc = model.add_part("osc", mass=OSC_M, inertia=(0.01, 0.01, 0.01), position=(0, y, 0))
    model.add_joint(pl.Prismatic("rail3", osc, model.ground, at=(0, y, 0), axis=(1, 0, 0)))
    b0 = model.add_marker(model.ground, "osc_anchor", position=(-1, y, 0))
    b1 = model.add_marker(osc, "osc_mk", position=(0, y, 0))
    model.add_force(pl.SpringDamper("osc_spring", b1, b0, stiffness=OSC_K, damping=OSC_C, free_length=1.0))
    system = pl.assemble(model)
    eq = pl.solve_equilibrium(system)
    lin = pl.linearize(system, eq)
    return system, eq, lin, lin.modes()


def test_mode_count(linear):
    """1 + 2 + 1 independent coordinates."""
    _, _, lin, modes = linear
    assert lin.M.shape == (4, 4)
    assert len(modes.frequencies) == 4
    expected = np.sort(np.concatenate([[W_PEND], np.sqrt(W2_CHAIN), [W_OSC]])) / (2 * np.pi)
    np.testing.assert_allclose(modes.frequencies, expected, rtol=1e-8)


def test_pendulum_frequency(linear):
    """f = sqrt(m g L / (J_c + m L²)) / 2π ≈ sqrt(g/L)/2π (J_c ≪ m L²)."""
    _, _, _, modes = linear
    f = modes.frequencies[np.argmin(np.abs(modes.frequencies - W_PEND / (2 * np.pi)))]
    assert f == pytest.approx(W_PEND / (2 * np.pi), rel=1e-8)
    assert f == pytest.approx(np.sqrt(G / BOB_L) / (2 * np.pi), rel=1e-6)  # J_c/(m L²) = 1e-6


def test_two_mass_chain_eigenvalues_and_shapes(linear):
    """ω² from the 2×2 generalized eigenproblem by hand, 1e-8 relative; shapes x2/x1 to 1e-8."""
    system, _, lin, modes = linear
    names = system.topo.body_names
    # an undamped mode's ζ = −Re(s)/|s| is round-off of the nonsymmetric eigensolver: a backward
    # error ~ eps ‖A‖ in Re(s), with ‖A‖ (≈ 1e3 s⁻², the state matrix) over |s| (5 to 20 rad/s)
    zeta_tol = 64 * np.finfo(float).eps * np.linalg.norm(lin.state_matrix, 2)
    i1, i2 = 7 * names.index("m1"), 7 * names.index("m2")  # x coordinates of m1, m2
    for w2 in W2_CHAIN:
        k = np.argmin(np.abs(modes.frequencies - np.sqrt(w2) / (2 * np.pi)))
        assert (2 * np.pi * modes.frequencies[k]) ** 2 == pytest.approx(w2, rel=1e-8)
        shape = modes.shapes[:, k]
        assert shape[i2] / shape[i1] == pytest.approx((K1 + K2 - w2 * M1) / K2, rel=1e-8)
        assert modes.damping_ratios[k] == pytest.approx(0.0, abs=zeta_tol / np.sqrt(w2))


def test_damped_oscillator(linear):
    """ζ = c / (2 sqrt(k m)) = 0.05, f_n = sqrt(k/m)/2π, f_d = f_n sqrt(1 − ζ²)."""
    _, _, _, modes = linear
    k = np.argmin(np.abs(modes.frequencies - W_OSC / (2 * np.pi)))
    assert modes.frequencies[k] == pytest.approx(W_OSC / (2 * np.pi), rel=1e-8)
    assert modes.damping_ratios[k] == pytest.approx(OSC_ZETA, rel=1e-8)
    assert modes.damped_frequencies[k] == pytest.approx(W_OSC * np.sqrt(1 - OSC_ZETA**2) / (2 * np.pi), rel=1e-8)


def test_equilibrium_is_the_modelled_pose(linear):
    """Every subsystem is modelled at rest in equilibrium (bob hanging, springs unstretched)."""
    system, eq, _, _ = linear
    np.testing.assert_allclose(eq.q, np.asarray(system.params["q_init"]), atol=1e-12)
