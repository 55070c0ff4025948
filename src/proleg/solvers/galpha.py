"""Generalized-α (Arnold & Brüls 2007) and HHT-I3 (Negrut et al. 2007) on the index-3 DAE.

    M(q) q̈ + Φ_qᵀ λ = Q(q, q̇, t),   Φ(q, t) = 0

following ../shared/notes/formulation.md §4: Newton on x = (q_{n+1}, μ = λ/β') with the scaled
residual R_q = (1/β')[M q̈ − Q] + Φ_qᵀμ, R_Φ = Φ, the local error estimate
e = h²(β − γ/2 + 1/12)(a_{n+1} − a_n) and the rescaling of a_n whenever h changes.

Newton matrix (modified Newton, as in Adams): [[M − (K + γ/(βh) C)/β', Φ_qᵀ], [Φ_q, 0]] with
K = ∂Q/∂q, C = ∂Q/∂v, by forward-mode autodiff compressed by the column colouring of
assembly/sparsity.py (one JVP per colour). The geometric terms ∂(M q̈)/∂q/β' and ∂(Φ_qᵀμ)/∂q
are left out: they are O(h²) and only slow the contraction, never change the solution. By
default the matrix is rebuilt every step; with ``StepOptions(jacobian_reuse=True)`` its
LU factors are kept across steps and rebuilt only when Newton contracts slowly, fails, or h has
moved by more than a factor ``jacobian_h_ratio`` since it was built (bench/README.md).

Velocity error (``error_on="positions+velocities"``)
----------------------------------------------------
On q̈ = f the α-method's accelerations satisfy a_n = q̈(t_n + δ₁h) + δ₂h²q⁗ + O(h³) with
δ₁ = α_m − α_f, δ₂ = (1 − α_f)/2 − (1 − α_m)(1/2 + δ₁) (Arnold & Brüls 2007, Sec. 3; HHT is
α_m = 0, α_f = −α). Taylor expansion of v_{n+1} = v_n + h[(1 − γ)a_n + γa_{n+1}] gives the
local velocity error v(t+h) − v_{n+1} = C_v h³ q⁗ + O(h⁴), C_v = 1/6 − δ₂ − γ/2 − γδ₁ (the h²
term vanishes for γ = 1/2 − δ₁); ρ∞ = 0.8: C_v = −29/324, HHT α = −0.05: −0.106. The same order
h³ as the position error, whose estimate is C h²(a_{n+1} − a_n) ≈ C h³q⃛. q⁗ is estimated by the
divided difference of the jerks j = (a_{n+1} − a_n)/h of this step and the last accepted one,
q⁗ ≈ 2(j_{n+1} − j_n)/(h_n + h_{n+1}), in the weights rtol·|v| + atol/T (T =
``velocity_time_scale``, AbstractAlphaIntegrator); the error norm is the larger of the two weighted
RMS norms. There is no velocity term on the first step after a start or a restart
(controller sample, motion breakpoint: the accelerations jump there and the history is reset).
With constraints (index 3) the estimate is projected onto Φ_q e = 0 with the step's Newton
matrix: the index-3 accelerations carry a transient along M⁻¹Φ_qᵀ (the multipliers' oscillation
after each change of h, Arnold & Brüls Sec. 4) that does not scale with h and, unprojected,
drives the step to dt_min (measured on the double pendulum in planar coordinates).
Measured (bench/galpha_error.py, bench/README.md): energy error 5–20× smaller at the same
rtol for ~2–2.7× the steps, and smaller for equal steps; the slope stays ~0.7 decade per
decade of rtol, as for any O(h³) local-error control of a second-order method (h ∝ tol^(1/3),
global error ∝ h² ∝ tol^(2/3)). Off by default.

Choosing values
---------------
``rho_inf`` (spectral radius at infinite frequency) in [0.5, 0.95]: 0.8 (default) damps
spurious high-frequency modes (stiff bushings, contact) while adding ~1e-6 relative energy loss
per second on a 1e-4 s step; never 1 (index-3 trapezoidal rule is unstable, note §4).
HHT: ``alpha`` in [−1/3, 0], ρ∞ = (1 + α)/(1 − α); M is evaluated at q_{n+1+α} to keep order 2.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from typing import NamedTuple

import jax
import jax.numpy as jnp
from jax.scipy.linalg import solve_triangular

from ..assembly.coordinates import Absolute
from .base import AbstractIntegrator
from .batching import any_lane


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
    Jfac: tuple  # LU factors of the Newton matrix and the row permutation ((n, n), (n,) int)
    jac_h: jnp.ndarray  # step it was built for (0: none yet)
    jac_ok: jnp.ndarray  # bool: fit for reuse on the next step
    jac_hold: jnp.ndarray  # int: steps left that take a fresh matrix (after a failed reuse)
    jac_pen: jnp.ndarray  # int: current hold length (doubles on each failed reuse, up to 64)
    jerk: jnp.ndarray  # (a_{n+1} − a_n)/h of the last accepted step (velocity error estimate)
    jerk_h: jnp.ndarray  # its step [s]; 0: none (start, restart) — no velocity term on the next step


@dataclass(frozen=True, kw_only=True)
class AbstractAlphaIntegrator(AbstractIntegrator):
    """The α-methods (generalized-α, HHT) on the index-3 equations, and the options they carry
    (Diffrax style: the solver object holds its settings). Any coordinates, constraints held
    exactly, numerically damped (stiff elements), robust on contact and impacts: the run is the
    compiled loop of solvers/driver.py (:func:`proleg.solvers.driver.run_alpha`).

    Parameters
    ----------
    rtol, atol : relative and absolute local error tolerances; atol in [m] for translations
        (and the modal coordinates of flexible bodies). Defaults 1e-6, 1e-7.
    atol_p : absolute tolerance of the Euler parameters [-]; default ``atol``
    dt_init : first step [s]; default min(1e-4, dt_max) (or ``fixed_step``)
    dt_min : smallest step [s] before the run stops with STEP_TOO_SMALL (default 1e-10)
    dt_max : largest step [s]; default min(t_end − t0, 1e-2). Not tied to the output times
        (outputs come from the dense output of the steps, solvers/driver.py).
    fixed_step : float [s], optional — fixed steps, no error control (steps still land on
        controller samples and motion breakpoints)
    max_newton : Newton iterations per step attempt (default 10)
    jacobian_reuse : keep the Newton matrix across steps (modified Newton, as in Adams): fewer
        matrix builds, linear convergence (:class:`StepOptions`). Under ``jax.vmap`` the
        rebuild decisions are batch-wide (solvers/batching.py).
    lu_per_lane : under ``jax.vmap``, one LAPACK LU call per variant instead of jaxlib's batched
        LU, which can deadlock when two batches run at once in threads (:class:`StepOptions`;
        :func:`proleg.sweep` sets it for its workers)
    error_on : "positions" (default) or "positions+velocities" — what the local error estimate
        covers (module docstring, "Velocity error").
    velocity_time_scale : float [s], default 0.1 — T in the velocity tolerance
        rtol·|v| + atol/T (and atol_p/T for Euler-parameter rates): a velocity error δv held
        over T moves a position by δv·T, so atol/T is the velocity error that costs atol in
        position over T. 0.1 s is the time scale of legged-robot motions (a touchdown lasts
        10–50 ms, a stride 0.3 s); with rtol·|v| dominating (moving parts) it does not matter.
    """

    rtol: float = 1e-6
    atol: float = 1e-7
    atol_p: float | None = None
    dt_init: float | None = None
    dt_min: float = 1e-10
    dt_max: float | None = None
    fixed_step: float | None = None
    max_newton: int = 10
    jacobian_reuse: bool = False
    lu_per_lane: bool = False
    error_on: str = "positions"
    velocity_time_scale: float = 0.1
    coordinates = "any"
    constraints = True
    stiff = True
    events = True
    order = 2

    def run(self, system, request):
        """The compiled chunk loop of solvers/driver.py over ``request`` (registered there in
        :data:`proleg.solvers.base.RUNNERS`: the driver imports this module, not the reverse)."""
        from .base import RUNNERS

        return RUNNERS["alpha"](self, system, request)

    def step_options(self) -> StepOptions:
        return StepOptions(
            rtol=float(self.rtol), atol=float(self.atol), atol_p=float(self.atol if self.atol_p is None else self.atol_p),
            max_newton=int(self.max_newton), jacobian_reuse=bool(self.jacobian_reuse), lu_per_lane=bool(self.lu_per_lane),
            velocity_error=self.error_on == "positions+velocities", velocity_time_scale=float(self.velocity_time_scale),
        )

    @property
    def method(self):
        """The same method with default options: what the compiled step depends on (the options
        reach it through :class:`StepOptions` and the driver's options)."""
        return type(self)(**{f.name: getattr(self, f.name) for f in fields(self) if f.name not in _OPTION_FIELDS})

    def _check_options(self):
        from ..errors import ModelError

        name = type(self).__name__
        for k in ("rtol", "atol"):
            if not float(getattr(self, k)) > 0:
                raise ModelError(f"{name} {k} must be positive, got {getattr(self, k)}.")
        for k in ("atol_p", "dt_init", "dt_max", "fixed_step"):
            v = getattr(self, k)
            if v is not None and not float(v) > 0:
                raise ModelError(f"{name} {k} must be positive [s or -], got {v}; leave it None for the default.")
        if not int(self.max_newton) >= 1:
            raise ModelError(f"{name} max_newton must be at least 1, got {self.max_newton}.")
        if self.error_on not in ("positions", "positions+velocities"):
            raise ModelError(f"{name} error_on must be 'positions' or 'positions+velocities', got {self.error_on!r}.")
        if not float(self.velocity_time_scale) > 0:
            raise ModelError(f"{name} velocity_time_scale must be positive [s], got {self.velocity_time_scale}.")


@dataclass(frozen=True)
class GeneralizedAlpha(AbstractAlphaIntegrator):
    """Generalized-α, index 3, scaled Newton (default integrator); the options of
    :class:`AbstractAlphaIntegrator` as keywords: ``GeneralizedAlpha(0.8, rtol=1e-8, atol=1e-9)``."""

    rho_inf: float = 0.8

    def __post_init__(self):
        self._check_options()
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

    @property
    def velocity_error_coefficient(self):
        am, af, _, _ = self.coefficients
        return _velocity_error_coefficient(am, af)

    hht = False


@dataclass(frozen=True)
class HHT(AbstractAlphaIntegrator):
    """HHT-I3 (Adams' HHT): α in [−1/3, 0]; the mass matrix is evaluated at q_{n+1+α}. The
    options of :class:`AbstractAlphaIntegrator` as keywords: ``HHT(-0.05, rtol=1e-7)``."""

    alpha: float = -0.05

    def __post_init__(self):
        self._check_options()
        if not (-1.0 / 3.0 <= self.alpha <= 0.0):
            raise ValueError(f"HHT alpha must be in [-1/3, 0], got {self.alpha}.")

    @property
    def coefficients(self):
        a = self.alpha
        return 0.0, 0.0, 0.5 - a, 0.25 * (1 - a) ** 2

    @property
    def error_coefficient(self):
        return 1.0 / 12.0 + self.alpha**2 / 4.0

    @property
    def velocity_error_coefficient(self):
        # HHT is the α-method with α_m = 0, α_f = −α (its accelerations approximate q̈(t + αh)).
        return _velocity_error_coefficient(0.0, -self.alpha)

    hht = True


def _velocity_error_coefficient(am, af):
    """C_v of the velocity update's local error v(t+h) − v_{n+1} = C_v h³ q⁗ + O(h⁴) for the
    α-method family with γ = 1/2 + α_f − α_m (module docstring, "Velocity error"):
    C_v = 1/6 − δ₂ − γ/2 − γ δ₁, δ₁ = α_m − α_f, δ₂ = (1 − α_f)/2 − (1 − α_m)(1/2 + δ₁)."""
    d1 = am - af
    gamma = 0.5 - d1
    d2 = 0.5 * (1.0 - af) - (1.0 - am) * (0.5 + d1)
    return 1.0 / 6.0 - d2 - 0.5 * gamma - gamma * d1


@dataclass(frozen=True)
class StepOptions:
    rtol: float = 1e-6
    atol: float = 1e-7  # translations [m]
    atol_p: float = 1e-7  # Euler parameters [-]
    newton_tol: float = 1e-3  # on the weighted RMS of Δq, in units of the error tolerance
    max_newton: int = 10
    phi_tol: float = 1e-10
    # Keep the Newton matrix across steps (rebuilt when Newton contracts slowly, fails, or h
    # leaves [1/r, r] of the step it was built for; batch-wide under jax.vmap, see batching.py).
    # Faster, but the iteration converges linearly: velocities carry ~1e-12 Newton noise per
    # step, which over 1e5 fixed steps shows in conservation checks at the 1e-6 level (a fresh
    # matrix per step keeps them at 1e-9). Off by default.
    jacobian_reuse: bool = False
    jacobian_h_ratio: float = 3.0  # rebuild when h / h_built leaves [1/r, r]
    reuse_max_iterations: int = 4  # a step that needed more rebuilds the matrix for the next
    # Under jax.vmap: factor each lane's Newton matrix with its own LAPACK call (a loop over the
    # lanes) instead of jaxlib's batched LU. The batched LU spreads its lanes over XLA's
    # intra-op thread pool and waits for them there; two batches running at once from two
    # threads then each hold a pool thread and wait for the other: a deadlock (jaxlib 0.10,
    # 2-core VM, 500 lanes). ``sweep`` sets it when it runs batches concurrently.
    lu_per_lane: bool = False
    velocity_error: bool = False  # error_on="positions+velocities"
    velocity_time_scale: float = 0.1  # [s]: velocity atol = atol / T


_OPTION_FIELDS = frozenset(f.name for f in fields(AbstractAlphaIntegrator))


def _weights(dyn, q, opts: StepOptions):
    return dyn.weights(q, opts.rtol, opts.atol, opts.atol_p)


def _wrms(x, w):
    return jnp.sqrt(jnp.mean((x / w) ** 2))


def lu_factors(J):
    """(LU, permutation) of a square J with partial pivoting.

    On the CPU by :func:`_lu_factors_augmented`; elsewhere (GPU) by the plain square LU, whose
    permutation the GPU computes in one kernel. The augmented matrix is not square, and jaxlib's
    GPU LU batches only square matrices (cuBLAS getrfBatched): under ``jax.vmap`` the augmented
    form became one cuSOLVER call per lane, 37 ms per step for 1,000 lanes on an H100 against
    ~1 ms (bench/README.md). The platform is chosen when the computation is lowered.
    """
    return jax.lax.platform_dependent(J, cpu=_lu_factors_augmented, default=_lu_factors_square)


def _lu_factors_square(J):
    lu, _, perm = jax.lax.linalg.lu(J)
    return lu, perm.astype(jnp.int32)


def _lu_factors_augmented(J):
    """LU without XLA-CPU's sequential pivots-to-permutation loop (one loop iteration per row,
    ~1 µs each on CPU): J is factored with the row numbers appended as an extra column, which
    LAPACK carries through the row swaps and forward elimination as L⁻¹·P·(0..n−1); multiplying
    by L recovers P·(0..n−1)."""
    n = J.shape[0]
    rows = jnp.arange(n, dtype=J.dtype)
    lu_aug, _, _ = jax.lax.linalg.lu(jnp.concatenate([J, rows[:, None]], 1))
    lu = lu_aug[:, :n]
    L = jnp.tril(lu, -1) + jnp.eye(n, dtype=J.dtype)
    perm = jnp.round(L @ lu_aug[:, n]).astype(jnp.int32)
    return lu, perm


@jax.custom_batching.custom_vmap
def lu_factors_per_lane(J):
    """:func:`lu_factors`; under ``jax.vmap`` one LAPACK call per lane (``StepOptions.lu_per_lane``)."""
    return lu_factors(J)


@lu_factors_per_lane.def_vmap
def _lu_factors_per_lane_vmap(axis_size, in_batched, J):
    (batched,) = in_batched
    if not batched:
        return lu_factors(J), (False, False)
    # Lane by lane on the CPU only: the deadlock is XLA-CPU's; a GPU factors the batch at once
    # (one cuSOLVER call per lane there would cost ~37 µs each, see lu_factors).
    per_lane = lambda J: jax.lax.map(lu_factors_per_lane, J)  # noqa: E731
    return jax.lax.platform_dependent(J, cpu=per_lane, default=jax.vmap(_lu_factors_square)), (True, True)


def lu_apply(fac, b):
    """Solve with LU factors and the row permutation (jax.scipy's lu_solve would rebuild the
    permutation from the pivots, a sequential loop, on every call)."""
    lu, perm = fac
    y = solve_triangular(lu, b[perm], lower=True, unit_diagonal=True)
    return solve_triangular(lu, y, lower=False)


def rarely(pred, fn, old, *args):
    """``fn(*args)`` if ``pred`` else ``old``, for work that is usually skipped.

    A ``lax.while_loop`` that runs zero or one time: on XLA-CPU a ``lax.cond`` costs ~50 µs per
    call even when its expensive branch is not taken (bench/README.md), a loop that does not
    run costs almost nothing.
    """

    def body(c):
        return jnp.array(False), fn(*args)

    return jax.lax.while_loop(lambda c: c[0], body, (pred, old))[1]


def iteration_matrix(dyn, q1, v1, t1, z, bp, cv, mfac):
    """Newton matrix [[mfac·M − (K + cv·C)/β', Φ_qᵀ], [Φ_q, 0]] at (q1, v1), colour-compressed.

    ``dyn``: the coordinate set (assembly/coordinates.py; a System means its absolute coordinates).
    """
    dyn = Absolute.of(dyn)
    nq, nc = dyn.nq, dyn.nc
    col = dyn.coloring

    def g(y):
        dq = y[col.color]  # the seed matrix product S @ y as a gather
        if dyn.kind == "joint":
            # mfac·M(q1) dq − Q(q1 + dq, v1 + cv dq)/β' through the inverse dynamics: at y = 0
            # the derivative of M(q1 + dq)(mfac β' dq) is M(q1) mfac β' exactly, and the tree's
            # kinematics are traced once instead of once for M and once for Q.
            Rq = dyn.inverse_dynamics(q1 + dq, v1 + cv * dq, (mfac * bp) * dq, t1, z) / bp
        else:  # (M is cheap and its own in absolute and planar coordinates)
            Rq = mfac * dyn.mass_action(q1, dq) - dyn.generalized_forces(q1 + dq, v1 + cv * dq, t1, z) / bp
        return jnp.concatenate([Rq, dyn.constraints(q1 + dq, t1)])

    Jc = jax.jacfwd(g)(jnp.zeros(col.ncolors, q1.dtype))[:, col.color]
    Jqq = jnp.where(col.mask_q, Jc[:nq], 0.0)
    Pq = jnp.where(col.mask_phi, Jc[nq:], 0.0)
    return jnp.concatenate([jnp.concatenate([Jqq, Pq.T], 1), jnp.concatenate([Pq, jnp.zeros((nc, nc), q1.dtype)], 1)], 0)


def with_power(st: StepState, new: StepState, h, pw1) -> StepState:
    """``new`` (a step of size h from ``st``) with its powers ``pw1`` and the energies
    integrated over the step by the trapezoidal rule."""
    return new._replace(pw=pw1, w=st.w + 0.5 * h * (st.pw + pw1))


def step(dyn, integrator, st: StepState, h, opts: StepOptions, power: bool = True):
    """One step of size h from ``st`` in the coordinates ``dyn`` (assembly/coordinates.py).
    ``power=False``: the new state's powers and energies are left for the caller to fill
    (:func:`with_power`), who evaluates them with other quantities of the same state.

    Returns (new state, error norm, iterations, converged, worst row, failed with a reused
    Newton matrix: retry at the same h, a Newton matrix was built).
    """
    dyn = Absolute.of(dyn)
    nq = dyn.nq
    am, af, gamma, beta = integrator.coefficients
    t1 = st.t + h
    # Rescale the auxiliary acceleration to the new step (note §4).
    a_n = st.qdd + (h / st.h_prev) * (st.a - st.qdd)
    bp = (1 - am) / (h * h * beta * (1 - af))
    cv = gamma / (beta * h)
    mfac = 1.0 / (1.0 + integrator.alpha) if integrator.hht else 1.0
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
        phi, vjp = jax.vjp(lambda qq: dyn.constraints(qq, t1), q1)
        if integrator.hht:
            al = integrator.alpha
            qm = (1 + al) * q1 - al * st.q
            Q = dyn.generalized_forces(q1, v1, t1, z)
            # (1/(1+α)) M q̈ + (Φ_qᵀλ − Q)_{n+1} − (α/(1+α)) g_n = 0, scaled by 1/β'
            Rq = (dyn.mass_action(qm, qdd1) / (1 + al) - Q - al / (1 + al) * st.g) / bp + vjp(mu)[0]
        else:
            # M q̈ − Q in one pass of the coordinate set's kinematics (inverse dynamics)
            Rq = dyn.inverse_dynamics(q1, v1, qdd1, t1, z) / bp + vjp(mu)[0]
        return jnp.concatenate([Rq, phi])

    def fresh_factors(x):
        q1 = x[:nq]
        _, v1, _ = update(q1)
        # The Newton matrix only steers the iteration: no derivative through it (forward-mode
        # sensitivities converge with the iteration itself), so no tangents are carried into it.
        args = jax.lax.stop_gradient((dyn, q1, v1, t1, z, bp, cv))
        return (lu_factors_per_lane if opts.lu_per_lane else lu_factors)(iteration_matrix(*args, mfac))

    # Predictor.
    a_star = (st.qdd - am * a_n) / (1 - am)
    q_star = st.q + h * st.v + h * h * ((0.5 - beta) * a_n + beta * a_star)
    x0 = jnp.concatenate([q_star, st.lam / bp])
    w = _weights(dyn, st.q, opts)
    n = x0.shape[0]
    reuse = opts.jacobian_reuse
    r_h = opts.jacobian_h_ratio

    if reuse:
        ratio = h / jnp.where(st.jac_h > 0, st.jac_h, jnp.inf)
        stale = ~st.jac_ok | (ratio > r_h) | (ratio < 1.0 / r_h) | (st.jac_hold > 0)
        build = any_lane(stale)
        Jfac = rarely(build, fresh_factors, st.Jfac, x0)
        jac_h = jnp.where(build, h, st.jac_h)
        fresh = build
    else:
        Jfac, jac_h, fresh = fresh_factors(x0), h, jnp.array(True)

    def cond(c):
        x, k, err, phi_prev, conv, bad, r = c
        return (~conv) & (~bad) & (k < opts.max_newton)

    def body(c):
        x, k, err, phi_prev, _, _, _ = c
        r = residual(x)
        dx = -lu_apply(Jfac, r)
        x = x + dx
        e = _wrms(dx[:nq], w)
        phi_max = jnp.max(jnp.abs(r[nq:]), initial=0.0)
        # Converged when the correction is small, or (modified Newton, linear contraction
        # ρ = e_k/e_{k−1}) when the remaining error ρ/(1−ρ)·e_k and the constraint residual
        # after this update, ≈ max(ρ, ρ_Φ)·|Φ(x_k)|, are below the tolerances (Hairer & Wanner
        # IV.8), ρ_Φ = |Φ(x_k)|/|Φ(x_{k−1})| being the contraction of the constraint residual.
        rho = jnp.where(k > 0, e / jnp.maximum(err, 1e-300), 1.0)
        rho_phi = jnp.where(k > 0, phi_max / jnp.maximum(phi_prev, 1e-300), 1.0)
        conv_rate = (k > 0) & (rho < 0.9) & (e * rho / (1.0 - rho) < 1e-2 * opts.newton_tol) & (jnp.maximum(rho, rho_phi) * phi_max < opts.phi_tol)
        # A single small correction proves convergence only with a fresh matrix (quadratic
        # convergence); with a reused one the error left after it is ρ·e, unknown until k = 1.
        conv = ((e < opts.newton_tol) & (phi_max < opts.phi_tol) | (e < 1e-3 * opts.newton_tol)) & fresh | conv_rate
        # A reused matrix that contracts slowly is given up at once (the driver retries the
        # step with a fresh one); with a fresh matrix only divergence is a failure.
        bad = ~jnp.isfinite(e) | jnp.where(fresh, (k > 2) & (rho > 2.0), (k > 0) & (rho > 0.5) & (e > opts.newton_tol))
        return x, k + 1, e, phi_max, conv, bad, r

    init = (x0, jnp.array(0), jnp.array(jnp.inf), jnp.array(jnp.inf), jnp.array(False), jnp.array(False), jnp.zeros(n))
    x, iters, e_last, _, conv, bad, r = jax.lax.while_loop(cond, body, init)
    q1 = x[:nq]
    a1, v1, qdd1 = update(q1)
    lam1 = x[nq:] * bp
    finite = jnp.all(jnp.isfinite(q1)) & jnp.all(jnp.isfinite(v1))
    # The rate test estimates |Φ| after the last update; check it (a cheap evaluation) so every
    # accepted state meets the constraints to 5·phi_tol whatever the estimate said.
    phi_ok = jnp.max(jnp.abs(dyn.constraints(q1, t1)), initial=0.0) < 5.0 * opts.phi_tol
    conv = conv & finite & ~bad & phi_ok
    # Reuse the matrix next step unless this one needed many iterations or failed; a failure
    # with a reused matrix is retried at the same h with a fresh one (``stale_fail``).
    jac_ok = conv & (iters <= opts.reuse_max_iterations)
    if reuse:  # (an n² check: skipped when the matrix is rebuilt every step anyway)
        jac_ok = jac_ok & jnp.all(jnp.isfinite(Jfac[0]))
    stale_fail = ~conv & ~fresh
    # Back off from reuse where it keeps failing (stiff, fast-rotating elements): hold fresh
    # matrices for 1, 3, 7, ... 63 steps after each failure; halve the hold after a success.
    if reuse:
        jac_pen = jnp.where(stale_fail, jnp.minimum(2 * st.jac_pen + 1, 63), jnp.where(conv & ~fresh, st.jac_pen // 2, st.jac_pen))
        jac_hold = jnp.where(stale_fail, jac_pen, jnp.maximum(st.jac_hold - conv.astype(st.jac_hold.dtype), 0))
    else:
        jac_pen, jac_hold = st.jac_pen, st.jac_hold
    da = (qdd1 - st.qdd) if integrator.hht else (a1 - a_n)
    e_vec = h * h * integrator.error_coefficient * da
    jerk = da / h  # ≈ q⃛ over the step
    err = _wrms(e_vec, w)
    if opts.velocity_error:
        # Velocity term (module docstring): C_v h³ q⁗, q⁗ from the divided difference of this
        # step's and the last step's jerk; none on the first step after a (re)start.
        d4 = 2.0 * (jerk - st.jerk) / (h + st.jerk_h)
        ev_vec = jnp.where(st.jerk_h > 0, h * h * h * integrator.velocity_error_coefficient * d4, 0.0)
        if dyn.nc:
            # Only the part along the constraints counts: the index-3 scheme's accelerations
            # carry a transient along M⁻¹Φ_qᵀ (the multipliers' ρ∞-decaying oscillation, note
            # §4) that does not scale with h. Removed by the projection with the Newton matrix,
            # e − J⁻¹Φ_qᵀ(Φ_q J⁻¹Φ_qᵀ)⁻¹Φ_q e (one JVP of Φ and two triangular solves).
            dphi = jax.jvp(lambda qq: dyn.constraints(qq, t1), (q1,), (ev_vec,))[1]
            ev_vec = ev_vec - lu_apply(Jfac, jnp.concatenate([jnp.zeros(nq, q1.dtype), dphi]))[:nq]
        wv = dyn.weights(st.q, 0.0, opts.atol, opts.atol_p) / opts.velocity_time_scale + opts.rtol * jnp.abs(st.v)
        err = jnp.maximum(err, _wrms(ev_vec, wv))
    if integrator.hht:
        _, vjp1 = jax.vjp(lambda qq: dyn.constraints(qq, t1), q1)
        g1 = vjp1(lam1)[0] - dyn.generalized_forces(q1, v1, t1, z)
    else:
        g1 = st.g
    new = StepState(t1, q1, v1, a1, qdd1, lam1, h, st.w, st.pw, z, g1, Jfac, jac_h, jac_ok, jac_hold, jac_pen, jerk, h)
    if power:
        new = with_power(st, new, h, dyn.power_terms(q1, v1, t1, z))
    worst = jnp.argmax(jnp.abs(jnp.where(jnp.isfinite(r), r, jnp.inf)))
    worst = jnp.where(conv, jnp.argmax(jnp.abs(e_vec / w)), worst)
    return new, err, iters, conv, worst, stale_fail, fresh
