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


def test_vertex_stress_is_exact_for_a_quadratic_field():
    """P2 represents u = (x^2, x y, 0) exactly; the recovered vertex stress equals the closed form
    sigma = lam tr(eps) I + 2 mu eps with eps_xx = 2x, eps_yy = x, eps_xy = y / 2 at every vertex
    (averaging values that agree leaves them unchanged). A recovery that mixed up element corners
    or averaged quadrature values would fail."""
    from proleg.fem import SolidModel, material

    m = SolidModel.box((0.02, 0.01, 0.01), 0.006, material("steel"))
    X = m.node_coordinates
    u = np.zeros(m.ndof)
    u[m.node_dof_table[:, 0]] = X[:, 0] ** 2
    u[m.node_dof_table[:, 1]] = X[:, 0] * X[:, 1]
    sig, vm = m.vertex_stress(u)
    x, y = m.points[:, 0], m.points[:, 1]
    lam, mu = m.material.lame
    assert np.allclose(sig[:, 0, 0], lam * 3 * x + 4 * mu * x, rtol=1e-9, atol=1e-3)
    assert np.allclose(sig[:, 1, 1], lam * 3 * x + 2 * mu * x, rtol=1e-9, atol=1e-3)
    assert np.allclose(sig[:, 0, 1], mu * y, rtol=1e-9, atol=1e-3)
    assert np.all(vm >= 0)


def test_swept_mesh_is_conforming_and_passes_the_patch_test():
    """A plate swept from its face (mesh_extruded, 3 layers) under a uniform end displacement:
    a conforming mesh reproduces the linear field, so the reaction is exactly E A delta / L
    (Poisson free); mismatched prism diagonals would leave gaps and break this."""
    from proleg.fem import SolidModel, material
    from proleg.fem.mesh import mesh_extruded

    L, W, T = 0.03, 0.01, 0.004

    def build(occ):
        occ.addBox(0, 0, 0, L, W, T)

    pts, tets = mesh_extruded(build, 0.004, T, layers=3)
    assert np.isclose(pts[:, 2].max(), T) and np.unique(pts[:, 2]).size == 4
    m = SolidModel(pts, tets, material("al7075-t6"), order=2)
    assert m.mass == pytest.approx(m.material.rho * L * W * T, rel=1e-12)
    x = m.node_coordinates
    left = m.nodes_where(lambda x, y, z: x < 1e-9)
    right = m.nodes_where(lambda x, y, z: x > L - 1e-9)
    d = 1e-6
    # exact linear field of uniaxial stress: u = d x / L, v = -nu d y / L, w = -nu d z / L
    nu = m.material.nu
    exact = np.zeros(m.ndof)
    exact[m.node_dof_table[:, 0]] = d * x[:, 0] / L
    exact[m.node_dof_table[:, 1]] = -nu * d * x[:, 1] / L
    exact[m.node_dof_table[:, 2]] = -nu * d * x[:, 2] / L
    r = m.K @ exact  # interior residual vanishes for a conforming mesh
    interior = np.setdiff1d(np.arange(m.ndof), np.r_[m.node_dofs(left), m.node_dofs(right)])
    assert np.abs(r[interior]).max() < 1e-9 * np.abs(r).max()
    assert r[m.node_dof_table[right, 0]].sum() == pytest.approx(m.material.E * W * T * d / L, rel=1e-9)
