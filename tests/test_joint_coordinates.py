"""Joint coordinates (assembly/joint_coordinates.py): CRBA and RNEA against the projection of the
absolute equations, the same motion as absolute coordinates, loop closure, vmap and jacfwd.

The projection reference: with q(x) the absolute coordinates of a joint-coordinate state,
T = ∂q/∂x and Ṫ ẋ = d²q(x + s ẋ)/ds², the equations M q̈ = Q in absolute coordinates become
Tᵀ M T ẍ = Tᵀ (Q − M Ṫ ẋ) (virtual work): so M_x = Tᵀ M T and Q_x = Tᵀ (Q − M Ṫ ẋ) exactly.
"""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from test_core_fourbar import build as four_bar
from test_planar import chain, check_vmap_and_jacfwd, slider_crank

import proleg as pl
from proleg.assembly.coordinates import coordinate_set
from proleg.assembly.joint_coordinates import JointCoordinates
from proleg.assembly.system import constraints, generalized_forces, mass_action
from proleg.spatial.rotation import A_of_p, p_of_A

G = 9.81


def floating_chain():
    """A free base (no joint to ground) spinning and falling, with two links on revolutes about
    different axes and a spring from the base to the tip: a floating-base tree in 3D."""
    model = pl.Model("floating_chain", gravity=(0, 0, -G))
    base = model.add_part("base", mass=2.0, inertia=(0.02, 0.03, 0.04), position=(0, 0, 1.0), velocity=(0.3, 0.0, 0.5), angular_velocity=(0.5, -1.0, 2.0))
    l1 = model.add_part("link1", mass=0.5, inertia=(0.001, 0.004, 0.004), position=(0.25, 0, 1.0))
    l2 = model.add_part("link2", mass=0.3, inertia=(0.001, 0.002, 0.002), position=(0.45, 0.1, 1.0))
    model.add_joint(pl.Revolute("shoulder", l1, base, at=(0.1, 0, 1.0), axis=(0, 1, 0)))
    model.add_joint(pl.Revolute("elbow", l2, l1, at=(0.4, 0, 1.0), axis=(0, 0.6, 0.8)))
    tip = model.add_marker(l2, "tip", position=(0.5, 0.2, 1.0))
    top = model.add_marker(base, "top", position=(0.0, 0.0, 1.2))
    model.add_force(pl.SpringDamper("spring", tip, top, stiffness=40.0, damping=0.2, free_length=0.4))
    return model


@pytest.fixture(scope="module")
def systems():
    out = {"chain3": pl.assemble(chain(3)), "floating": pl.assemble(floating_chain())}
    with pytest.warns(UserWarning, match="redundant"):
        out["slider_crank"] = pl.assemble(slider_crank())
    return out


def test_tree_and_loops(systems):
    """A hanging chain has one angle per hinge and no constraint; the slider-crank keeps the
    wrist as a cut joint with its 2 in-plane rows (the 3 out-of-plane ones are constant on the
    tree); the floating base has 7 coordinates and its normalization row."""
    dims = {}
    for name, s in systems.items():
        dyn = coordinate_set(s, s.params["q_init"], "joint")
        assert isinstance(dyn, JointCoordinates)
        dims[name] = (dyn.nq, dyn.nc, dyn.tree.cut)
    assert dims == {"chain3": (3, 0, []), "floating": (9, 1, []), "slider_crank": (3, 2, ["wrist"])}


def _random_state(dyn, rng):
    T = dyn.tree
    x = rng.uniform(-1.5, 1.5, dyn.nq)
    for c in T.float_col:
        p = rng.normal(size=4)
        x[c + 3 : c + 7] = p / np.linalg.norm(p)
    xd = rng.normal(size=dyn.nq)
    for c in T.float_col:  # ṗ ⟂ p on the unit sphere
        p = x[c + 3 : c + 7]
        xd[c + 3 : c + 7] -= p * (p @ xd[c + 3 : c + 7])
    return jnp.asarray(x), jnp.asarray(xd)


@pytest.mark.parametrize("name", ["chain3", "floating", "slider_crank"])
def test_crba_rnea_match_projection(systems, name):
    """M(x) by CRBA and Q(x, ẋ) by RNEA equal Tᵀ M T and Tᵀ (Q − M Ṫ ẋ) at 3 random states
    (all elements, gravity, gyroscopic terms) to 1e-10 of their size; the spatial velocities
    equal T ẋ; and p_of_A inverts A_of_p."""
    system = systems[name]
    dyn = coordinate_set(system, system.params["q_init"], "joint")
    rng = np.random.default_rng(3)

    @jax.jit
    def both(x, xd):
        qx = lambda y: dyn.absolute(y, jnp.zeros_like(y))[0]  # noqa: E731
        T = jax.jacfwd(qx)(x)
        q, v = dyn.absolute(x, xd)
        Tdxd = jax.jvp(lambda y: jax.jvp(qx, (y,), (xd,))[1], (x,), (xd,))[1]
        # Along the unit sphere a floating base's p̈ has the radial part −|ṗ|² p (x + s ẋ leaves it).
        pc = np.asarray(dyn.tree.dof_type) == 3
        Tdxd = Tdxd + T @ jnp.where(pc, -jnp.sum(jnp.where(pc, xd * xd, 0.0)) * x, 0.0)
        Mabs = jax.jacfwd(lambda a: mass_action(system, q, a))(jnp.zeros_like(q))
        Qp = T.T @ (generalized_forces(system, q, v, 0.3) - mass_action(system, q, Tdxd))
        return dyn.mass_matrix(x), T.T @ Mabs @ T, dyn.generalized_forces(x, xd, 0.3), Qp, v, T @ xd

    for _ in range(3):
        x, xd = _random_state(dyn, rng)
        M, Mp, Q, Qp, v, Txd = both(x, xd)
        # A floating base's ṗ ∥ p moves nothing (ω = 2 G ṗ = 0) in joint coordinates but scales
        # A(p) off the unit sphere in the projection: compare on the tangent space (P), where the
        # normalization row does not act.
        P = np.eye(dyn.nq)
        for c in dyn.tree.float_col:
            e = np.zeros(dyn.nq)
            e[c + 3 : c + 7] = x[c + 3 : c + 7]
            P -= np.outer(e, e)
        M, Mp, Q, Qp = P @ M @ P, P @ Mp @ P, P @ Q, P @ Qp
        np.testing.assert_allclose(M, Mp, rtol=0, atol=1e-10 * np.abs(Mp).max())
        np.testing.assert_allclose(Q, Qp, rtol=0, atol=1e-10 * np.abs(Qp).max())
        np.testing.assert_allclose(v, Txd, rtol=0, atol=1e-12)
    p = rng.normal(size=(20, 4))
    p /= np.linalg.norm(p, axis=1, keepdims=True)
    # round trip of unit quaternions through 3×3 matrices: ~20 flops on O(1) values and a sqrt, 64 eps
    np.testing.assert_allclose(np.abs(np.sum(p_of_A(A_of_p(jnp.asarray(p))) * p, 1)), 1.0, atol=64 * np.finfo(float).eps)


def _compare(system, t_end, pos_tol, vel_tol):
    opts = dict(t_end=t_end, dt_output=0.01, integrator=pl.GeneralizedAlpha(rtol=1e-10, atol=1e-11), progress=False)
    ra = pl.simulate(system, coordinates="absolute", **opts)
    rj = pl.simulate(system, coordinates="joint", **opts)
    assert rj.coordinates == "joint" and rj.ok
    nb = system.topo.nbody
    qa, qj = np.asarray(ra.q).reshape(-1, nb, 7), np.asarray(rj.q).reshape(-1, nb, 7)
    assert np.abs(qa[..., :3] - qj[..., :3]).max() < pos_tol
    # Same rotation (p and −p are the same attitude).
    assert np.abs(np.abs(np.sum(qa[..., 3:] * qj[..., 3:], -1)) - 1.0).max() < pos_tol
    for b in system.topo.body_names:
        pa, pj = ra.part(b), rj.part(b)
        assert np.abs(pa.velocity - pj.velocity).max() < vel_tol
        assert np.abs(pa.angular_velocity - pj.angular_velocity).max() < vel_tol
    return ra, rj


@pytest.mark.parametrize("n", [pytest.param(1, marks=pytest.mark.slow), 2])
def test_pendulums_same_motion_as_absolute(n):
    """Simple and double pendulum (products of inertia, hinges offset along the axis): joint and
    absolute coordinates agree to the integration tolerance (rtol 1e-10): 1e-6 m, 1e-5 m/s."""
    _compare(pl.assemble(chain(n)), 0.5, 1e-6, 1e-5)


@pytest.mark.slow
def test_floating_chain_same_motion_as_absolute(systems):
    """A spinning, falling floating base with two links and a spring: the same motion in both
    coordinate sets (1e-6 m, 1e-5 rad/s), and the base's Euler parameters stay normalized."""
    _, rj = _compare(systems["floating"], 0.4, 1e-6, 1e-5)
    p = rj.part("base").quaternion
    assert np.abs(np.sum(p * p, 1) - 1.0).max() < 1e-9


def test_four_bar_keeps_its_loop():
    """Four-bar in joint coordinates: three hinge angles of the spanning tree and the fourth
    hinge's two in-plane rows as constraints; every joint equation of the absolute model holds
    to 1e-9 over 1 s, and the motion is that of the absolute run (1e-6 m)."""
    with pytest.warns(UserWarning, match="redundant"):
        system = pl.assemble(four_bar())
    dyn = coordinate_set(system, system.params["q_init"], "joint")
    assert (dyn.nq, dyn.nc) == (3, 2)
    ra, rj = _compare(system, 1.0, 1e-6, 1e-4)
    phi = jax.jit(jax.vmap(lambda q: constraints(system, q, 0.0)))(rj.q)
    assert np.abs(np.asarray(phi)).max() < 1e-9


@pytest.mark.slow
def test_vmap_and_jacfwd_through_joint_coordinates():
    """Sweeps and sensitivities in joint coordinates: a vmap of 8 spring stiffnesses equals the
    loop to 1e-12; d(final x)/dk by jacfwd equals central differences within 1e-5 relative."""
    system = pl.assemble(chain(2, tilt=False, spring=50.0))

    def final_x(k):
        r = pl.simulate(system.with_params({"spring.stiffness": k}), t_end=0.2, dt_output=0.05, integrator=pl.GeneralizedAlpha(fixed_step=1e-3),
                        progress=False, coordinates="joint")
        return r.part("link2").position[-1, 0]

    check_vmap_and_jacfwd(final_x, jnp.linspace(20.0, 90.0, 8))


@pytest.mark.slow
def test_hyq_leg_same_drop_as_planar():
    """The HyQ leg (hydraulic cylinders on universal pins: cut joints, floating cylinder parts)
    drops the same in joint coordinates as in its default (planar) coordinates at rtol 1e-8."""
    system = pl.assemble(pl.robots.hyq_leg())
    opts = dict(t_end=0.3, integrator=pl.GeneralizedAlpha(rtol=1e-8, atol=1e-9), progress=False)
    ra = pl.simulate(system, **opts)
    rj = pl.simulate(system, coordinates="joint", **opts)
    nb = system.topo.nbody
    qa, qj = np.asarray(ra.q).reshape(-1, nb, 7), np.asarray(rj.q).reshape(-1, nb, 7)
    assert np.abs(qa[..., :3] - qj[..., :3]).max() < 1e-5
