"""Tetrahedral solid model of the FLEGX 300 x 50 x 3 mm strip against beam closed forms.

A solid strip clamped over its whole root section is slightly stiffer than a beam: the clamp
suppresses the Poisson (anticlastic) contraction near the root, so the response lies between
the beam (E) and the plate (E / (1 - nu^2)) values. The tests assert both the bracket and the
2 % tolerance of the brief.
"""

import numpy as np
import pytest

from proleg.errors import ModelError
from proleg.fem import SolidModel, cantilever_omega, material, mesh_box

L, W, T = 0.3, 0.05, 0.003
MAT = material("aisi304")
I_THIN = W * T**3 / 12


@pytest.fixture(scope="module")
def strip():
    # 10 mm quadratic tets, one element through the thickness: ~7.3k DOFs, ~3 s
    return SolidModel.box((L, W, T), 0.01, MAT, order=2)


@pytest.fixture(scope="module")
def clamped(strip):
    return strip.node_dofs(strip.nodes_where(lambda x, y, z: np.isclose(x, 0.0)))


def test_mesh_mass_is_exact(strip):
    assert strip.mass == pytest.approx(MAT.rho * L * W * T, rel=1e-12)


def test_bending_frequencies_within_2_percent(strip, clamped):
    w, phi = strip.modes(6, clamped)
    assert np.allclose(phi.T @ strip.M @ phi, np.eye(6), atol=1e-9)
    # classify modes by the tip corners: bending moves both corners alike along z
    c0 = strip.node_at([L, 0, 0])
    c1 = strip.node_at([L, W, 0])
    tab = strip.node_dof_table
    uz0, uz1 = phi[tab[c0, 2]], phi[tab[c1, 2]]
    uy0 = phi[tab[c0, 1]]
    bending = (uz0 * uz1 > 0) & (np.abs(uz0 - uz1) < 0.05 * np.abs(uz0)) & (np.abs(uy0) < 0.1 * np.abs(uz0))
    ref = np.array([cantilever_omega(n, L, MAT.E, I_THIN, MAT.rho * W * T) for n in (1, 2, 3)])
    got = w[bending][:3]
    assert got.shape == (3,)
    assert np.allclose(got, ref, rtol=0.02)
    # beam <= solid <= plate (E / (1 - nu^2)) bound
    assert np.all(got >= ref) and np.all(got <= ref / np.sqrt(1 - MAT.nu**2))


def test_static_tip_deflection_and_stress(strip, clamped):
    P = 10.0
    f = strip.surface_load(lambda x, y, z: np.isclose(x, L), (0.0, 0.0, -P))
    assert f[strip.node_dof_table[:, 2]].sum() == pytest.approx(-P, rel=1e-12)
    u = strip.static(f, clamped)
    tip = -strip.displacement_at(u, [[L, W / 2, T / 2]])[0, 2]
    beam = P * L**3 / (3 * MAT.E * I_THIN)
    assert beam * (1 - MAT.nu**2) < tip < beam
    assert tip == pytest.approx(beam, rel=0.025)
    # mid-span bending stress sigma = M c / I on the top surface, von Mises = |sigma_xx| there
    r = strip.stress_at(u, [[L / 2, W / 2, T], [L / 2, W / 2, 0.0]])
    sigma = P * (L / 2) * (T / 2) / I_THIN
    assert r.von_mises == pytest.approx([sigma, sigma], rel=0.015)
    assert r.stress[0, 0, 0] > 0 > r.stress[1, 0, 0]  # tension on top for a downward tip load


def test_linear_tets_lock_in_bending():
    coarse = SolidModel.box((L, W, T), 0.02, MAT, order=1)
    fixed = coarse.node_dofs(coarse.nodes_where(lambda x, y, z: np.isclose(x, 0.0)))
    w, _ = coarse.modes(1, fixed)
    ref = cantilever_omega(1, L, MAT.E, I_THIN, MAT.rho * W * T)
    assert w[0] > 1.5 * ref  # one linear tet through the thickness is far too stiff


def test_bad_input_errors(strip):
    with pytest.raises(ModelError, match="positive"):
        mesh_box((0.3, -0.05, 0.003), 0.01)
    with pytest.raises(ModelError, match="element size"):
        mesh_box((0.3, 0.05, 0.003), 0.0)
    pts = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 1.0]])
    tets = np.array([[0, 1, 2, 3], [1, 2, 3, 4]])  # both positively oriented
    SolidModel(pts, tets, MAT, order=1)
    inverted = tets.copy()
    inverted[1] = inverted[1][[0, 2, 1, 3]]
    with pytest.raises(ModelError, match="inverted.*negative Jacobian.*\\[1\\]"):
        SolidModel(pts, inverted, MAT)
    with pytest.raises(ModelError, match="not on the mesh"):
        strip.node_at([L / 3 + 1e-4, 1e-4, 1e-3])
    single = SolidModel(pts[:4], tets[:1], MAT, order=1)
    with pytest.raises(ModelError, match="12 free DOFs"):
        single.modes(13)
    with pytest.raises(ModelError, match="order"):
        SolidModel(pts, tets, MAT, order=3)
