"""Craig-Bampton reduction: frequency convergence, exact statics at the interface, invariants, file."""

import numpy as np
import pytest

from proleg.errors import ModelError
from proleg.fem import BeamModel, ReducedBody, Section, SolidModel, craig_bampton, solve_static

L, W, T = 0.3, 0.05, 0.003


@pytest.fixture(scope="module")
def strip_beam():
    return BeamModel.polyline([[0, 0, 0], [L, 0, 0]], 40, Section.rectangle(W, T), "aisi304")


def _dense(K):
    return K.toarray() if hasattr(K, "toarray") else np.asarray(K)


def _reduce(beam, n_modes, **kw):
    root, tip = beam.node_at([0, 0, 0]), beam.node_at([L, 0, 0])
    B = np.r_[beam.node_dofs(root), beam.node_dofs(tip)]
    body = craig_bampton(beam.K, beam.M, B, n_modes, node_coordinates=beam.node_coordinates,
                         node_dofs=beam.node_dof_table, **kw)
    return body, root, tip, B


def test_reduced_frequencies_match_full_model(strip_beam):
    body, root, _, _ = _reduce(strip_beam, 30)
    w_full, _ = strip_beam.modes(5, clamp=[root])
    w_red = body.omega(fixed=np.arange(6))  # q_C of the root node are its physical DOFs
    assert np.allclose(w_red[:5], w_full, rtol=1e-3)
    # fewer modes: still an upper bound (Rayleigh-Ritz), and worse
    coarse, *_ = _reduce(strip_beam, 4)
    w_coarse = coarse.omega(fixed=np.arange(6))[:5]
    assert np.all(w_coarse >= w_full * (1 - 1e-12))
    assert np.max(w_coarse / w_full - 1) > np.max(w_red[:5] / w_full - 1)


def test_static_boundary_load_is_exact(strip_beam):
    body, root, tip, B = _reduce(strip_beam, 3)
    f = np.zeros(strip_beam.ndof)
    f[strip_beam.dof(tip, "uz")] = -5.0
    f[strip_beam.dof(tip, "uy")] = 2.0
    f[strip_beam.dof(tip, "rx")] = 0.3
    u_full = solve_static(strip_beam.K, f, strip_beam.node_dofs(root))
    q = solve_static(body.K, body.basis.T @ f, np.arange(6))
    u_red = body.basis @ q
    # Exact in exact arithmetic; in floating point both solves carry a normwise forward error up
    # to ~ eps × cond, with cond that of the diagonally scaled restrained stiffness (Cholesky/LU
    # errors are invariant to that scaling, van der Sluis; the raw cond ~1.6e11 mixes m and rad).
    # Here eps × cond ~ 3e-9; measured 1e-11 (Intel, OpenBLAS SkylakeX kernels) to 6e-11
    # (OPENBLAS_CORETYPE=Zen, as on AMD), so a different summation order passes, while a wrong
    # reduction (a missing constraint mode) is off by O(1).
    free = np.setdiff1d(np.arange(strip_beam.ndof), strip_beam.node_dofs(root))
    Kff = _dense(strip_beam.K)[np.ix_(free, free)]
    s = 1.0 / np.sqrt(np.diag(Kff))
    tol = np.finfo(float).eps * np.linalg.cond(Kff * s[:, None] * s[None, :])
    assert 1e-10 < tol < 1e-7  # the bound is meaningful: well below any modelling error
    assert np.linalg.norm(u_red[B] - u_full[B]) <= tol * np.linalg.norm(u_full[B])
    # interior too: constraint modes are the exact static shapes under boundary loads
    assert np.linalg.norm(u_red - u_full) <= tol * np.linalg.norm(u_full)


def test_block_structure_and_orthonormalisation(strip_beam):
    body, *_ = _reduce(strip_beam, 6)
    nb = 12
    assert np.allclose(body.K[:nb, nb:], 0.0, atol=1e-8 * np.abs(body.K).max())  # Eq. 14
    assert np.allclose(body.M[nb:, nb:], np.eye(6), atol=1e-10)  # mass-normalised normal modes
    assert np.allclose(np.diag(body.K[nb:, nb:]), body.fixed_interface_omega**2, rtol=1e-8)
    ortho, *_ = _reduce(strip_beam, 6, orthonormalize=True)
    assert np.allclose(ortho.M, np.eye(ortho.nq), atol=1e-9)
    f_ortho = np.sort(np.sqrt(np.abs(np.diag(ortho.K)))) / (2 * np.pi)
    # six free-free rigid-body modes (numerically ~0: below 0.05 Hz), then identical flexible ones
    assert np.all(body.frequencies_hz[:6] < 0.05) and np.all(f_ortho[:6] < 0.05)
    assert body.frequencies_hz[6] > 100.0
    assert np.allclose(f_ortho[6:], body.frequencies_hz[6:], rtol=1e-8)


def test_inertia_invariants_of_the_strip(strip_beam):
    body, *_ = _reduce(strip_beam, 6, orthonormalize=True)
    inv = body.invariants
    m = 7800 * L * W * T
    sec = strip_beam.section
    assert inv["I1"] == pytest.approx(m, rel=1e-12)
    assert np.allclose(inv["I2"], [m * L / 2, 0, 0], atol=1e-12 * m)
    # about the root: torsion rho I_p L, transverse m L^2 / 3 (Euler-Bernoulli mass: no rotary inertia)
    assert np.allclose(inv["I7"], np.diag([7800 * sec.Ip * L, m * L**2 / 3, m * L**2 / 3]), rtol=1e-10,
                       atol=1e-12 * m * L**2)
    # effective-mass sum rule: the orthonormal basis spans rigid translations, so sum_j S_dj^2 = m
    assert np.allclose(np.sum(inv["I3"] ** 2, axis=1), m, rtol=1e-9)
    assert inv["I6"] == pytest.approx(np.eye(body.nq), abs=1e-9)
    assert inv["I5"].shape == (body.nq, 3, 3) and inv["I9"].shape == (body.nq, body.nq, 3, 3)
    assert np.allclose(inv["I8"], -inv["I5"])  # skew(s)^T = -skew(s)


def test_save_load_roundtrip(strip_beam, tmp_path):
    body, *_ = _reduce(strip_beam, 5)
    path = tmp_path / "strip.npz"
    body.save(path)
    back = ReducedBody.load(path)
    # bitwise: arrays written to .npz and read back, no arithmetic
    assert np.array_equal(back.K, body.K) and np.array_equal(back.modes, body.modes)
    assert np.array_equal(back.node_dofs, body.node_dofs) and back.n_modes == 5
    assert set(back.invariants) == {f"I{i}" for i in range(1, 10)}
    assert np.array_equal(back.invariants["I7"], body.invariants["I7"])
    assert back.units == "SI: m, kg, s, N, rad"
    node = body.interface_nodes[0]
    assert np.allclose(back.expand(np.eye(back.nq)[0])[node], body.modes[node, :, 0])
    with pytest.raises(ModelError, match="Cannot read"):
        ReducedBody.load(tmp_path / "missing.npz")


def test_solid_reduction_matches_full():
    solid = SolidModel.box((0.1, 0.02, 0.01), 0.01, "al7075-t6", order=2)
    root = solid.nodes_where(lambda x, y, z: np.isclose(x, 0.0))
    tipc = solid.node_at([0.1, 0.0, 0.0])
    B = np.r_[solid.node_dofs(root), solid.node_dofs(tipc)]
    body = craig_bampton(solid.K, solid.M, B, 20, node_coordinates=solid.node_coordinates,
                         node_dofs=solid.node_dof_table)
    w_full, _ = solid.modes(5, solid.node_dofs(root))
    w_red = body.omega(fixed=np.arange(root.size * 3))
    assert np.allclose(w_red[:5], w_full, rtol=1e-3)
    assert body.invariants["I1"] == pytest.approx(2810 * 0.1 * 0.02 * 0.01, rel=1e-12)
    a, b, c = 0.1, 0.02, 0.01
    m = 2810 * a * b * c
    # box inertia about its corner (P2 consistent mass integrates x^2 exactly)
    I7 = m * np.array([[(b**2 + c**2) / 3, -a * b / 4, -a * c / 4],
                       [-a * b / 4, (a**2 + c**2) / 3, -b * c / 4],
                       [-a * c / 4, -b * c / 4, (a**2 + b**2) / 3]])
    assert np.allclose(body.invariants["I7"], I7, rtol=1e-10)


def test_bad_input_errors(strip_beam):
    K, M = strip_beam.K, strip_beam.M
    with pytest.raises(ModelError, match="boundary DOFs must be distinct"):
        craig_bampton(K, M, [0, 0, 1], 2)
    with pytest.raises(ModelError, match="interior DOFs"):
        craig_bampton(K, M, strip_beam.node_dofs([0]), strip_beam.ndof)
    with pytest.raises(ModelError, match="singular"):
        craig_bampton(K, M, [strip_beam.dof(0, "ux")], 2)
