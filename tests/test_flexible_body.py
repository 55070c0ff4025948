"""Craig-Bampton flexible bodies in the multibody core (floating frame of reference).

Link: seed 002's FLEGX lower-leg strip, 300 x 50 x 3 mm AISI 304, beam elements, reduced to
its two end nodes + fixed-interface modes. Closed forms: the clamped strip's first bending
frequency (171.32 rad/s = 27.266 Hz, seed 002 worked example); energy conservation of an
undamped flexible pendulum; the rigid-pendulum limit as E grows.
"""

import numpy as np
import pytest

import proleg as pl
from proleg.fem import BeamModel, Section, craig_bampton
from tolerances import CONSTRAINT_RESIDUAL

L = 0.3


def reduced_strip(n_el=8, n_modes=3):
    beam = BeamModel.polyline([(0, 0, 0), (L, 0, 0)], n_el, Section.rectangle(0.05, 0.003), "aisi304")
    root, tip = beam.node_at((0, 0, 0)), beam.node_at((L, 0, 0))
    B = np.concatenate([beam.node_dofs([root]).ravel(), beam.node_dofs([tip]).ravel()])
    rb = craig_bampton(beam.K, beam.M, B, n_modes, node_coordinates=beam.node_coordinates, node_dofs=beam.node_dof_table)
    return beam, rb, root, tip


@pytest.fixture(scope="module")
def strip():
    return reduced_strip()


def test_clamped_link_vibrates_at_its_fe_first_frequency(strip):
    beam, rb, root, tip = strip
    w, _ = beam.modes(1, clamp=[root])
    f_fe = w[0] / (2 * np.pi)
    assert f_fe == pytest.approx(27.266, rel=2e-3)  # seed 002: omega_1 = 171.32 rad/s
    m = pl.Model("clamped", gravity=(0, 0, -9.81))
    fb = m.add_flexible_body("link", rb, frame_node=root, position=(0, 0, 0))
    m.add_joint(pl.Fixed("clamp", m.ground, fb, at=(0, 0, 0)))
    res = pl.simulate(pl.assemble(m), t_end=0.15, dt_output=2.5e-4, integrator=pl.GeneralizedAlpha(rtol=1e-6, atol=1e-8), progress=False)
    tip_z = np.einsum("ij,nj->n", rb.modes[tip, 2:3][:, fb.eta_cols], np.asarray(res.q[:, 7:]))
    zc = tip_z - 0.5 * (tip_z.max() + tip_z.min())
    up = np.where((zc[:-1] < 0) & (zc[1:] >= 0))[0]
    tc = res.t[up] - zc[up] * (res.t[up + 1] - res.t[up]) / (zc[up + 1] - zc[up])
    f_sim = 1.0 / np.mean(np.diff(tc))
    assert f_sim == pytest.approx(f_fe, rel=1e-2)
    assert res.constraint_residual().max() < CONSTRAINT_RESIDUAL  # tests/tolerances.py: 50 phi_tol


def pendulum(rb, root, tip, scale_K=1.0):
    m = pl.Model("flex_pendulum", gravity=(0, 0, -9.81))
    fb = m.add_flexible_body("link", rb, frame_node=root, position=(0, 0, 0))
    m.add_joint(pl.Revolute("pin", fb, m.ground, at=(0, 0, 0), axis=(0, 1, 0)))
    m.add_marker(fb, "tip", node=tip)
    s = pl.assemble(m)
    if scale_K != 1.0:
        s = s.with_params(flex_link_K=s.params["flex_link_K"] * scale_K)
    return s


@pytest.mark.parametrize("t_end", [0.5, pytest.param(2.0, marks=pytest.mark.slow)])
def test_flexible_pendulum_conserves_energy(t_end):
    """Released from horizontal, no damping: T + V (incl. elastic) constant within 1e-5 relative."""
    beam, rb, root, tip = reduced_strip(n_el=4, n_modes=1)
    s = pendulum(rb, root, tip)
    res = pl.simulate(s, t_end=t_end, dt_output=5e-3, integrator=pl.GeneralizedAlpha(rtol=1e-8, atol=1e-10), progress=False)
    e = res.energy
    scale = beam.mass * 9.81 * L / 2  # potential drop to the bottom
    assert np.max(np.abs(e.total - e.total[0])) / scale < 1e-5
    assert np.max(e.kinetic) > 0.5 * scale  # it really swung


def test_stiff_flexible_pendulum_matches_rigid_pendulum():
    beam, rb, root, tip = reduced_strip(n_el=4, n_modes=1)
    s = pendulum(rb, root, tip, scale_K=1e4)
    res = pl.simulate(s, t_end=0.3, dt_output=1e-2, integrator=pl.GeneralizedAlpha(rtol=1e-7, atol=1e-9), progress=False)
    ang_flex = res.joint("pin").angle
    # The rigid strip with the FE model's mass and inertia about the pin.
    I_pin = float(rb.invariants["I7"][1, 1])
    m = pl.Model("rigid_pendulum", gravity=(0, 0, -9.81))
    mass = beam.mass
    Iy = I_pin - mass * (L / 2) ** 2
    rod = m.add_part("rod", mass=mass, inertia=(0.5 * Iy, Iy, Iy), position=(L / 2, 0, 0))
    m.add_joint(pl.Revolute("pin", rod, m.ground, at=(0, 0, 0), axis=(0, 1, 0)))
    ang_rigid = pl.simulate(pl.assemble(m), t_end=0.3, dt_output=1e-2, integrator=pl.GeneralizedAlpha(rtol=1e-9, atol=1e-11),
                            progress=False).joint("pin").angle
    assert np.max(np.abs(ang_flex - ang_rigid)) < 2e-3


def test_marker_off_the_mesh_is_an_error(strip):
    beam, rb, root, tip = strip
    m = pl.Model("bad")
    fb = m.add_flexible_body("link", rb, frame_node=root, position=(0, 0, 0))
    with pytest.raises(pl.ModelError, match="not on the mesh"):
        m.add_marker(fb, "off", position=(0.1234, 0.02, 0))
    with pytest.raises(pl.ModelError, match="frame_node"):
        m.add_flexible_body("link2", rb, frame_node=5, position=(0, 0, 0))


def test_stress_recovery_matches_beam_theory_at_the_clamp():
    """A static tip force P on the clamped strip: bending stress at the clamp sigma = P L c / I.

    Stress field: the beam's root section from the element curvature (a linear function of the
    nodal displacements) — here via the first element's end rotations, as a user would supply.
    """
    beam, rb, root, tip = reduced_strip(n_el=8, n_modes=2)
    sec = Section.rectangle(0.05, 0.003)
    E, c = 200e9, 0.0015
    le = L / 8
    n1 = beam.node_at((le, 0, 0))

    def root_stress(u):
        # Hermite cubic: curvature at x = 0 from w0, th0, w1, th1 of the first element (bending in x-z)
        w0, t0 = u[beam.dof(root, "uz")], -u[beam.dof(root, "ry")]
        w1, t1 = u[beam.dof(n1, "uz")], -u[beam.dof(n1, "ry")]
        kappa = (6 * (w1 - w0) / le**2 - (4 * t0 + 2 * t1) / le)
        sxx = E * c * kappa
        return np.array([[[sxx, 0, 0], [0, 0, 0], [0, 0, 0]]])

    P = 30.0
    m = pl.Model("clamped_load", gravity=(0, 0, 0))
    fb = m.add_flexible_body("link", rb, frame_node=root, position=(0, 0, 0), stress=([(0, 0, c)], root_stress), damping_ratio=0.05)
    m.add_joint(pl.Fixed("clamp", m.ground, fb, at=(0, 0, 0)))
    tipm = m.add_marker(fb, "tip", node=tip)
    m.add_force(pl.Force("load", tipm, value=(0, 0, -P)))
    eq = pl.solve_equilibrium(pl.assemble(m))
    res = eq.result()
    vm = res.stress("link").von_mises[0, 0]
    assert sec.Iy == pytest.approx(0.05 * 0.003**3 / 12)
    assert vm == pytest.approx(P * L * c / sec.Iy, rel=2e-2)
