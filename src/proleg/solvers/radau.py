"""Radau IIA (3 stages, order 5) for the constrained equations of motion, index-2 (GGL) form.

The equations of motion of any coordinate set (assembly/coordinates.py: absolute, planar, joint
with loop rows; Euler-parameter normalization rows are constraint rows like any other) are
integrated in the stabilised index-2 formulation of Gear, Gupta & Leimkuhler (1985):

    q̇ = v − Φ_qᵀ μ,     M(q) v̇ = Q(q, v, t) − Φ_qᵀ λ,     0 = Φ(q, t),     0 = Φ_q v + Φ_t

μ vanishes on the exact solution; it keeps q on Φ = 0 while v satisfies the velocity
constraint, so neither drifts (the index-1 form of solvers/ode.py drifts by the integration
error). The differential variables are y = (q, v), the algebraic ones (μ, λ).

Method (Hairer & Wanner, *Solving ODEs II*, §IV.8 and §VII.4; the structure of Hairer's
RADAU5 code, re-derived here): collocation at c = ((4 − √6)/10, (4 + √6)/10, 1). With stage
increments Z_i = Y_i − y_n and h·(derivatives) = A⁻¹ Z, the residual of stage i is (rows
scaled by h, algebraic unknowns U = hμ, L = hλ, so that the Newton matrix stays O(1) as h → 0)

    (A⁻¹Z_q)_i − h V_i + Φ_q(Q_i)ᵀ U_i,   M(Q_i)(A⁻¹Z_v)_i − h Q(Q_i, V_i, t_i) + Φ_q(Q_i)ᵀ L_i,
    −Φ(Q_i, t_i),   −(Φ_q V_i + Φ_t)(Q_i, t_i)

solved by simplified Newton with the matrix frozen per step, K = A⁻¹ ⊗ E + I ⊗ G, where
E = diag(I, M(q_n), 0, 0) and G is the Jacobian of the non-derivative part at the step start
(including ∂(M(q) h a_n)/∂q). ``linear_solver="eigen"`` (default) factors K as Hairer does
through the eigen-decomposition T⁻¹A⁻¹T = [[γ, 0, 0], [0, α, −β], [0, β, α]]: one real LU of
γE + G and one complex LU of (α + iβ)E + G, both N × N (N = 2 nq + 2 nc), instead of one
3N × 3N LU ("dense", ~5× the flops; kept for comparison, bench/README.md).

Error estimate (RADAU5): err = (γE + G)⁻¹ [E Σ d_i Z_i − g(y_n)], d = (−(13 + 7√6)/3,
(−13 + 7√6)/3, −1/3), the difference to an embedded order-3 solution filtered by the stiff
solve; when it fails on the first step or right after a rejection, it is recomputed with g at
y_n + err (Hairer's second filter). The norm is the RMS of err_i / (atol + rtol max(|y_n,i|,
|y_n+1,i|)) over positions AND velocities; λ and μ (index-2 variables) are left out (RADAU5
includes index-2 variables with their weights scaled by 1/h; here they enter only the Newton
norm, h-scaled). Steps: Hairer's rule h_new = h / max(1/8, min(5, err^¼ / fac))
with fac = min(0.9, 0.9 (1 + 2 k_max)/(k + 2 k_max)) (k Newton iterations), and Gustafsson's
predictive (PI) controller on accepted steps (Hairer & Wanner II, §IV.8, eq. (8.21)). No
increase right after a rejection; a Newton failure halves h.

Newton stops when θ/(1 − θ) ‖ΔW‖ ≤ κ (RMS over positions, velocities and the h-scaled
multipliers hμ, hλ in the weights atol + rtol |·| — Hairer's h-scaling of index-2 variables;
θ the contraction rate, κ = max(10 ε / rtol, min(0.03, √rtol))), is abandoned when θ ≥ 0.99 or
after ``max_newton`` iterations. Started from the previous step's collocation polynomial.

Order: on index-2 Hessenberg systems Radau IIA keeps order 2s − 1 = 5 in the differential
variables (q, v) and order s = 3 in the algebraic ones (λ, μ) (Hairer, Lubich & Roche 1989).
The local error estimate is O(h⁴) while the local error is O(h⁶), so the global error falls
faster than rtol (about rtol^(5/4)); Hairer's code compensates by replacing rtol by
0.1 rtol^(2/3), which we do not: rtol 1e-8 then means an error of that order or below.

Outputs come from the collocation polynomial of the step that contains them (the continuous
extension, order 3 between step points, exact at the step points), so asking for many costs
little. Steps land exactly on controller sample times, motion-law breakpoints and t_end.

Choosing values
---------------
``rtol`` = 1e-8, ``atol`` = 1e-9 (defaults, as the Diffrax integrators): error control on
positions [m, rad, Euler parameters] and velocities. ``max_newton`` = 7 (RADAU5's default).
``dt_init`` default: 1e-4 of the run, at most dt_max; a first step that fails is cut 10×.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import jax
import jax.numpy as jnp
import numpy as np
from jax.scipy.linalg import lu_factor, lu_solve

from ..errors import ModelError, Status
from .base import AbstractIntegrator, RunRequest, Solution, absolute_outputs, output_grid
from .initial import mass_matrix

_S6 = math.sqrt(6.0)
C = np.array([(4.0 - _S6) / 10.0, (4.0 + _S6) / 10.0, 1.0])
A = np.array([
    [(88.0 - 7.0 * _S6) / 360.0, (296.0 - 169.0 * _S6) / 1800.0, (-2.0 + 3.0 * _S6) / 225.0],
    [(296.0 + 169.0 * _S6) / 1800.0, (88.0 + 7.0 * _S6) / 360.0, (-2.0 - 3.0 * _S6) / 225.0],
    [(16.0 - _S6) / 36.0, (16.0 + _S6) / 36.0, 1.0 / 9.0],
])
AINV = np.linalg.inv(A)
DD = np.array([-(13.0 + 7.0 * _S6) / 3.0, (-13.0 + 7.0 * _S6) / 3.0, -1.0 / 3.0])


def _eigen_transform():
    """T with T⁻¹ A⁻¹ T = [[γ, 0, 0], [0, α, −β], [0, β, α]] (real γ ≈ 3.6378, α ± iβ)."""
    w, V = np.linalg.eig(AINV)
    kr = int(np.argmin(np.abs(w.imag)))
    kc = int(np.argmax(w.imag))
    gamma, alpha, beta = w[kr].real, w[kc].real, w[kc].imag
    T = np.stack([V[:, kr].real, V[:, kc].real, -V[:, kc].imag], 1)
    lam = np.array([[gamma, 0.0, 0.0], [0.0, alpha, -beta], [0.0, beta, alpha]])
    assert np.allclose(np.linalg.solve(T, AINV @ T), lam, atol=1e-12)
    return gamma, alpha, beta, T, np.linalg.inv(T)


GAMMA, ALPHA, BETA, T, TINV = _eigen_transform()


def _lagrange(s):
    """Weights of Z_1..Z_3 in the collocation polynomial u(s) (u(0) = 0, u(c_i) = Z_i), s = (t − t_n)/h."""
    out = []
    for j in range(3):
        num, den = s, C[j]
        for k in range(3):
            if k != j:
                num = num * (s - C[k])
                den = den * (C[j] - C[k])
        out.append(num / den)
    return jnp.stack(out)


@dataclass(frozen=True)
class Radau5(AbstractIntegrator):
    """Radau IIA, order 5, on the index-2 (GGL) constrained equations of motion (``simulate(integrator=...)``).

    Runs in the coordinates ``simulate(coordinates=...)`` picks (absolute, planar or joint
    coordinates with loop-closure rows); the constraints hold to the Newton tolerance at every
    step. See the module docstring for the method, its error estimate and controller.

    Parameters
    ----------
    rtol, atol : float, relative and absolute local error tolerance on every position and
        velocity coordinate ([m, rad, 1] and [m/s, rad/s, 1/s])
    dt_init : float [s], optional — first step (default 1e-4 of the run, at most dt_max)
    dt_min : float [s], default 1e-14 — smallest step before the run stops with a status
    dt_max : float [s], optional — largest step (default: the run)
    max_steps : int, step budget of one run (accepted and rejected)
    max_newton : int, default 7 — simplified-Newton iterations per step before h is halved
    linear_solver : "eigen" (default; Hairer's real + complex N × N factorizations) or "dense"
        (one 3N × 3N LU)
    fixed_step : float [s], optional — constant steps without error control (convergence
        studies); the run stops with a status if Newton fails
    """

    rtol: float = 1e-8
    atol: float = 1e-9
    dt_init: float | None = None
    dt_min: float = 1e-14
    dt_max: float | None = None
    max_steps: int = 200_000
    max_newton: int = 7
    linear_solver: str = "eigen"
    fixed_step: float | None = None
    coordinates = "any"
    constraints = True
    stiff = True
    order = 5

    def __post_init__(self):
        name = type(self).__name__
        for key in ("rtol", "atol"):
            v = getattr(self, key)
            if isinstance(v, jax.core.Tracer):
                continue
            if not (isinstance(v, (int, float, np.floating)) and math.isfinite(v) and v > 0):
                raise ModelError(f"{name} {key} must be a finite number > 0, got {v!r}. Give e.g. {name}(rtol=1e-8, atol=1e-9).")
        for key in ("dt_init", "dt_max", "dt_min", "fixed_step"):
            v = getattr(self, key)
            if v is not None and not (math.isfinite(v) and v > 0):
                raise ModelError(f"{name} {key} must be a positive time [s] or None, got {v!r}.")
        if not (isinstance(self.max_newton, int) and self.max_newton >= 2):
            raise ModelError(f"{name} max_newton must be an integer ≥ 2, got {self.max_newton!r} (RADAU5 uses 7).")
        if not (isinstance(self.max_steps, int) and self.max_steps >= 1):
            raise ModelError(f"{name} max_steps must be a positive integer, got {self.max_steps!r}.")
        if self.linear_solver not in ("eigen", "dense"):
            raise ModelError(f"{name} linear_solver must be 'eigen' or 'dense', got {self.linear_solver!r}.")

    @property
    def static(self):
        """The integrator with its tolerances (and fixed step, passed as the first step) replaced by
        1: the hashable, compile-time part."""
        return dataclasses.replace(self, rtol=1.0, atol=1.0, fixed_step=None if self.fixed_step is None else 1.0)

    @property
    def tol(self):
        return jnp.asarray(self.rtol, jnp.float64), jnp.asarray(self.atol, jnp.float64)

    def run(self, system, request: RunRequest) -> Solution:
        """The index-2 equations of ``system`` in ``request.coordinates`` (:func:`run_radau`)."""
        return run_radau(self, system, request)


class _Equations:
    """The GGL residual pieces of a coordinate set ``dyn`` with controller state ``z`` held."""

    def __init__(self, dyn, z):
        self.dyn, self.z, self.nq, self.nc = dyn, z, dyn.nq, dyn.nc

    def split(self, y):
        nq, nc = self.nq, self.nc
        return y[..., :nq], y[..., nq : 2 * nq], y[..., 2 * nq : 2 * nq + nc], y[..., 2 * nq + nc :]

    def g(self, q, v, U, L, t, h):
        """The non-derivative part of a stage residual (see the module docstring), (N,)."""
        dyn = self.dyn
        Q = -h * dyn.generalized_forces(q, v, t, self.z)
        if not self.nc:
            return jnp.concatenate([-h * v, Q])
        # one linearisation of Φ at (q, t) serves Φ_qᵀU and Φ_qᵀL (a vjp per product built it twice)
        phi, pull = jax.vjp(lambda qq: dyn.constraints(qq, t), q)
        _, phid = jax.jvp(lambda qq, tt: dyn.constraints(qq, tt), (q, t), (v, jnp.ones_like(t)))
        return jnp.concatenate([-h * v + pull(U)[0], Q + pull(L)[0], -phi, -phid])

    def residual(self, W, q, v, t, h):
        """Stage residuals (3, N) of unknowns W = (Z_q, Z_v, U, L) per stage."""
        Zq, Zv, U, L = self.split(W)
        Dq, Dv = jnp.asarray(AINV) @ Zq, jnp.asarray(AINV) @ Zv
        ts = t + jnp.asarray(C) * h

        def one(zq, zv, u, lam, ti, dq, dv):
            Qi, Vi = q + zq, v + zv
            r = self.g(Qi, Vi, u, lam, ti, h)
            return r.at[: 2 * self.nq].add(jnp.concatenate([dq, self.dyn.mass_action(Qi, dv)]))

        return jax.vmap(one)(Zq, Zv, U, L, ts, Dq, Dv)


def _factor(cfg, E, G):
    """Factorizations of the Newton matrix and of γE + G (error estimate)."""
    lu1 = lu_factor(GAMMA * E + G)
    if cfg.linear_solver == "dense":
        K = jnp.kron(jnp.asarray(AINV), E) + jnp.kron(jnp.eye(3), G)
        return lu1, lu_factor(K)
    return lu1, lu_factor((ALPHA + 1j * BETA) * E.astype(jnp.complex128) + G.astype(jnp.complex128))


def _newton_solve(cfg, facs, r):
    """ΔW with K ΔW = −r, r (3, N)."""
    lu1, lu2 = facs
    if cfg.linear_solver == "dense":
        return -lu_solve(lu2, r.reshape(-1)).reshape(r.shape)
    rt = jnp.asarray(TINV) @ r
    x1 = lu_solve(lu1, rt[0])
    x23 = lu_solve(lu2, rt[1] + 1j * rt[2])
    return -(jnp.asarray(T) @ jnp.stack([x1, x23.real, x23.imag]))


def _rms(x):
    return jnp.sqrt(jnp.mean(x * x))


def integrate(cfg: Radau5, dyn, sample, q, v, lam, a, z, w, times, stops, is_tick, tol, h0, dt_max):
    """Integrate from (times[0], q, v) to stops[-1]; outputs at ``times`` by the collocation
    polynomial. ``sample(t, q, v, z)`` updates the controllers at the stops flagged ``is_tick``.

    Returns (qs, vs, ws, zs, stats (accepted, rejected, Newton iterations, factorizations), status, t)."""
    rtol, atol = tol
    nq, nc = dyn.nq, dyn.nc
    N = 2 * nq + 2 * nc
    nd = 2 * nq
    n_out = times.shape[0]
    f64 = q.dtype
    fnewt = jnp.maximum(10.0 * jnp.finfo(f64).eps / rtol, jnp.minimum(0.03, jnp.sqrt(rtol)))
    safe, facl, facr = 0.9, 5.0, 1.0 / 8.0
    kmax = cfg.max_newton
    t_end = stops[-1]

    bufs = (
        jnp.zeros((n_out, nq), f64).at[0].set(q), jnp.zeros((n_out, nq), f64).at[0].set(v),
        jnp.zeros((n_out,) + w.shape, f64).at[0].set(w), jnp.zeros((n_out,) + z.shape, z.dtype).at[0].set(z),
    )
    carry0 = dict(
        t=times[0], q=q, v=v, mu=jnp.zeros(nc, f64), lam=lam, a=a, z=z, w=w, h=h0,
        Zprev=jnp.zeros((3, nd), f64), h_old=h0, have_prev=jnp.asarray(False),
        first=jnp.asarray(True), rejected=jnp.asarray(False), eta=jnp.asarray(1.0, f64),
        h_acc=h0, err_acc=jnp.asarray(1e-2, f64), si=jnp.asarray(0), oi=jnp.asarray(1),
        stats=jnp.zeros(4, jnp.int32), status=jnp.asarray(0),
    )

    def cond(cb):
        c = cb[0]
        return (c["si"] < stops.shape[0]) & (c["status"] == 0)

    def body(cb):
        c, bufs = cb
        t, qn, vn, z = c["t"], c["q"], c["v"], c["z"]
        eqs = _Equations(dyn, z)
        t_stop = stops[jnp.minimum(c["si"], stops.shape[0] - 1)]
        hit = t + 1.0001 * c["h"] >= t_stop
        h = jnp.where(hit, t_stop - t, c["h"])
        yn_d = jnp.concatenate([qn, vn])
        # Newton matrix at the step start.
        Mn = mass_matrix(dyn, qn)
        E = jnp.zeros((N, N), f64).at[:nq, :nq].set(jnp.eye(nq, dtype=f64)).at[nq:nd, nq:nd].set(Mn)
        yn = jnp.concatenate([qn, vn, h * c["mu"], h * c["lam"]])
        scal = atol + rtol * jnp.abs(yn)  # Newton norm: q, v and the h-scaled μ, λ (Hairer's index-2 scaling)

        def gfull(y):
            qq, vv, U, L = eqs.split(y)
            return eqs.g(qq, vv, U, L, t, h).at[nq:nd].add(h * dyn.mass_action(qq, c["a"]))

        G = jax.jacfwd(gfull)(yn)
        facs = _factor(cfg, E, G)
        # Predictor: the previous collocation polynomial extrapolated (Hairer's STARTN = 0).
        s = 1.0 + jnp.asarray(C) * h / c["h_old"]
        P = jax.vmap(_lagrange)(s)  # (3 new stages, 3 old)
        Zd = jnp.where(c["have_prev"], P @ c["Zprev"] - c["Zprev"][2], 0.0)
        W0 = jnp.concatenate([Zd, jnp.broadcast_to(jnp.concatenate([h * c["mu"], h * c["lam"]]), (3, 2 * nc))], 1)
        eta0 = jnp.maximum(c["eta"], jnp.finfo(f64).eps) ** 0.8

        def ncond(s_):
            k, _, _, _, _, done, fail = s_
            return (~done) & (~fail) & (k < kmax)

        def nbody(s_):
            k, W, dyno_old, thq_old, eta, _, _ = s_
            dW = _newton_solve(cfg, facs, eqs.residual(W, qn, vn, t, h))
            dyno = _rms(dW / scal)
            thq = dyno / jnp.maximum(dyno_old, 1e-300)
            theta = jnp.where(k > 1, jnp.sqrt(thq * thq_old), thq)  # RADAU5's contraction estimate
            fail = ((k > 0) & (theta >= 0.99)) | ~jnp.isfinite(dyno)
            eta = jnp.where(k > 0, theta / (1.0 - jnp.minimum(theta, 0.99)), eta)
            W = W + dW
            done = (eta * dyno <= fnewt) | (dyno == 0.0)
            return k + 1, W, dyno, thq, eta, done & ~fail, fail

        k, W, _, _, eta, conv, _ = jax.lax.while_loop(
            ncond, nbody, (jnp.asarray(0), W0, jnp.asarray(1.0, f64), jnp.asarray(1.0, f64), eta0, jnp.asarray(False), jnp.asarray(False))
        )
        Zq, Zv, U, L = eqs.split(W)
        q1, v1 = qn + Zq[2], vn + Zv[2]
        # Error estimate on (q, v).
        zdd = jnp.asarray(DD) @ W[:, :nd]
        ez = jnp.concatenate([zdd[:nq], Mn @ zdd[nq:], jnp.zeros(2 * nc, f64)])
        lu1 = facs[0]
        err_v = lu_solve(lu1, ez - gfull_plain(eqs, yn, t, h))
        scal_e = atol + rtol * jnp.maximum(jnp.abs(yn_d), jnp.abs(jnp.concatenate([q1, v1])))
        err = _rms(err_v[:nd] / scal_e)
        err_v2 = lu_solve(lu1, ez - gfull_plain(eqs, yn + err_v, t, h))
        err = jnp.where((err >= 1.0) & (c["first"] | c["rejected"]), _rms(err_v2[:nd] / scal_e), err)
        err = jnp.maximum(jnp.where(jnp.isfinite(err), err, jnp.inf), 1e-10)
        # Step size (Hairer's RADAU5 rule, Gustafsson's predictive controller on acceptance).
        fac = jnp.minimum(safe, safe * (1 + 2 * kmax) / (k + 2 * kmax))
        quot = jnp.clip(err**0.25 / fac, facr, facl)
        facgus = jnp.clip(c["h_acc"] / h * (err * err / c["err_acc"]) ** 0.25 / safe, facr, facl)
        accept = conv & ((err < 1.0) | (cfg.fixed_step is not None)) & jnp.all(jnp.isfinite(W))
        quot_acc = jnp.where(c["first"], quot, jnp.maximum(quot, facgus))
        h_new_acc = h / quot_acc
        h_new_acc = jnp.where(c["rejected"], jnp.minimum(h_new_acc, h), h_new_acc)
        h_new_rej = jnp.where(~conv, 0.5 * h, jnp.where(c["first"], 0.1 * h, h / quot))
        h_new = jnp.minimum(jnp.where(accept, h_new_acc, h_new_rej), dt_max)
        if cfg.fixed_step is not None:  # constant steps (order studies): a Newton failure stops the run
            h_new = jnp.where(accept, c["h"], 0.0)
        # Accepted: powers by the same quadrature, outputs by the collocation polynomial.
        ts = t + jnp.asarray(C) * h
        pw = jax.vmap(lambda zq, zv, ti: dyn.power_terms(qn + zq, vn + zv, ti, z))(Zq, Zv, ts)
        Zw = h * (jnp.asarray(A) @ pw)
        t1 = jnp.where(hit, t_stop, t + h)
        tick = hit & is_tick[jnp.minimum(c["si"], stops.shape[0] - 1)]
        z1 = jnp.where(tick, sample(t1, q1, v1, z), z)

        def ocond(o):
            oi, _ = o
            return accept & (oi < n_out) & (times[jnp.minimum(oi, n_out - 1)] <= t1 + 1e-12 * jnp.maximum(1.0, jnp.abs(t1)))

        def obody(o):
            oi, (bq, bv, bw, bz) = o
            to = times[oi]
            lw = _lagrange(jnp.clip((to - t) / h, 0.0, 1.0))
            zo = jnp.where(to >= t1 - 1e-12 * jnp.maximum(1.0, jnp.abs(t1)), z1, z)
            return oi + 1, (bq.at[oi].set(qn + lw @ Zq), bv.at[oi].set(vn + lw @ Zv), bw.at[oi].set(c["w"] + lw @ Zw), bz.at[oi].set(zo))

        oi1, bufs = jax.lax.while_loop(ocond, obody, (c["oi"], bufs))
        n_fail = ~accept & (h_new < cfg.dt_min)
        status = jnp.where(n_fail, jnp.where(conv, int(Status.STEP_TOO_SMALL), int(Status.NEWTON_FAILED)), 0)
        steps = c["stats"][0] + c["stats"][1] + 1
        status = jnp.where((status == 0) & (steps >= cfg.max_steps) & ~(accept & hit & (c["si"] + 1 >= stops.shape[0])), int(Status.MAX_STEPS), status)
        status = jnp.where(accept & ~jnp.all(jnp.isfinite(q1)), int(Status.NONFINITE), status)
        new = dict(
            t=t1, q=q1, v=v1, mu=U[2] / h, lam=L[2] / h, a=jnp.asarray(AINV)[2] @ Zv / h, z=z1, w=c["w"] + Zw[2], h=h_new,
            Zprev=W[:, :nd], h_old=h, have_prev=~tick, first=tick, rejected=jnp.asarray(False), eta=eta,
            h_acc=h, err_acc=jnp.maximum(1e-2, err), si=c["si"] + hit.astype(c["si"].dtype), oi=oi1,
            stats=c["stats"] + jnp.array([1, 0, 0, 0], jnp.int32), status=status,
        )
        rej = dict(c, h=h_new, rejected=jnp.asarray(True), stats=c["stats"] + jnp.array([0, 1, 0, 0], jnp.int32), status=status)
        out = jax.tree_util.tree_map(lambda x_, y_: jnp.where(accept, x_, y_), new, rej)
        return dict(out, stats=out["stats"] + jnp.stack([0, 0, k, 1]).astype(jnp.int32)), bufs

    c, bufs = jax.lax.while_loop(cond, body, (carry0, bufs))
    return (*bufs, c["stats"], c["status"], c["t"])


def gfull_plain(eqs, y, t, h):
    """g at the (scaled) point y = (q, v, hμ, hλ)."""
    q, v, U, L = eqs.split(y)
    return eqs.g(q, v, U, L, t, h)


def _run(cfg, dyn, q, v, lam, a, z, times, stops, is_tick, tol, h0, dt_max):
    from .initial import sample_state

    def sample(t, x, xd, zz):
        return sample_state(dyn, t, x, xd, zz)

    w = jnp.zeros(2, q.dtype)
    return integrate(cfg, dyn, sample, q, v, lam, a, z, w, times, stops, is_tick, tol, h0, dt_max)


def _reduce(dyn, q, v, qdd, lam):
    """The consistent absolute start (q, v, q̈, λ) in the coordinates ``dyn``."""
    x, xd = dyn.reduce(q, v)
    return x, xd, dyn.reduce_acceleration(x, xd, qdd, q), dyn.reduce_multipliers(lam)


_JITS = {}


def run_radau(ig: Radau5, system, request: RunRequest) -> Solution:
    """Integrate ``system`` with Radau5 in ``request.coordinates``: the consistent start reduced to
    the coordinate set, one compiled loop of Radau IIA steps that land on controller sample
    times (each tick updates the controller state), motion-law breakpoints and the last output;
    outputs from the steps' collocation polynomials."""
    from ..assembly.coordinates import coordinate_set
    from .initial import _consistent_state, initial_z, sample_period

    if not _JITS:
        from ..compile_cache import cached_jit  # on disk: a new process skips the trace

        _JITS["run"] = cached_jit(_run, xla="loop", static_argnums=(0,))
        _JITS["reduce"] = cached_jit(_reduce)
    t0 = float(request.t0)
    times = output_grid(t0, request.times)
    q, v, qdd, lam, z0, _ = _consistent_state(system, request.q0, request.v0, t0, initial_z(system))
    q_ic, v_ic = q, v
    dyn = coordinate_set(system, q, request.coordinates)
    if dyn.kind != "absolute":
        q, v, qdd, lam = _JITS["reduce"](dyn, q, v, qdd, lam)
    t1 = float(times[-1])
    Ts = sample_period(system)
    ticks = t0 + Ts * np.arange(1, int(math.floor((t1 - t0) / Ts + 1e-9)) + 1) if Ts else np.zeros(0)
    bps = np.array([b for b in request.breakpoints if t0 < b < t1])
    stops = np.unique(np.concatenate([ticks[ticks < t1 - 1e-12], bps, [t1]]).round(12))
    is_tick = np.isin(stops, ticks.round(12))
    dt_max = ig.dt_max if ig.dt_max is not None else t1 - t0
    h0 = ig.dt_init if ig.dt_init is not None else min(1e-4 * (t1 - t0), dt_max)
    h0 = ig.fixed_step if ig.fixed_step is not None else h0
    f64 = jnp.float64
    qs, vs, ws, zs, st, stat, t_reached = _JITS["run"](
        ig.static, dyn, q, v, lam, qdd, z0, jnp.asarray(times), jnp.asarray(stops), jnp.asarray(is_tick), ig.tol,
        jnp.asarray(h0, f64), jnp.asarray(dt_max, f64),
    )
    traced = isinstance(stat, jax.core.Tracer)
    if dyn.kind != "absolute":
        qs, vs = absolute_outputs(dyn, qs, vs)
    status, msg = Status.SUCCESS, "success"
    keep = len(times)
    if not traced and int(stat) != 0:
        status = Status(int(stat))
        keep = int(np.searchsorted(times, float(t_reached), side="right"))
        msg = f"Radau5 on '{system.topo.name}': {status.describe()} at t = {float(t_reached):.6g} s (rtol {ig.rtol:g})."
    stats = np.zeros(4, int) if traced else np.asarray(st).astype(int)
    sol = Solution(times[:keep], qs[:keep], vs[:keep], ws[:keep], zs[:keep], stats, status, msg, dyn.kind, start=(q_ic, v_ic))
    if traced:
        sol.traced_status = (stat, t_reached, st)
    return sol
