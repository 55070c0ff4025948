"""Consistent initial conditions (Adams' initial-conditions analysis; note §4) and the KKT solve
for accelerations and multipliers (note §5)."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from ..assembly.coordinates import Absolute
from ..assembly.system import System, constraints, constraints_and_jacobian, generalized_forces, power_terms
from ..compile_cache import cached_jit
from ..errors import ConvergenceError


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


def kkt_accelerations(system: System, q, v, t, z=None, M=None, Pq=None, Q=None):
    """Solve [[M, Φ_qᵀ], [Φ_q, 0]] [q̈; λ] = [Q; γ] (``system``: a System or a coordinate set).
    ``M``, ``Pq`` (Φ_q) and ``Q``: already evaluated at (q, v, t, z), if the caller has them."""
    dyn = Absolute.of(system)
    nq = q.shape[0]
    M = mass_matrix(dyn, q) if M is None else M
    Pq = jax.jacfwd(lambda qq: dyn.constraints(qq, t))(q) if Pq is None else Pq
    Q = dyn.generalized_forces(q, v, t, z) if Q is None else Q
    g = gamma_rhs(dyn, q, v, t)
    nc = Pq.shape[0]
    S = jnp.block([[M, Pq.T], [Pq, jnp.zeros((nc, nc))]])
    x = jnp.linalg.solve(S, jnp.concatenate([Q, g]))
    return x[:nq], x[nq:]


def _normalize_p(q, nb):
    qb = q[: 7 * nb].reshape(nb, 7)
    p = qb[:, 3:] / jnp.linalg.norm(qb[:, 3:], axis=1, keepdims=True)
    return jnp.concatenate([jnp.concatenate([qb[:, :3], p], 1).reshape(-1), q[7 * nb :]])


def sample_controllers(system, t, q, v, z, first=False, kin=None):
    """Controller sample: z ← update(t, q, v, z) for every sampled element. ``kin``: the (body,
    marker) kinematics at (q, v) if the caller has them (then q and v are not read)."""
    for g in system.topo.extensions:
        if hasattr(g, "sample"):
            z = g.sample(system.params, t, q, v, z, system, first, kin)
    return z


def sample_state(dyn, t, x, xd, z):
    """:func:`sample_controllers` at a state (x, ẋ) of the coordinate set ``dyn``: from its own
    kinematics where it has them (joint coordinates), else through absolute coordinates."""
    if hasattr(dyn, "kinematics"):
        return sample_controllers(dyn.system, t, None, None, z, kin=dyn.kinematics(x, xd))
    return sample_controllers(dyn.system, t, *dyn.absolute(x, xd), z)


def initial_z(system: System):
    parts = [g.z0(system.params) for g in system.topo.extensions if hasattr(g, "z0")]
    if not parts:
        return np.zeros(0)  # NumPy: no eager JAX op (each would compile)
    return jnp.concatenate([jnp.asarray(p) for p in parts])


def _ic_positions(system: System, q_user, t0, n_iter: int):
    nb = system.topo.nbody
    q_user = _normalize_p(q_user, nb)

    def gn(q, _):
        phi, Pq = constraints_and_jacobian(system, q, t0)
        nq, nc = q.shape[0], phi.shape[0]
        S = jnp.block([[jnp.eye(nq), Pq.T], [Pq, jnp.zeros((nc, nc))]])
        dx = jnp.linalg.solve(S, jnp.concatenate([q_user - q, -phi]))
        return _normalize_p(q + dx[:nq], nb), None

    q, _ = jax.lax.scan(gn, q_user, None, length=n_iter)
    return q


@cached_jit(static_argnums=(4,))
def _ic(system: System, q_user, v_user, t0, n_iter: int, z0):
    """One compiled initial-conditions analysis: positions (Gauss-Newton), velocities (M-weighted
    projection), a controller sample at t0, accelerations and multipliers (KKT), powers."""
    q = _ic_positions(system, q_user, t0, n_iter)
    M = mass_matrix(system, q)
    phi, Pq = constraints_and_jacobian(system, q, t0)
    Pt = jax.jacfwd(lambda tt: constraints(system, q, tt))(t0)
    nq, nc = q.shape[0], Pq.shape[0]
    S = jnp.block([[M, Pq.T], [Pq, jnp.zeros((nc, nc))]])
    v = jnp.linalg.solve(S, jnp.concatenate([M @ v_user, -Pt]))[:nq]
    z = sample_controllers(system, t0, q, v, z0, True)
    Q = generalized_forces(system, q, v, t0, z)
    qdd, lam = kkt_accelerations(system, q, v, t0, z, M=M, Pq=Pq, Q=Q)
    # HHT carries g = (Φ_qᵀλ − Q) of the previous step; start it consistently (not 0).
    g = Pq.T @ lam - Q
    return q, v, qdd, lam, z, (power_terms(system, q, v, t0, z), g), jnp.max(jnp.abs(phi))


def consistent_state(system: System, q_user=None, v_user=None, t0=0.0, z0=None, tol=1e-10):
    """Initial (q, v, q̈, λ, z) satisfying the constraints at position, velocity and acceleration level."""
    return _consistent_state(system, q_user, v_user, t0, z0, tol)[:5]


def _consistent_state(system, q_user, v_user, t0, z0, tol=1e-10):
    q_user = system.params["q_init"] if q_user is None else jnp.asarray(q_user, jnp.float64)
    v_user = system.params["v_init"] if v_user is None else jnp.asarray(v_user, jnp.float64)
    t0 = t0 if isinstance(t0, jax.core.Tracer) else np.asarray(t0, np.float64)  # no eager op (compile)
    z0 = initial_z(system) if z0 is None else z0
    q, v, qdd, lam, z, pw, res = _ic(system, q_user, v_user, t0, 8, z0)
    if not isinstance(res, jax.core.Tracer):
        tries = 0
        while float(res) > tol and tries < 6:
            q, v, qdd, lam, z, pw, res = _ic(system, q, v_user, t0, 8, z0)
            tries += 1
        if not float(res) <= tol:
            row = int(jnp.argmax(jnp.abs(jax.jit(constraints)(system, q, t0))))
            elem, lab = system.topo.ct.labels[row]
            raise ConvergenceError(
                f"Initial conditions: model '{system.topo.name}' cannot be assembled (constraint residual "
                f"{float(res):.3g} in '{elem}', equation {lab}). Check joint locations and part poses."
            )
    return q, v, qdd, lam, z, pw


def sample_period(system):
    """The controllers' sample period [s] (the shortest), or None."""
    periods = [g.period for g in system.topo.extensions if getattr(g, "period", None)]
    if not periods:
        return None
    base = min(periods)
    return float(base)
