"""P2 tetrahedra and lumped models against closed forms (issue 17 FE tests).

- cantilever and free-free square beams (L/h = 20): first bending frequency within 1 % of
  Euler-Bernoulli. Shear and rotary inertia lower the solid's frequency by ~0.3 % at L/h = 20
  (Timoshenko), the clamp's suppressed Poisson contraction raises it slightly: 1 % covers both;
- a thick-walled tube in torsion: twist within 2 % of T L / (G J) (no warping for a circular
  section, so the clamped end is exact and the error is discretisation only);
- a spring-mass chain on a soft support: the closed-form frequencies of a fixed-free chain;
- a lumped mass at the tip of a beam: the exact transcendental frequency and the Rayleigh-Ritz
  (static-deflection shape) upper bound.
"""

import math

import numpy as np
import pytest
from scipy.optimize import brentq

from proleg.fem import BeamModel, LumpedModel, Section, SolidModel, material
from proleg.fem.mesh import axial_rotation, mesh_occ, rotation_field, torque_load

AL = material("al7075-t6")
L, H = 0.24, 0.012  # square beam, L/h = 20
I_SQ = H**4 / 12


def _omega_eb(beta_l):
    return beta_l**2 / L**2 * math.sqrt(AL.E * I_SQ / (AL.rho * H * H))


@pytest.fixture(scope="module")
def beam():
    return SolidModel.box((L, H, H), 0.006, AL, order=2)


def test_cantilever_first_frequency_within_1_percent(beam):
    fixed = beam.node_dofs(beam.nodes_where(lambda x, y, z: np.isclose(x, 0.0)))
    w, _ = beam.modes(2, fixed)
    ref = _omega_eb(1.8751040687)
    assert w[0] == pytest.approx(ref, rel=0.01)
    assert w[1] == pytest.approx(ref, rel=0.01)  # square section: the pair in y and z


def test_free_free_first_frequency_within_1_percent(beam):
    w, _ = beam.modes(8)
    assert np.all(np.abs(w[:6]) < 1e-3 * w[6])  # six rigid-body modes
    ref = _omega_eb(4.7300407449)
    assert w[6] == pytest.approx(ref, rel=0.01)
    assert w[7] == pytest.approx(ref, rel=0.01)


def test_thick_tube_torsion_within_2_percent():
    ro, ri, length, T = 0.02, 0.01, 0.06, 140.0

    def build(occ):
        a = occ.addCylinder(0, 0, 0, 0, 0, length, ro)
        b = occ.addCylinder(0, 0, 0, 0, 0, length, ri)
        occ.cut([(3, a)], [(3, b)])

    tube = SolidModel(*mesh_occ(build, 0.005), AL, order=2)
    fixed = tube.node_dofs(tube.nodes_where(lambda x, y, z: np.isclose(z, 0.0)))
    f = torque_load(tube, lambda x, y, z: np.isclose(z, length), T)
    assert rotation_field(tube) @ f == pytest.approx(T, rel=1e-12)
    u = tube.static(f, fixed)
    end = tube.nodes_where(lambda x, y, z: np.isclose(z, length))
    J = math.pi / 2 * (ro**4 - ri**4)
    assert axial_rotation(tube, u, end) == pytest.approx(T * length / (AL.G * J), rel=0.02)
    # equilibrium: the clamp reactions (K u - f, forces on the tube) balance the applied torque
    reaction = tube.K @ u - f
    assert rotation_field(tube) @ reaction == pytest.approx(-T, rel=1e-6)


def test_spring_mass_chain_on_soft_support():
    """n equal masses m in a chain of equal springs k, the first on the (soft) ground spring:
    omega_j = 2 sqrt(k/m) sin((2j - 1) pi / (2 (2n + 1))), j = 1..n (fixed-free chain)."""
    n, m, k = 4, 3.0, 2.0e4
    model = LumpedModel()
    kr = 50.0  # rotational springs with small inertias: rotation modes far above the band
    for i in range(n):  # all centres at one point: no lever arm couples translation and rotation
        model.add_body(f"m{i}", m, (0.0, 0.0, 0.0), inertia=(1e-6, 1e-6, 1e-6))
    model.add_spring("m0", "ground", (k, k, k, kr, kr, kr), name="support")
    for i in range(1, n):
        model.add_spring(f"m{i}", f"m{i - 1}", (k, k, k, kr, kr, kr), name=f"s{i}")
    w, phi = model.modes(3 * n)
    ref = 2 * np.sqrt(k / m) * np.sin((2 * np.arange(1, n + 1) - 1) * np.pi / (2 * (2 * n + 1)))
    assert np.allclose(w, np.repeat(ref, 3), rtol=1e-9)  # x, y, z alike
    assert np.allclose(phi.T @ model.M @ phi, np.eye(3 * n), atol=1e-9)


def test_lumped_mass_on_beam_against_rayleigh_ritz():
    """Cantilever with a tip mass Mt: exact 1 + cos cosh + (Mt/m) bL (cos sinh - sin cosh) = 0;
    Rayleigh-Ritz with the static tip-load shape: omega^2 = 3 E I / (L^3 (Mt + 33/140 m)), an
    upper bound within ~1 % for Mt >= m."""
    sec = Section.rectangle(0.03, 0.01)
    length, mt = 0.5, 1.2
    beam = BeamModel.polyline([[0, 0, 0], [length, 0, 0]], 20, sec, AL)
    model = LumpedModel(beam.K, beam.M, beam.node_coordinates, beam.node_dof_table)
    tip = beam.node_at([length, 0, 0])
    model.add_body("tip", mt, (length, 0, 0), inertia=(1e-6, 1e-6, 1e-6))  # a near-point mass
    # stiff attachment: 1e10 N/m, 1e7 N m/rad (stiffer makes the eigenproblem ill-conditioned)
    model.add_spring("tip", tip, (1e10, 1e10, 1e10, 1e7, 1e7, 1e7), name="rigid link")
    w, _ = model.modes(1, beam.node_dofs([0]))
    m = AL.rho * sec.A * length
    EI = AL.E * sec.Iy  # bending about the thin direction (x-z plane) is the lowest
    r = mt / m

    def char(bl):
        return 1 + np.cos(bl) * np.cosh(bl) + r * bl * (np.cos(bl) * np.sinh(bl) - np.sin(bl) * np.cosh(bl))

    bl = brentq(char, 0.3, 1.875)
    exact = bl**2 / length**2 * math.sqrt(EI / (AL.rho * sec.A))
    rayleigh = math.sqrt(3 * EI / (length**3 * (mt + 33 / 140 * m)))
    assert w[0] == pytest.approx(exact, rel=1e-3)
    assert exact <= rayleigh <= 1.01 * exact
    assert w[0] == pytest.approx(rayleigh, rel=0.01)
