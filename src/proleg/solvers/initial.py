"""Consistent initial conditions (Adams' initial-conditions analysis; note §4) and the KKT solve
for accelerations and multipliers (note §5)."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from ..assembly.coordinates import Absolute
from ..assembly.system import System


def mass_matrix(system: System, q):
    """Dense M(q) (nq, nq); singular along each p (the normalization row regularises the KKT).
    ``system`` may also be a coordinate set (assembly/coordinates.py)."""
    dyn = Absolute.of(system)
    return jax.jacfwd(lambda a: dyn.mass_action(q, a))(jnp.zeros_like(q))


def gamma_rhs(system: System, q, v, t):
    """γ = −d²/ds² Φ(q + s v, t + s) at s = 0 (two nested jvps)."""
    dyn = Absolute.of(system)
    f = lambda s: dyn.constraints(q + s * v, t + s)
    df = lambda s: jax.jvp(f, (s,), (jnp.ones_like(s),))[1]
    return -jax.jvp(df, (jnp.zeros(()),), (jnp.ones(()),))[1]


def kkt_accelerations(system: System, q, v, t, z=None):
    """Solve [[M, Φ_qᵀ], [Φ_q, 0]] [q̈; λ] = [Q; γ] (``system``: a System or a coordinate set)."""
    dyn = Absolute.of(system)
    nq = q.shape[0]
    M = mass_matrix(dyn, q)
    Pq = jax.jacfwd(lambda qq: dyn.constraints(qq, t))(q)
    Q = dyn.generalized_forces(q, v, t, z)
    g = gamma_rhs(dyn, q, v, t)
    nc = Pq.shape[0]
    S = jnp.block([[M, Pq.T], [Pq, jnp.zeros((nc, nc))]])
    x = jnp.linalg.solve(S, jnp.concatenate([Q, g]))
    return x[:nq], x[nq:]


def _normalize_p(q, nb):
    qb = q[: 7 * nb].reshape(nb, 7)
    p = qb[:, 3:] / jnp.linalg.norm(qb[:, 3:], axis=1, keepdims=True)
    return jnp.concatenate([jnp.concatenate([qb[:, :3], p], 1).reshape(-1), q[7 * nb :]])
