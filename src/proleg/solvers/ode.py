"""High-order integrators for the joint-coordinate equations of motion (Diffrax).

In joint coordinates a tree without closed loops has no constraint but the normalization row
of each floating base, so its equations of motion are an ODE,

    ẋ = u,   M(x) u̇ = Q(x, u, t) − Φ_xᵀλ,   Φ_x u̇ = γ    (floating bases: pᵀp̈ = −ṗᵀṗ)

A closed loop (or a motion, a coupler) adds its rows to Φ: the same equations are then the
index-1 form of the DAE, whose position and velocity constraints drift by the integration
error (optionally held by Baumgarte's stabilization); the generalized-α/HHT path keeps them
exactly.

and the dissipated energy and input work are integrated with it (ẇ = powers). Diffrax's
explicit Tsit5 / Dopri5 (order 5, for non-stiff models) and its L-stable ESDIRK Kvaerno5
(order 5, for stiff bushings and contact) integrate y = (x, u, w) with a PID step-size
controller whose error norm covers positions AND velocities: rtol and atol apply to every
component (RMS norm of e_i / (atol + rtol |y_i|)).

Choosing values
---------------
``rtol`` = 1e-8 and ``atol`` = 1e-9 (defaults): on the undamped double pendulum the energy
error stays below 1e-6 of the largest kinetic energy over 10 s, and the IFToMM A01 pendulum
within 1e-3 m over 100 s (bench/accuracy.py). The local error of an order-5 pair falls as
h⁵, so the global error follows rtol: 1.2 decades per decade of rtol on Andrews' squeezer
between 1e-5 and 1e-9 (Tsit5; bench/README.md).
``pcoeff``/``icoeff`` = 0.0/1.0 is Diffrax's integral controller; (0.3, 0.4) is the
smoother PI setting Hairer recommends for stiff problems (Kvaerno5's default here).
"""

from __future__ import annotations

import contextlib
import math
from dataclasses import dataclass

import jax
import jax.numpy as jnp
import numpy as np

from ..errors import Status
from .base import AbstractIntegrator, RunRequest, Solution, absolute_outputs, output_grid
from .eom import accelerations, vector_field  # noqa: F401  (re-exported)


@dataclass(frozen=True)
class AbstractODEIntegrator(AbstractIntegrator):
    """An adaptive Diffrax solver for the joint-coordinate ODE (``simulate(integrator=...)``).

    Parameters
    ----------
    rtol, atol : relative and absolute local error tolerance on every state component
        (joint coordinates [rad or m], their rates [rad/s or m/s], energies [J])
    pcoeff, icoeff : PID controller coefficients (Diffrax ``PIDController``)
    max_steps : int, step limit of one run (SolverError beyond)
    stabilization : float [1/s], default 0 — Baumgarte rate s for closed loops: the
        acceleration-level constraint Φ̈ = 0 becomes Φ̈ + 2s Φ̇ + s² Φ = 0 (0: the plain index-1
        form, whose drift stays at the integration error over short runs, such as Andrews'
        squeezer's 0.03 s; simulate warns when |Φ| exceeds 1e-6)
    dt_max : float [s], optional — largest step
    fixed_step : float [s], optional — constant steps without error control
    """

    rtol: float = 1e-8
    atol: float = 1e-9
    pcoeff: float = 0.0
    icoeff: float = 1.0
    max_steps: int = 1_000_000
    stabilization: float = 0.0
    dt_max: float | None = None
    fixed_step: float | None = None
    coordinates = "joint"
    order = 5

    def __post_init__(self):
        for name in ("rtol", "atol"):
            v = getattr(self, name)
            if not (v > 0):
                raise ValueError(f"{type(self).__name__} {name} must be > 0, got {v}.")

    def solver(self, fixed=False):
        raise NotImplementedError

    def run(self, system, request):
        """The joint-coordinate ODE of ``system`` by Diffrax (:func:`run_ode`)."""
        return run_ode(self, system, request)

    def controller(self, tol, dt_max=None, fixed=False):
        """Diffrax step-size controller; ``tol`` = (rtol, atol), arrays (traced: no recompile per tolerance)."""
        import diffrax

        if fixed:
            return diffrax.ConstantStepSize()
        return diffrax.PIDController(rtol=tol[0], atol=tol[1], pcoeff=self.pcoeff, icoeff=self.icoeff, dtmax=dt_max)

    @property
    def static(self):
        """The integrator with its tolerances replaced by 1: the hashable, compile-time part."""
        import dataclasses

        return dataclasses.replace(self, rtol=1.0, atol=1.0, dt_max=None, fixed_step=None)

    @property
    def tol(self):
        return jnp.asarray(self.rtol, jnp.float64), jnp.asarray(self.atol, jnp.float64)


@dataclass(frozen=True)
class Tsit5(AbstractODEIntegrator):
    """Tsitouras' 5(4) explicit Runge–Kutta pair (Diffrax ``Tsit5``), for non-stiff models."""

    def solver(self, fixed=False):
        import diffrax

        return diffrax.Tsit5()


@dataclass(frozen=True)
class Dopri5(AbstractODEIntegrator):
    """Dormand–Prince 5(4) explicit Runge–Kutta pair (Diffrax ``Dopri5``; Exudyn's DOPRI5)."""

    def solver(self, fixed=False):
        import diffrax

        return diffrax.Dopri5()


@dataclass(frozen=True)
class Kvaerno5(AbstractODEIntegrator):
    """Kværnø's L-stable ESDIRK 5(4) (Diffrax ``Kvaerno5``), for stiff bushings and contact."""

    stiff = True

    pcoeff: float = 0.3
    icoeff: float = 0.4

    def solver(self, fixed=False):
        """With fixed steps the Newton tolerances cannot come from the step controller: full Newton
        to 1e-11 (the chord iteration's divergence test trips on round-off at such tolerances)."""
        import diffrax

        if fixed:
            import optimistix

            return diffrax.Kvaerno5(root_finder=optimistix.Newton(rtol=1e-11, atol=1e-13), root_find_max_steps=40)
        return diffrax.Kvaerno5()


@contextlib.contextmanager
def _no_callback_checks():
    """Equinox's runtime checks off while Diffrax is traced here.

    ``diffeqsolve`` checks ``saveat.ts`` (increasing, within [t0, t1]) with ``eqx.error_if``,
    whose "raise" mode is a host callback. A host callback cannot be serialised by
    ``jax.export`` nor kept in XLA's persistent cache, so every new process traced and compiled
    the integration loop again: seconds of every warm start (bench/compile_cache.py --table).
    The output times reaching :func:`solve` were checked already by ``output_grid`` (and
    ``simulate``'s own validation), so nothing is lost; the step limit and non-finite states are
    reported through Diffrax's result code (``throw=False``), not through these checks. Equinox
    reads the mode from a module global at trace time; a future equinox without it leaves the
    checks on (correct, only slower to start)."""
    try:
        from equinox import _errors
    except ImportError:  # pragma: no cover - equinox always comes with diffrax
        yield
        return
    if not hasattr(_errors, "EQX_ON_ERROR"):
        yield
        return
    old = _errors.EQX_ON_ERROR
    _errors.EQX_ON_ERROR = "off"
    try:
        yield
    finally:
        _errors.EQX_ON_ERROR = old


def solve(integrator, dyn, y0, z, t0, t1, tol, ts=None, dt0=None, dt_max=None, fixed=False):
    """Integrate y0 from t0 to t1 with ``z`` held, tolerances ``tol`` = (rtol, atol); ``fixed``: constant
    steps dt0. The states at ``ts`` (or at t1). Returns (ys, accepted steps, rejected steps, ok)."""
    import diffrax

    from ..compile_cache import traced_raw, tracing

    saveat = diffrax.SaveAt(ts=ts) if ts is not None else diffrax.SaveAt(t1=True)
    # The model reaches Diffrax as its arrays only, its structure (the System's topology) closed
    # over by the vector field, and diffeqsolve is called as its function inside proleg's jit,
    # not through its filter_jit wrapper: both keep what they are given in JAX's caches (one of
    # them unbounded), which held every model simulated for the life of the process
    # (compile_cache.traced_raw; tests/test_model_release.py).
    leaves, treedef = jax.tree_util.tree_flatten(dyn)

    def field(t, y, args):
        return vector_field(t, y, (jax.tree_util.tree_unflatten(treedef, args[0]), *args[1:]))

    diffeqsolve = traced_raw(diffrax.diffeqsolve) if tracing(y0) else diffrax.diffeqsolve
    with _no_callback_checks():
        sol = diffeqsolve(
            diffrax.ODETerm(field), integrator.solver(fixed), t0, t1, dt0, y0,
            args=(leaves, z, integrator.stabilization), saveat=saveat, stepsize_controller=integrator.controller(tol, dt_max, fixed),
            max_steps=integrator.max_steps, throw=False, adjoint=diffrax.ForwardMode(),
        )
    return sol.ys, sol.stats["num_accepted_steps"], sol.stats["num_rejected_steps"], sol.result == diffrax.RESULTS.successful


def _start(dyn, q, v):
    return dyn.reduce(q, v)


def _run_free(integrator, dyn, y0, z, times, tol, h, dt_max, fixed):
    ys, ns, nr, ok = solve(integrator, dyn, y0, z, times[0], times[-1], tol, ts=times, dt0=h, dt_max=dt_max, fixed=fixed)
    return ys, jnp.broadcast_to(z, (times.shape[0],) + z.shape), ns, nr, ok


def _run_sampled(integrator, dyn, y0, z0, grid, tick, tol, h, dt_max, fixed):
    """Sample to sample (and output to output): one solve per interval of ``grid``; at a tick
    the controllers sample the state reached."""
    from .initial import sample_state

    def seg(c, k):
        y, z, ns, nr, ok = c
        ys, a, b, good = solve(integrator, dyn, y, z, grid[k], grid[k + 1], tol, dt0=h, dt_max=dt_max, fixed=fixed)
        y = jax.tree_util.tree_map(lambda w: w[-1], ys)
        z = jnp.where(tick[k + 1], sample_state(dyn, grid[k + 1], y[0], y[1], z), z)
        return (y, z, ns + a, nr + b, ok & good), (y, z)

    c0 = (y0, z0, jnp.array(0), jnp.array(0), jnp.array(True))
    (_, _, ns, nr, ok), (ys, zs) = jax.lax.scan(seg, c0, jnp.arange(grid.shape[0] - 1))
    ys = jax.tree_util.tree_map(lambda a, b: jnp.concatenate([a[None], b]), y0, ys)
    return ys, jnp.concatenate([z0[None], zs]), ns, nr, ok


_JITS = {}


def _jits():
    if not _JITS:
        from ..compile_cache import cached_jit  # on disk: a new process skips the trace (the loop's is seconds)

        _JITS["start"] = cached_jit(_start)
        _JITS["free"] = cached_jit(_run_free, xla="loop", static_argnums=(0, 7, 8))
        _JITS["sampled"] = cached_jit(_run_sampled, xla="loop", static_argnums=(0, 8, 9))
    return _JITS


def run_ode(integrator: AbstractODEIntegrator, system, request: RunRequest) -> Solution:
    """Integrate ``system`` in joint coordinates with a Diffrax pair: the consistent start, the
    joint-coordinate ODE of the tree to the output times, controllers sampled between solves.

    Closed loops, motions and couplers run in the index-1 form (module docstring): a warning
    says when the loop constraints drift beyond 1e-6; GeneralizedAlpha/HHT and Radau5 keep them
    exactly."""
    from ..assembly.joint_coordinates import joint_set
    from .initial import _consistent_state, initial_z, sample_period

    J = _jits()
    t0 = float(request.t0)
    times_np = output_grid(t0, request.times)
    dyn = joint_set(system)
    q, v, _, _, z0, _ = _consistent_state(system, request.q0, request.v0, t0, initial_z(system))
    x, u = J["start"](dyn, q, v)
    y0 = (x, u, jnp.zeros(2, x.dtype))
    times_j = jnp.asarray(times_np)
    Ts = sample_period(system)
    fixed = integrator.fixed_step is not None
    h = None if not fixed else jnp.asarray(integrator.fixed_step, jnp.float64)
    dt_max = integrator.dt_max
    if Ts is None:
        ys, zs, ns, nr, ok = J["free"](integrator.static, dyn, y0, z0, times_j, integrator.tol, h, dt_max, fixed)
        keep, t_out = np.arange(times_np.shape[0]), times_np
    else:
        ticks = t0 + Ts * np.arange(1, int(math.floor((times_np[-1] - t0) / Ts + 1e-9)) + 1)
        grid = np.unique(np.concatenate([times_np, ticks]).round(12))
        is_tick = np.isin(grid.round(12), ticks.round(12))
        ys, zs, ns, nr, ok = J["sampled"](integrator.static, dyn, y0, z0, jnp.asarray(grid), jnp.asarray(is_tick), integrator.tol, h, dt_max, fixed)
        keep = np.flatnonzero(np.isin(grid.round(12), times_np.round(12)))
        t_out = grid[keep]
    qs, vs = absolute_outputs(dyn, ys[0][keep], ys[1][keep])
    traced = isinstance(x, jax.core.Tracer) or isinstance(ns, jax.core.Tracer)
    stats = np.zeros(4, int) if traced else np.array([int(ns), int(nr), 0, 0])
    status, msg = Status.SUCCESS, "success"
    if not traced and not bool(ok):
        status = Status.MAX_STEPS
        msg = f"{type(integrator).__name__} stopped before t = {times_np[-1]:.6g} s (step limit {integrator.max_steps} or non-finite state)."
    sol = Solution(t_out, qs, vs, ys[2][keep], zs[keep], stats, status, msg, "joint", start=(q, v))
    if traced:
        sol.traced_status = (jnp.where(ok, 0, int(Status.MAX_STEPS)), jnp.asarray(t0, jnp.float64), jnp.stack([ns, nr, 0 * ns, 0 * ns]))
    if dyn.tree.ct.n_rows and not traced:
        phi = float(np.abs(np.asarray(jax.vmap(dyn.constraints)(ys[0][keep], jnp.asarray(t_out)))).max())
        if phi > 1e-6:
            import warnings

            warnings.warn(
                f"{type(integrator).__name__} on '{system.topo.name}': the loop constraints ({', '.join(dyn.tree.cut)}) drifted to "
                f"|Φ| = {phi:.2g} (index-1 form). Tighten rtol, set stabilization=..., or use GeneralizedAlpha or Radau5.",
                stacklevel=4,
            )
    return sol

