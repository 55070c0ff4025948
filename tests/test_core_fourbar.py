"""Planar four-bar (crank-rocker) from four Revolute joints in 3D, all axes along ground y.

Geometry of examples/four_bar.yaml, in the x-z plane: ground pivots A = (0, 0) and D = (0.4, 0),
crank AB = a = 0.10, coupler BC = b = 0.35, rocker DC = c = 0.30 (m); assembled with the crank
vertical and C the upper intersection of |C − B| = b, |C − D| = c.

Closed form (position analysis by circle intersection): for a crank angle φ (from +x towards +z),
B = A + a (cos φ, sin φ); with e = |D − B| and u = (D − B)/e, the foot of C on BD is
B + ℓ u with ℓ = (b² − c² + e²) / (2e) and C = B + ℓ u + h n, h = sqrt(b² − ℓ²), n ⟂ u on the
assembled (upper) branch. The rocker angle is ψ = atan2(C_z − D_z, C_x − D_x).

20 joint equations on 18 coordinates with mobility 1: three rows are redundant (formulation
note §6) and assembly removes them with a warning.
"""

import numpy as np
import pytest

import proleg as pl

A_PT = np.array([0.0, 0.0, 0.0])
D_PT = np.array([0.4, 0.0, 0.0])
LA, LB, LC = 0.10, 0.35, 0.30  # crank, coupler, rocker [m]


def circle_point(B, D, sign=1.0):
    """C with |C − B| = LB and |C − D| = LC in the x-z plane; sign picks the branch."""
    bx, bz = B[0], B[2]
    dx, dz = D[0] - bx, D[2] - bz
    e = np.hypot(dx, dz)
    ux, uz = dx / e, dz / e
    ell = (LB**2 - LC**2 + e**2) / (2 * e)
    h = np.sqrt(LB**2 - ell**2)
    nx, nz = -uz, ux  # u turned +90° in the (x, z) plane
    return np.array([bx + ell * ux + sign * h * nx, 0.0, bz + ell * uz + sign * h * nz])


def rocker_angle(phi):
    """ψ(φ) from the closed-form position analysis (upper branch, the assembled one)."""
    B = A_PT + LA * np.array([np.cos(phi), 0.0, np.sin(phi)])
    C = circle_point(B, D_PT, sign=1.0)
    return np.arctan2(C[2] - D_PT[2], C[0] - D_PT[0])


def rod_part(model, name, p, q, mass, **kw):
    """A slender rod from p to q: COM at the midpoint, part x axis along the rod (a rotation about y)."""
    L = np.linalg.norm(q - p)
    x = (q - p) / L
    y = np.array([0.0, 1.0, 0.0])
    R = np.column_stack([x, y, np.cross(x, y)])
    r = 0.005
    inertia = (mass * r**2 / 2, mass * L**2 / 12, mass * L**2 / 12)
    return model.add_part(name, mass=mass, inertia=inertia, position=(p + q) / 2, orientation=R, **kw)


B0 = A_PT + np.array([0.0, 0.0, LA])
C0 = circle_point(B0, D_PT, sign=1.0)


def build():
    model = pl.Model("four_bar", gravity=(0, 0, 0))
    # Drive: an initial angular velocity of the crank about −y (B starts towards −x). The other
    # parts are given at rest; the initial-conditions solve projects the velocities onto the
    # constraints (M-weighted), which leaves the crank about 8 % of this speed (≈ 6.5 rad/s).
    w = np.array([0.0, -80.0, 0.0])
    crank = rod_part(model, "crank", A_PT, B0, 0.10, angular_velocity=w, velocity=np.cross(w, (B0 - A_PT) / 2))
    coupler = rod_part(model, "coupler", B0, C0, 0.35)
    rocker = rod_part(model, "rocker", D_PT, C0, 0.30)
    y = (0, 1, 0)
    model.add_joint(pl.Revolute("A", model.ground, crank, at=A_PT, axis=y))
    model.add_joint(pl.Revolute("B", crank, coupler, at=B0, axis=y))
    model.add_joint(pl.Revolute("C", coupler, rocker, at=C0, axis=y))
    model.add_joint(pl.Revolute("D", rocker, model.ground, at=D_PT, axis=y))
    return model


@pytest.fixture(scope="module")
def system():
    with pytest.warns(UserWarning, match="redundant"):
        return pl.assemble(build())


def test_assembled_geometry_closes():
    # Round-off of the circle intersection (hypot, sqrt, a mild cancellation in b² − ℓ²; another
    # libm may round each 1 ulp apart): 64 eps × 0.4 m, the ground link, = 5.7e-15 m; an error in
    # the construction is ≥ 1e-6 m. Angles: 64 eps × π rad.
    tol_m, tol_rad = 64 * np.finfo(float).eps * 0.4, 64 * np.finfo(float).eps * np.pi
    assert C0 == pytest.approx([0.2987218950531729, 0.0, 0.2823875802126918], abs=tol_m)
    assert np.linalg.norm(C0 - B0) == pytest.approx(LB, abs=tol_m)
    assert np.linalg.norm(C0 - D_PT) == pytest.approx(LC, abs=tol_m)
    assert rocker_angle(np.pi / 2) == pytest.approx(np.arctan2(C0[2], C0[0] - D_PT[0]), abs=tol_rad)


def test_redundant_rows_dropped(system):
    """Three equations removed, the mechanism keeps one DOF (7·3 − rank Φ_q = 1)."""
    assert len(system.topo.dropped) == 3
    assert all(joint in {"A", "B", "C", "D"} for joint, _ in system.topo.dropped)
    report = pl.assembly.system.dof_report(system)
    assert report["rank"] == 1
    assert report["gruebler"] == -2


@pytest.mark.parametrize("method", ["auto", "GeneralizedAlpha"])
def test_rocker_follows_closed_form(system, method):
    """ψ_sim (from the rocker COM, the midpoint of DC) equals ψ(φ_sim) from the crank COM's angle,
    at every output within 1e-6 rad, over more than one full crank turn; with no integrator named
    (Radau5 on joint coordinates, solvers/auto.py) and with the α-method."""
    ig = pl.GeneralizedAlpha() if method == "GeneralizedAlpha" else "auto"
    res = pl.simulate(system, t_end=1.5, dt_output=0.005, integrator=ig)
    crank = res.part("crank").position
    rocker = res.part("rocker").position
    phi = np.unwrap(np.arctan2(crank[:, 2] - A_PT[2], crank[:, 0] - A_PT[0]))
    psi = np.arctan2(rocker[:, 2] - D_PT[2], rocker[:, 0] - D_PT[0])
    assert abs(phi[-1] - phi[0]) > 2 * np.pi  # the crank really turns
    psi_exact = np.array([rocker_angle(p) for p in phi])
    assert np.max(np.abs(psi - psi_exact)) < 1e-6
    # The loop closes to the integrator's constraint tolerance, not to round-off: step ends within
    # 5 phi_tol (1e-10), outputs between steps projected to first order. Measured 7.9e-10 (Intel,
    # AVX-512) and 1.13e-9 with XLA, NumPy and OpenBLAS limited to AVX2 (as on AMD Zen 2/3),
    # so 50 phi_tol = 5e-9; a loop that drifts open is off by ≥ 1e-6.
    from proleg.solvers.galpha import StepOptions

    if method == "GeneralizedAlpha":
        assert np.max(res.constraint_residual()) < 50 * StepOptions().phi_tol
    else:
        # Radau5 closes the loop at each step's end to its Newton tolerance (1.2e-14 at t_end); outputs
        # between steps come from the order-3 collocation polynomial, not projected: measured 2.9e-8
        # (rtol 1e-6), so 1e-7; a loop that drifts open is off by ≥ 1e-6.
        assert res.stats["integrator"].startswith("Radau5") and res.coordinates == "joint"
        assert np.max(res.constraint_residual()) < 1e-7
    # the motion stays planar
    for name in ("crank", "coupler", "rocker"):
        assert np.max(np.abs(res.part(name).position[:, 1])) < 1e-9
