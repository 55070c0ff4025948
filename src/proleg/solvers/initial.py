"""Consistent initial conditions (Adams' initial-conditions analysis; note §4) and the KKT solve
for accelerations and multipliers (note §5)."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from ..assembly.system import System, constraints, generalized_forces, mass_action
from ..errors import ConvergenceError


def mass_matrix(system: System, q):
    """Dense M(q) (nq, nq); singular along each p (the normalization row regularises the KKT)."""
    return jax.jacfwd(lambda a: mass_action(system, q, a))(jnp.zeros_like(q))


def gamma_rhs(system: System, q, v, t):
    """γ = −d²/ds² Φ(q + s v, t + s) at s = 0 (two nested jvps)."""
    f = lambda s: constraints(system, q + s * v, t + s)
    df = lambda s: jax.jvp(f, (s,), (jnp.ones_like(s),))[1]
    return -jax.jvp(df, (jnp.zeros(()),), (jnp.ones(()),))[1]


def kkt_accelerations(system: System, q, v, t, z=None):
    """Solve [[M, Φ_qᵀ], [Φ_q, 0]] [q̈; λ] = [Q; γ]."""
    nq = q.shape[0]
    M = mass_matrix(system, q)
    Pq = jax.jacfwd(lambda qq: constraints(system, qq, t))(q)
    Q = generalized_forces(system, q, v, t, z)
    g = gamma_rhs(system, q, v, t)
    nc = Pq.shape[0]
    S = jnp.block([[M, Pq.T], [Pq, jnp.zeros((nc, nc))]])
    x = jnp.linalg.solve(S, jnp.concatenate([Q, g]))
    return x[:nq], x[nq:]


def _normalize_p(q, nb):
    qb = q[: 7 * nb].reshape(nb, 7)
    p = qb[:, 3:] / jnp.linalg.norm(qb[:, 3:], axis=1, keepdims=True)
    return jnp.concatenate([jnp.concatenate([qb[:, :3], p], 1).reshape(-1), q[7 * nb :]])


@jax.jit
def _pos_ic_step(system, q, q_user, t):
    phi = constraints(system, q, t)
    Pq = jax.jacfwd(lambda qq: constraints(system, qq, t))(q)
    nq, nc = q.shape[0], phi.shape[0]
    S = jnp.block([[jnp.eye(nq), Pq.T], [Pq, jnp.zeros((nc, nc))]])
    dx = jnp.linalg.solve(S, jnp.concatenate([q_user - q, -phi]))
    return q + dx[:nq], jnp.max(jnp.abs(phi))


@jax.jit
def _vel_ic(system, q, v_user, t):
    M = mass_matrix(system, q)
    Pq = jax.jacfwd(lambda qq: constraints(system, qq, t))(q)
    Pt = jax.jacfwd(lambda tt: constraints(system, q, tt))(t)
    nq, nc = q.shape[0], Pq.shape[0]
    S = jnp.block([[M, Pq.T], [Pq, jnp.zeros((nc, nc))]])
    x = jnp.linalg.solve(S, jnp.concatenate([M @ v_user, -Pt]))
    return x[:nq]


def initial_conditions(system: System, q_user=None, v_user=None, t0=0.0, tol=1e-12, max_iter=50):
    """Positions and velocities satisfying Φ = 0 and Φ_q v + Φ_t = 0, closest to the user's.

    Returns (q0, v0, report) where ``report`` lists the parts whose pose or velocity changed by
    more than 1e-9 (position [m] / rotation [rad] / speed).
    """
    topo = system.topo
    nb = topo.nbody
    q_user = system.params["q_init"] if q_user is None else jnp.asarray(q_user)
    v_user = system.params["v_init"] if v_user is None else jnp.asarray(v_user)
    q_user = _normalize_p(q_user, nb)
    q = q_user
    t0 = jnp.asarray(t0, jnp.float64)
    res = np.inf
    for _ in range(max_iter):
        q_new, res = _pos_ic_step(system, q, q_user, t0)
        q = _normalize_p(q_new, nb)
        if float(jnp.max(jnp.abs(constraints(system, q, t0)))) < tol:
            break
    else:
        res = float(jnp.max(jnp.abs(constraints(system, q, t0))))
        row = int(jnp.argmax(jnp.abs(constraints(system, q, t0))))
        elem, lab = topo.ct.labels[row]
        raise ConvergenceError(
            f"Initial conditions: could not assemble model '{topo.name}' (constraint residual {res:.3g} "
            f"in '{elem}' equation {lab}). Check the joint locations and part poses."
        )
    v = _vel_ic(system, q, v_user, t0)
    report = []
    qa, qb_ = np.asarray(q)[: 7 * nb].reshape(nb, 7), np.asarray(q_user)[: 7 * nb].reshape(nb, 7)
    va, vb_ = np.asarray(v)[: 7 * nb].reshape(nb, 7), np.asarray(v_user)[: 7 * nb].reshape(nb, 7)
    for b, name in enumerate(topo.body_names):
        dr = np.linalg.norm(qa[b, :3] - qb_[b, :3])
        dp = 2 * np.linalg.norm(qa[b, 3:] - qb_[b, 3:])
        dv = np.linalg.norm(va[b] - vb_[b])
        if max(dr, dp, dv) > 1e-9:
            report.append({"part": name, "moved_m": dr, "rotated_rad": dp, "velocity_change": dv})
    return q, v, report
