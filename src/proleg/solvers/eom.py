"""The joint-coordinate equations of motion of a tree as an ODE right-hand side, shared by the
Diffrax pairs (solvers/ode.py) and the generic step driver of the integrator protocol
(solvers/base.py): y = (x, u, w), ẏ = (u, u̇, [dissipated, input] power)."""

from __future__ import annotations

import jax
import jax.numpy as jnp


def accelerations(dyn, x, u, t, z, stabilization=0.0, MQ=None):
    """u̇ of the joint-coordinate ODE: M u̇ + Φ_xᵀλ = Q, Φ_x u̇ = γ (− 2s Φ̇ − s²Φ) (KKT); (nq,).
    Without constraints by Cholesky (M is symmetric positive definite): 1 µs against 7.5 µs for
    the LU of jnp.linalg.solve on the 8-link chain (bench/README.md, accuracy section)."""
    from .initial import gamma_rhs

    M, Q = (dyn.mass_matrix(x), dyn.generalized_forces(x, u, t, z)) if MQ is None else MQ
    if dyn.nc == 0:
        return jax.scipy.linalg.cho_solve(jax.scipy.linalg.cho_factor(M), Q)
    Pq = jax.jacfwd(lambda y: dyn.constraints(y, t))(x)
    nc = Pq.shape[0]
    S = jnp.block([[M, Pq.T], [Pq, jnp.zeros((nc, nc), x.dtype)]])
    g = gamma_rhs(dyn, x, u, t)
    if stabilization:
        phi, phid = jax.jvp(lambda s: dyn.constraints(x + s * u, t + s), (jnp.zeros((), x.dtype),), (jnp.ones((), x.dtype),))
        g = g - 2.0 * stabilization * phid - stabilization**2 * phi
    return jnp.linalg.solve(S, jnp.concatenate([Q, g]))[: x.shape[0]]


def vector_field(t, y, args):
    """Diffrax vector field of y = (x, u, w): (u, u̇, [dissipated, input] power)."""
    dyn, z, stabilization = args
    x, u, _ = y
    M, Q, pw = dyn.dynamics(x, u, t, z)  # one pass of kinematics (assembly/joint_coordinates.py)
    return u, accelerations(dyn, x, u, t, z, stabilization, (M, Q)), pw
