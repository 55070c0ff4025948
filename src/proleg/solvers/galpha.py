"""Generalized-α (Arnold & Brüls 2007) and HHT-I3 (Negrut et al. 2007) on the index-3 DAE.

    M(q) q̈ + Φ_qᵀ λ = Q(q, q̇, t),   Φ(q, t) = 0

following ../shared/notes/formulation.md §4: Newton on x = (q_{n+1}, μ = λ/β') with the scaled
residual R_q = (1/β')[M q̈ − Q] + Φ_qᵀμ, R_Φ = Φ, the iteration matrix from forward-mode
autodiff of R (modified Newton: one Jacobian and LU per step, refreshed when convergence is
slow), the local error estimate e = h²(β − γ/2 + 1/12)(a_{n+1} − a_n) and the rescaling of a_n
whenever h changes.

Choosing values
---------------
``rho_inf`` (spectral radius at infinite frequency) in [0.5, 0.95]: 0.8 (default) damps
spurious high-frequency modes (stiff bushings, contact) while adding ~1e-6 relative energy loss
per second on a 1e-4 s step; never 1 (index-3 trapezoidal rule is unstable, note §4).
HHT: ``alpha`` in [−1/3, 0], ρ∞ = (1 + α)/(1 − α); M is evaluated at q_{n+1+α} to keep order 2.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import jax
import jax.numpy as jnp
from jax.scipy.linalg import lu_factor, lu_solve

from ..assembly.system import System, constraints, generalized_forces, mass_action, power_terms


class StepState(NamedTuple):
    t: jnp.ndarray
    q: jnp.ndarray
    v: jnp.ndarray
    a: jnp.ndarray  # auxiliary acceleration (GA); equals qdd for HHT
    qdd: jnp.ndarray
    lam: jnp.ndarray
    h_prev: jnp.ndarray  # step for which ``a`` is consistent
    w: jnp.ndarray  # (2,) integrated [dissipated energy, input work] [J]
    pw: jnp.ndarray  # (2,) powers at t
    z: jnp.ndarray  # discrete (controller) state, held between samples
    g: jnp.ndarray  # HHT: (Φ_qᵀλ − Q) at t_n


@dataclass(frozen=True)
class GeneralizedAlpha:
    """Generalized-α, index 3, scaled Newton (default integrator)."""

    rho_inf: float = 0.8

    def __post_init__(self):
        if not (0.0 <= self.rho_inf < 1.0):
            raise ValueError(f"GeneralizedAlpha rho_inf must be in [0, 1), got {self.rho_inf} (ρ∞ = 1 is unstable at index 3).")

    @property
    def coefficients(self):
        r = self.rho_inf
        am = (2 * r - 1) / (r + 1)
        af = r / (r + 1)
        gamma = 0.5 + af - am
        beta = 0.25 * (gamma + 0.5) ** 2
        return am, af, gamma, beta

    @property
    def error_coefficient(self):
        am, af, gamma, beta = self.coefficients
        return beta - gamma / 2 + 1.0 / 12.0

    hht = False


@dataclass(frozen=True)
class HHT:
    """HHT-I3 (Adams' HHT): α in [−1/3, 0]; the mass matrix is evaluated at q_{n+1+α}."""

    alpha: float = -0.05

    def __post_init__(self):
        if not (-1.0 / 3.0 <= self.alpha <= 0.0):
            raise ValueError(f"HHT alpha must be in [-1/3, 0], got {self.alpha}.")

    @property
    def coefficients(self):
        a = self.alpha
        return 0.0, 0.0, 0.5 - a, 0.25 * (1 - a) ** 2

    @property
    def error_coefficient(self):
        return 1.0 / 12.0 + self.alpha**2 / 4.0

    hht = True


@dataclass(frozen=True)
class StepOptions:
    rtol: float = 1e-6
    atol: float = 1e-7  # translations [m]
    atol_p: float = 1e-7  # Euler parameters [-]
    newton_tol: float = 1e-3  # on the weighted RMS of Δq, in units of the error tolerance
    max_newton: int = 10
    phi_tol: float = 1e-10
    # Refresh the iteration matrix inside a step when Newton contracts slowly. Off under jax.vmap
    # (a lax.cond becomes a select there and would rebuild the Jacobian every iteration).
    jacobian_refresh: bool = True


def _weights(system: System, q, opts: StepOptions):
    nb = system.topo.nbody
    atol = jnp.concatenate([jnp.tile(jnp.array([opts.atol] * 3 + [opts.atol_p] * 4), nb), jnp.full(system.topo.n_eta, opts.atol)])
    return atol + opts.rtol * jnp.abs(q)


def _wrms(x, w):
    return jnp.sqrt(jnp.mean((x / w) ** 2))


def step(system: System, integrator, st: StepState, h, opts: StepOptions):
    """One step of size h from ``st``. Returns (new state, error norm, iterations, converged, worst row)."""
    nq = system.topo.nq
    am, af, gamma, beta = integrator.coefficients
    t1 = st.t + h
    # Rescale the auxiliary acceleration to the new step (note §4).
    a_n = st.qdd + (h / st.h_prev) * (st.a - st.qdd)
    bp = (1 - am) / (h * h * beta * (1 - af))
    z = st.z

    def update(q1):
        a1 = (q1 - st.q - h * st.v - h * h * (0.5 - beta) * a_n) / (h * h * beta)
        v1 = st.v + h * ((1 - gamma) * a_n + gamma * a1)
        if integrator.hht:
            qdd1 = a1
        else:
            qdd1 = ((1 - am) * a1 + am * a_n - af * st.qdd) / (1 - af)
        return a1, v1, qdd1

    def residual(x):
        q1, mu = x[:nq], x[nq:]
        a1, v1, qdd1 = update(q1)
        phi, vjp = jax.vjp(lambda qq: constraints(system, qq, t1), q1)
        if integrator.hht:
            al = integrator.alpha
            qm = (1 + al) * q1 - al * st.q
            Q = generalized_forces(system, q1, v1, t1, z)
            # (1/(1+α)) M q̈ + (Φ_qᵀλ − Q)_{n+1} − (α/(1+α)) g_n = 0, scaled by 1/β'
            Rq = (mass_action(system, qm, qdd1) / (1 + al) - Q - al / (1 + al) * st.g) / bp + vjp(mu)[0]
        else:
            Q = generalized_forces(system, q1, v1, t1, z)
            Rq = (mass_action(system, q1, qdd1) - Q) / bp + vjp(mu)[0]
        return jnp.concatenate([Rq, phi])

    # Predictor.
    a_star = (st.qdd - am * a_n) / (1 - am)
    q_star = st.q + h * st.v + h * h * ((0.5 - beta) * a_n + beta * a_star)
    x0 = jnp.concatenate([q_star, st.lam / bp])
    w = _weights(system, st.q, opts)

    n = x0.shape[0]
    nc = n - nq

    def jac_lu(x):
        # Only the nq coordinate columns by forward mode: ∂R/∂μ = [Φ_qᵀ; 0] is the transpose of
        # the constraint block ∂R_Φ/∂q, so the iteration matrix costs nq JVPs, not nq + nc.
        Jq = jax.jacfwd(lambda qq: residual(jnp.concatenate([qq, x[nq:]])))(x[:nq])
        J = jnp.concatenate([Jq, jnp.concatenate([Jq[nq:].T, jnp.zeros((nc, nc))], 0)], 1)
        return lu_factor(J)

    def cond(c):
        x, lu, k, err, prev, conv, bad, r, need = c
        return (~conv) & (~bad) & (k < opts.max_newton)

    def body(c):
        # Modified Newton: the iteration matrix is (re)built only on the first iteration and
        # when the contraction is slow; a single jacfwd site keeps compile time down.
        x, lu, k, err, prev, conv, bad, _, need = c
        if opts.jacobian_refresh:
            lu = jax.lax.cond(need, jac_lu, lambda _: lu, x)
        r = residual(x)
        dx = -lu_solve(lu, r)
        x = x + dx
        e = _wrms(dx[:nq], w)
        phi_ok = jnp.max(jnp.abs(r[nq:])) < opts.phi_tol
        conv = (e < opts.newton_tol) & phi_ok | (e < 1e-3 * opts.newton_tol)
        bad = ~jnp.isfinite(e) | ((k > 2) & (e > 2.0 * prev) & (prev > 0))
        need = (k > 0) & (e > 0.3 * err) & ~conv
        return x, lu, k + 1, e, err, conv, bad, r, need

    if opts.jacobian_refresh:
        lu_init = (jnp.zeros((n, n)), jnp.zeros(n, jnp.int32))
    else:
        lu_init = jac_lu(x0)
    init = (x0, lu_init, jnp.array(0), jnp.array(jnp.inf), jnp.array(0.0), jnp.array(False), jnp.array(False), jnp.zeros(n), jnp.array(opts.jacobian_refresh))
    x, _, iters, _, _, conv, bad, r, _ = jax.lax.while_loop(cond, body, init)
    q1 = x[:nq]
    a1, v1, qdd1 = update(q1)
    lam1 = x[nq:] * bp
    finite = jnp.all(jnp.isfinite(q1)) & jnp.all(jnp.isfinite(v1))
    conv = conv & finite & ~bad
    if integrator.hht:
        e_vec = h * h * integrator.error_coefficient * (qdd1 - st.qdd)
    else:
        e_vec = h * h * integrator.error_coefficient * (a1 - a_n)
    err = _wrms(e_vec, w)
    pw1 = power_terms(system, q1, v1, t1, z)
    wnew = st.w + 0.5 * h * (st.pw + pw1)
    if integrator.hht:
        _, vjp1 = jax.vjp(lambda qq: constraints(system, qq, t1), q1)
        g1 = vjp1(lam1)[0] - generalized_forces(system, q1, v1, t1, z)
    else:
        g1 = st.g
    new = StepState(t1, q1, v1, a1, qdd1, lam1, h, wnew, pw1, z, g1)
    worst = jnp.argmax(jnp.abs(jnp.where(jnp.isfinite(r), r, jnp.inf)))
    worst = jnp.where(conv, jnp.argmax(jnp.abs(e_vec / w)), worst)
    return new, err, iters, conv, worst
