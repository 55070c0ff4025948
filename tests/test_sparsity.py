"""The colour-compressed Newton matrix (assembly/sparsity.py, solvers/galpha.iteration_matrix)
equals the dense forward-mode Jacobian of the same equations, element type by element type:
a wrong structural pattern would silently drop couplings (slow Newton, never a wrong answer),
so every pattern source is checked here to 1e-12 relative.
"""

import sys
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np

import proleg as pl
from proleg.assembly.system import constraints, generalized_forces, mass_action
from proleg.solvers.galpha import iteration_matrix

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "bench"))
from common import build_chain  # noqa: E402


@jax.jit
def _dense_jacobian(system, q, v, z, bp, cv):
    def R(dq):
        Rq = mass_action(system, q, dq) - generalized_forces(system, q + dq, v + cv * dq, 0.3, z) / bp
        return jnp.concatenate([Rq, constraints(system, q + dq, 0.3)])

    return jax.jacfwd(R)(jnp.zeros(system.nq))


def dense_matrix(system, q, v, z, bp, cv):
    """[[M − (K + cv C)/β', Φ_qᵀ], [Φ_q, 0]] by dense jacfwd (the reference), compiled once."""
    nq, nc = system.nq, system.nc
    J = _dense_jacobian(system, q, v, z, bp, cv)
    return np.block([[np.asarray(J[:nq]), np.asarray(J[nq:]).T], [np.asarray(J[nq:]), np.zeros((nc, nc))]])


def check(system, seed=0):
    rng = np.random.default_rng(seed)
    q = np.asarray(system.params["q_init"]) + 1e-3 * rng.standard_normal(system.nq)
    v = np.asarray(system.params["v_init"]) + 0.3 * rng.standard_normal(system.nq)
    from proleg.analyses.simulate import initial_z

    z = initial_z(system)
    q, v = jnp.asarray(q), jnp.asarray(v)
    J = np.asarray(jax.jit(iteration_matrix)(system, q, v, 0.3, z, 1e4, 50.0, 1.0))
    Jd = dense_matrix(system, q, v, z, 1e4, 50.0)
    scale = np.abs(Jd).max()
    np.testing.assert_allclose(J, Jd, rtol=0, atol=1e-12 * scale)
    return system.topo.coloring


def test_chain_needs_two_part_colours_whatever_its_length():
    for n in (3, 8):
        col = check(pl.assemble(build_chain(n, spring=50.0)))
        assert col.ncolors == 14 and not col.dense


def test_bushings_springs_and_rotational_elements():
    col = check(pl.assemble(build_chain(4, joints="bushing", spring=80.0)))
    assert not col.dense


def test_hyq_leg_with_contact_actuators_and_controllers():
    from proleg.robots import hyq_leg

    for joints in ("rigid", "bushings4"):
        check(pl.assemble(hyq_leg(joints)))


def test_flexible_body_columns_travel_with_their_part():
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from test_flexible_body import pendulum, reduced_strip

    beam, rb, root, tip = reduced_strip(n_el=4, n_modes=2)
    check(pendulum(rb, root, tip))


def test_state_dependent_force_makes_the_pattern_dense():
    model = build_chain(3)
    model.add_force(pl.Force("pull", model.parts[0], lambda t, s: -10.0 * s.position("link3")))
    system = pl.assemble(model)
    col = check(system)
    assert col.dense


def test_slide_friction_couples_the_parts_loading_its_slider():
    """SlideFriction's normal load reads every load on the sliding part (toe contact, spring):
    its pattern must couple the joint's parts with the parts those elements touch."""
    m = pl.Model("telescope", gravity=(0, 0, -9.81))
    up = m.add_part("upper", mass=1.0, inertia=(0.01,) * 3, position=(0, 0, 0.4))
    lo = m.add_part("lower", mass=0.3, inertia=(0.003,) * 3, position=(0.05, 0, 0.2))
    other = m.add_part("other", mass=1.0, inertia=(0.01,) * 3, position=(1.0, 0, 0.5))
    ax = np.array([0.2, 0.0, -1.0]) / np.linalg.norm([0.2, 0.0, -1.0])
    m.add_joint(pl.Revolute("hip", up, m.ground, at=(0, 0, 0.5), axis=(0, 1, 0)))
    leg = m.add_joint(pl.Prismatic("leg", lo, up, at=(0, 0, 0.5), axis=ax))
    m.add_joint(pl.Revolute("other_pin", other, m.ground, at=(1.0, 0, 0.6), axis=(0, 1, 0)))
    toe = m.add_marker(lo, "toe", np.array([0, 0, 0.5]) + 0.45 * ax)
    top = m.add_marker(up, "top", (0, 0, 0.5))
    m.add_force(pl.SpringDamper("spring", toe, top, stiffness=2000.0, damping=10.0, free_length=0.45))
    m.add_contact(pl.SphereContact("toe_contact", toe, radius=0.02, stiffness=1e5, damping=100.0, mu_static=0.8, mu_dynamic=0.6))
    m.add_force(pl.SlideFriction("leg_friction", leg, mu_static=0.3, mu_dynamic=0.2, overlap=0.05, bearing_offset=0.2))
    col = check(pl.assemble(m))
    assert not col.dense
