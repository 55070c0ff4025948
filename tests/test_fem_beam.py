"""Beam elements against closed forms: cantilever frequencies, tip deflections, frames."""

import importlib

import numpy as np
import pytest

from proleg.errors import ModelError
from proleg.fem import BeamModel, Section, cantilever_omega, material, solve_modes

STEEL = material("structural_steel")
cb_module = importlib.import_module("proleg.fem.craig_bampton")


def _cantilever_refs(L, E, I, lam, n=3):
    # omega_n = (beta_n L)^2 / L^2 sqrt(E I / lambda), beta L = 1.8751, 4.6941, 7.8548
    return np.array([cantilever_omega(k, L, E, I, lam) for k in range(1, n + 1)])


@pytest.mark.parametrize("theory", ["euler-bernoulli", "timoshenko"])
def test_planar_cantilever_frequencies(theory):
    # slender rod, L / D = 100: shear and rotary inertia change omega_1..3 by < 0.1 %
    sec = Section.tube(0.01)
    L = 1.0
    beam = BeamModel.polyline([[0, 0], [L, 0]], 30, sec, STEEL, theory=theory)
    w, _ = beam.modes(3, clamp=[0])  # the first axial mode is far above the third bending mode
    ref = _cantilever_refs(L, STEEL.E, sec.Iz, STEEL.rho * sec.A)
    assert np.allclose(w, ref, rtol=5e-3)


@pytest.mark.parametrize("theory", ["euler-bernoulli", "timoshenko"])
def test_strip_bends_about_thin_direction_3d(theory):
    # 300 x 50 x 3 mm strip along x: out-of-plane (z) bending uses Iy = W t^3 / 12
    L, W, t = 0.3, 0.05, 0.003
    sec = Section.rectangle(W, t)
    beam = BeamModel.polyline([[0, 0, 0], [L, 0, 0]], 40, sec, "aisi304", theory=theory)
    w, phi = beam.modes(8, clamp=[0])
    tab = beam.node_dof_table
    ux, uy, uz, rx = (np.abs(phi[tab[:, c]]).max(axis=0) for c in (0, 1, 2, 3))
    is_z_bending = (uz > 10 * np.maximum(ux, uy)) & (uz > 10 * rx * 0.025)  # not torsion (half-width 25 mm)
    m = beam.material
    ref = _cantilever_refs(L, m.E, sec.Iy, m.rho * sec.A)
    assert np.allclose(w[is_z_bending][:3], ref, rtol=5e-3)


def test_modes_are_mass_normalised_and_mass_is_consistent():
    sec = Section.rectangle(0.05, 0.003)
    beam = BeamModel.polyline([[0, 0, 0], [0.3, 0, 0]], 20, sec, "aisi304")
    _, phi = beam.modes(5, clamp=[0])
    assert np.allclose(phi.T @ beam.M @ phi, np.eye(5), atol=1e-10)
    e = np.zeros(beam.ndof)
    e[beam.node_dof_table[:, 1]] = 1.0  # rigid y translation
    assert e @ beam.M @ e == pytest.approx(beam.mass, rel=1e-12)
    assert beam.mass == pytest.approx(7800 * 0.3 * 0.05 * 0.003, rel=1e-12)


def test_sparse_shift_invert_matches_dense(monkeypatch):
    sec = Section.tube(0.02, 0.016)
    beam = BeamModel.polyline([[0, 0, 0], [1.0, 0.2, 0.1]], 120, sec, STEEL, theory="timoshenko")
    assert beam.ndof > cb_module.DENSE_LIMIT
    w_sparse, _ = beam.modes(6, clamp=[0])
    monkeypatch.setattr(cb_module, "DENSE_LIMIT", 10**6)
    w_dense, _ = solve_modes(beam.K, beam.M, 6, beam.node_dofs([0]))
    assert np.allclose(w_sparse, w_dense, rtol=1e-7)  # degenerate pairs: ~1e-8 from ARPACK


@pytest.mark.parametrize("n_el", [1, 7])
def test_euler_bernoulli_tip_deflection(n_el):
    # delta = P L^3 / (3 E I): cubic Hermite elements are exact at the nodes
    sec = Section.rectangle(0.05, 0.003)
    L, P = 0.3, 2.0
    beam = BeamModel.polyline([[0, 0, 0], [L, 0, 0]], n_el, sec, "aisi304")
    u = beam.static({(n_el, "uz"): -P}, clamp=[0])
    assert u[-1, 2] == pytest.approx(-P * L**3 / (3 * beam.material.E * sec.Iy), rel=1e-10)
    # slope at the tip, P L^2 / (2 E I), is theta_y = -dw/dx
    assert u[-1, 4] == pytest.approx(P * L**2 / (2 * beam.material.E * sec.Iy), rel=1e-10)


def test_timoshenko_adds_shear_deflection_exactly():
    # stubby beam: delta = P L^3 / (3 E I) + P L / (kappa G A), exact with one element
    sec = Section.rectangle(0.04, 0.04)
    L, P = 0.2, 1000.0
    for n_el in (1, 5):
        beam = BeamModel.polyline([[0, 0], [L, 0]], n_el, sec, STEEL, theory="timoshenko")
        u = beam.static({(n_el, "uy"): P}, clamp=[0])
        exact = P * L**3 / (3 * STEEL.E * sec.Iz) + P * L / (sec.shear_factor * STEEL.G * sec.A)
        assert u[-1, 1] == pytest.approx(exact, rel=1e-10)
    eb = BeamModel.polyline([[0, 0], [L, 0]], 5, sec, STEEL).static({(5, "uy"): P}, clamp=[0])
    assert eb[-1, 1] < u[-1, 1]


def test_l_frame_bending_plus_torsion():
    # L-shaped frame in the x-y plane, clamped at the origin, load P along z at the free end:
    # delta = P a^3 / (3 E I) + P b^3 / (3 E I) + P a b^2 / (G J)
    sec = Section.tube(0.03, 0.026)
    a, b, P = 0.5, 0.3, 100.0
    beam = BeamModel.polyline([[0, 0, 0], [a, 0, 0], [a, b, 0]], [5, 3], sec, STEEL)
    tip = beam.node_at([a, b, 0])
    u = beam.static({(tip, "uz"): P}, clamp=[beam.node_at([0, 0, 0])])
    E, G = STEEL.E, STEEL.G
    exact = P * a**3 / (3 * E * sec.Iy) + P * b**3 / (3 * E * sec.Iy) + P * a * b**2 / (G * sec.J)
    assert u[tip, 2] == pytest.approx(exact, rel=1e-10)


def test_tube_section_constants():
    # FLEGX upper leg tube OD 75 / ID 71 mm (seed 002): A = pi (D^2 - d^2) / 4, J = 2 I
    s = Section.tube(0.075, 0.071)
    assert s.A == pytest.approx(np.pi * (0.075**2 - 0.071**2) / 4)
    assert s.J == pytest.approx(2 * s.Iy) and s.Iy == pytest.approx(np.pi * (0.075**4 - 0.071**4) / 64)
    assert 0.5 < s.shear_factor < 0.55  # thin-walled tube -> ~0.53 (Cowper)


def test_bad_input_errors():
    sec = Section.rectangle(0.05, 0.003)
    with pytest.raises(ModelError, match="width"):
        Section.rectangle(-0.05, 0.003)
    with pytest.raises(ModelError, match="inner_diameter"):
        Section.tube(0.02, 0.03)
    with pytest.raises(ModelError, match="theory"):
        BeamModel.polyline([[0, 0], [1, 0]], 2, sec, STEEL, theory="bernoulli")
    with pytest.raises(ModelError, match="zero length"):
        BeamModel([[0, 0], [0, 0]], [[0, 1]], sec, STEEL)
    beam = BeamModel.polyline([[0, 0], [1, 0]], 2, sec, STEEL)
    with pytest.raises(ModelError, match="No beam node"):
        beam.node_at([0.3, 0.0])
    with pytest.raises(ModelError, match="modes"):
        beam.modes(7, clamp=[0])  # 2 free nodes x 3 DOFs = 6
    with pytest.raises(ModelError, match="singular"):
        beam.static({(2, "uy"): 1.0})  # nothing clamped
    with pytest.raises(ModelError, match="Unknown material 'unobtainium'.*aisi304"):
        material("unobtainium")
