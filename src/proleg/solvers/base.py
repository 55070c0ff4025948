"""The integrator protocol: what every method of :func:`proleg.simulate` implements.

In the style of Diffrax's ``AbstractSolver``, an integrator is a small frozen object that
carries its options and declares what it can do; :func:`proleg.simulate` is a short driver
over it (consistent initial conditions, the run, the :class:`proleg.Result`).

Two levels, so that a method needs only what it has:

* **Step level** (``init``, ``step``, ``interpolate``): a method on the joint-coordinate ODE
  y = (x, u, w) of a loop-free tree (solvers/ode.py ``vector_field``). ``step`` returns the new
  state, its local error estimate (None: fixed steps, no error control) and the dense-output
  information of the step. The generic driver :func:`run_steps` gives such a method step-size
  control, controller samples, output times and a :class:`Solution` — a fixed-step RK4 is
  fifteen lines (tests/test_integrator_protocol.py).
* **Run level** (``run``): a method with its own compiled loop overrides ``run(system,
  request)`` and returns a :class:`Solution`: the α-methods (solvers/driver.py), Radau5
  (solvers/radau.py) and the Diffrax pairs (solvers/ode.py).

Adding a method is one file (a subclass) and, for ``integrator="auto"`` to consider it, one
entry in the choice table (solvers/auto.py).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any, ClassVar

import jax
import jax.numpy as jnp
import numpy as np

from ..errors import Status


#: run-level loops that live in modules importing their method's module (solvers/driver.py
#: registers the α-methods' loop here), so that a method's ``run`` needs no import of them
RUNNERS: dict = {}


@dataclass(frozen=True)
class RunRequest:
    """What :func:`proleg.simulate` asks of an integrator's ``run`` (analyses/simulate.py builds it).

    Parameters
    ----------
    t0 : float [s], start time
    times : (n,) strictly increasing output times [s]; the first may equal ``t0``
    q0, v0 : initial coordinates and velocities (None: the modelled pose), made consistent
    coordinates : "auto", "absolute", "planar" or "joint" (assembly/coordinates.py)
    breakpoints : times [s] where a motion law's derivatives jump (steps land on them)
    chunk, free_running : the α-methods' chunking (:class:`proleg.RunOptions`)
    on_chunk : callable(Solution) after each chunk of a concrete run (partial results), or None
    progress : callable(t) -> None, or None: called as the run advances (a progress bar)
    on_start : callable(q, v, z) called once with the consistent start of a concrete run
    """

    t0: float
    times: np.ndarray
    q0: Any = None
    v0: Any = None
    coordinates: str = "auto"
    breakpoints: tuple = ()
    chunk: int | None = None
    free_running: bool = False
    on_chunk: Any = None
    progress: Any = None
    on_start: Any = None


@dataclass
class Solution:
    """What an integrator's ``run`` returns: outputs in absolute coordinates at ``t``.

    ``stats`` = [accepted steps, rejected steps, Newton iterations, Jacobian builds];
    ``traced_status`` (status, failure time, stats as arrays) under jit/vmap, where a Python
    status cannot be read; ``start`` the consistent absolute (q, v) at t0."""

    t: Any
    q: Any
    v: Any
    w: Any
    z: Any
    stats: Any
    status: Status = Status.SUCCESS
    message: str = "success"
    coordinates: str = "absolute"
    traced_status: Any = None
    start: Any = None
    extra: dict = field(default_factory=dict)


@dataclass(frozen=True)
class AbstractIntegrator:
    """The protocol every integrator of :func:`proleg.simulate` implements.

    Class attributes (the capabilities that ``integrator="auto"`` and the checks read):

    coordinates : "any" (absolute, planar or joint coordinates, with constraint rows) or
        "joint" (the joint coordinates of a loop-free tree: an ODE)
    constraints : True where closed loops, motions and couplers hold exactly (index 2 or 3);
        False where they enter in index-1 form and drift by the integration error
    stiff : True for methods stable on stiff elements (implicit, L- or strongly damped)
    events : True where the method handles the non-smooth forces of contacts, stops and
        impacts robustly (error-controlled low-order implicit steps)
    order : the classical order of the method

    A step-level method implements :meth:`step` (and :meth:`init`, :meth:`interpolate` if it
    has state or a dense output); a run-level method overrides :meth:`run`.
    """

    coordinates: ClassVar[str] = "joint"
    constraints: ClassVar[bool] = False
    stiff: ClassVar[bool] = False
    events: ClassVar[bool] = False
    order: ClassVar[int] = 1

    # -- step level ------------------------------------------------------------------------
    def init(self, f, t0, y0, args):
        """The method's own state before the first step (FSAL stages, history); default none."""
        return None

    def step(self, f, t0, t1, y0, args, state):
        """One step from ``t0`` to ``t1`` of y' = f(t, y, args) (y a pytree).

        Returns (y1, y_error, dense, state): ``y_error`` the local error estimate (same pytree
        as y; None for fixed steps without error control), ``dense`` what :meth:`interpolate`
        needs, ``state`` the method's new state."""
        raise NotImplementedError(f"{type(self).__name__} implements neither step() nor run().")

    def interpolate(self, dense, t0, t1, y0, y1, t):
        """y at ``t`` in [t0, t1] from the step's dense information; default: the cubic Hermite
        interpolant of the end values and slopes, when ``dense`` holds (f0, f1), else linear."""
        s = (t - t0) / (t1 - t0)
        if dense is None:
            return jax.tree_util.tree_map(lambda a, b: a + s * (b - a), y0, y1)
        f0, f1 = dense
        h = t1 - t0
        h00, h10, h01, h11 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s, -2 * s**3 + 3 * s**2, s**3 - s**2
        return jax.tree_util.tree_map(lambda a, b, fa, fb: h00 * a + h10 * h * fa + h01 * b + h11 * h * fb, y0, y1, f0, f1)

    # -- run level -------------------------------------------------------------------------
    def run(self, system, request: RunRequest) -> Solution:
        """Integrate ``system`` over ``request`` (default: :func:`run_steps` over :meth:`step`)."""
        return run_steps(self, system, request)

    @property
    def tolerances(self):
        """(rtol, atol) of the method, or None where it has no error control."""
        rt, at = getattr(self, "rtol", None), getattr(self, "atol", None)
        return None if rt is None else (rt, at)

    def describe(self) -> str:
        """One line naming the method and its options (``result.stats["integrator"]``)."""
        opts = [f"{f.name}={getattr(self, f.name)!r}" for f in dataclasses.fields(self) if f.name in ("rtol", "atol", "rho_inf", "alpha", "dt", "fixed_step")
                and getattr(self, f.name) is not None]
        return f"{type(self).__name__}({', '.join(opts)})"


def output_grid(t0, times):
    """The output times with t0 first (what the loops record), as a NumPy array."""
    times = np.asarray(times, float)
    return np.concatenate([[t0], times[times > t0]]) if times[0] > t0 else times


_absolute = None


def _absolute_batch(dyn, xs, us):
    return jax.vmap(lambda d, x, u: d.absolute(x, u), in_axes=(None, 0, 0))(dyn, xs, us)


def absolute_outputs(dyn, xs, us):
    """Absolute (q, v) of a batch of reduced states (one compiled executable per coordinate set)."""
    global _absolute
    if _absolute is None:
        from ..compile_cache import cached_jit

        _absolute = cached_jit(_absolute_batch)
    return _absolute(dyn, xs, us)


def _rms_norm(err, y0, y1, rtol, atol):
    leaves = [jnp.ravel(e / (atol + rtol * jnp.maximum(jnp.abs(a), jnp.abs(b))))
              for e, a, b in zip(jax.tree_util.tree_leaves(err), jax.tree_util.tree_leaves(y0), jax.tree_util.tree_leaves(y1))]
    e = jnp.concatenate(leaves)
    return jnp.sqrt(jnp.mean(e * e))


def _step_loop(method, dyn, y0, z0, grid, tick, tol, h0, dt_max, max_steps):
    """The generic loop: steps of ``method`` from grid[0] over the grid's points (outputs and
    controller samples), landing on each; error control where ``step`` returns an estimate."""
    from .initial import sample_state
    from .eom import vector_field

    adaptive = getattr(method, "fixed_step", None) is None
    rtol, atol = tol
    args0 = (dyn, z0, 0.0)

    def f(t, y, args):
        return vector_field(t, y, args)

    def segment(carry, k):
        y, z, st, ns, nr, ok, h = carry
        ta, tb = grid[k], grid[k + 1]
        args = (dyn, z, 0.0)

        def cond(c):
            t, y, st, ns, nr, ok, h = c
            return (t < tb) & ok & (ns + nr < max_steps)

        def body(c):
            t, y, st, ns, nr, ok, h = c
            # the last step of a segment lands on tb, taking a sliver left by round-off with it
            hh = jnp.where(t + h * (1.0 + 1e-8) >= tb, tb - t, h)
            y1, err, _, st1 = method.step(f, t, t + hh, y, args, st)
            if err is None:
                acc, fac = jnp.asarray(True), jnp.asarray(1.0)
            else:
                en = _rms_norm(err, y, y1, rtol, atol)
                acc = en <= 1.0
                fac = jnp.clip(0.9 * jnp.maximum(en, 1e-10) ** (-1.0 / (method.order)), 0.2, 5.0)
            finite = jnp.all(jnp.stack([jnp.all(jnp.isfinite(a)) for a in jax.tree_util.tree_leaves(y1)]))
            acc = acc & finite
            pick = lambda a, b: jax.tree_util.tree_map(lambda u, v: jnp.where(acc, u, v), a, b)  # noqa: E731
            y_n = pick(y1, y)
            st_n = st1 if st1 is None else pick(st1, st)
            h_n = jnp.minimum(h * jnp.where(finite, fac, 0.2), dt_max) if adaptive else h
            return (jnp.where(acc, jnp.where(hh == tb - t, tb, t + hh), t), y_n, st_n, ns + acc, nr + (~acc), ok & (adaptive | finite), h_n)

        t, y, st, ns, nr, ok, h = jax.lax.while_loop(cond, body, (ta, y, st, ns, nr, ok, h))
        ok = ok & (t >= tb)
        z = jnp.where(tick[k + 1], sample_state(dyn, tb, y[0], y[1], z), z)
        return (y, z, st, ns, nr, ok, h), (y, z)

    st0 = method.init(f, grid[0], y0, args0)
    c0 = (y0, z0, st0, jnp.array(0), jnp.array(0), jnp.array(True), h0)
    (_, _, _, ns, nr, ok, _), (ys, zs) = jax.lax.scan(segment, c0, jnp.arange(grid.shape[0] - 1))
    ys = jax.tree_util.tree_map(lambda a, b: jnp.concatenate([a[None], b]), y0, ys)
    return ys, jnp.concatenate([z0[None], zs]), ns, nr, ok


def run_steps(method, system, request: RunRequest) -> Solution:
    """The generic driver of step-level methods on the joint-coordinate ODE of a loop-free tree:
    consistent start, one compiled loop that steps to each output time and controller sample
    (controllers update there), error control when the method estimates its error
    (h ← h·clip(0.9 err^(−1/order), 0.2, 5)), fixed steps ``method.fixed_step`` [s] otherwise."""
    from ..assembly.joint_coordinates import joint_set
    from ..compile_cache import jit
    from .initial import _consistent_state, initial_z, sample_period

    global _STEP_JIT
    if _STEP_JIT is None:
        _STEP_JIT = jit(_step_loop, xla="loop", static_argnums=(0, 9))
    t0 = float(request.t0)
    grid_out = output_grid(t0, request.times)
    dyn = joint_set(system)
    q, v, _, _, z0, _ = _consistent_state(system, request.q0, request.v0, t0, initial_z(system))
    x, u = dyn.reduce(q, v)
    y0 = (x, u, jnp.zeros(2, x.dtype))
    Ts = sample_period(system)
    t1 = float(grid_out[-1])
    ticks = t0 + Ts * np.arange(1, int(math.floor((t1 - t0) / Ts + 1e-9)) + 1) if Ts else np.zeros(0)
    grid = np.unique(np.concatenate([grid_out, ticks]).round(12))
    is_tick = np.isin(grid, ticks.round(12))
    fixed = getattr(method, "fixed_step", None)
    rtol, atol = method.tolerances or (1.0, 1.0)
    dt_max = getattr(method, "dt_max", None) or (t1 - t0)
    h0 = fixed if fixed is not None else (getattr(method, "dt_init", None) or min(1e-4 * (t1 - t0), dt_max))
    f64 = jnp.float64
    ys, zs, ns, nr, ok = _STEP_JIT(
        method, dyn, y0, z0, jnp.asarray(grid), jnp.asarray(is_tick), (jnp.asarray(rtol, f64), jnp.asarray(atol, f64)),
        jnp.asarray(h0, f64), jnp.asarray(dt_max, f64), int(getattr(method, "max_steps", 1_000_000)),
    )
    keep = np.flatnonzero(np.isin(grid, grid_out.round(12)))
    qs, vs = absolute_outputs(dyn, ys[0][keep], ys[1][keep])
    traced = isinstance(ns, jax.core.Tracer)
    stats = np.zeros(4, int) if traced else np.array([int(ns), int(nr), 0, 0])
    status, msg = Status.SUCCESS, "success"
    if not traced and not bool(ok):
        status = Status.MAX_STEPS
        msg = f"{type(method).__name__} stopped before t = {t1:.6g} s (step limit, a non-finite state, or fixed steps that diverged)."
    sol = Solution(grid[keep], qs, vs, ys[2][keep], zs[keep], stats, status, msg, "joint", start=(q, v))
    if traced:
        sol.traced_status = (jnp.where(ok, 0, int(Status.MAX_STEPS)), jnp.asarray(t0, f64), jnp.stack([ns, nr, 0 * ns, 0 * ns]))
    return sol


_STEP_JIT = None
