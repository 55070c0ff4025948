"""``simulate`` with a high-order ODE integrator (solvers/ode.py) in joint coordinates.

``simulate(system, ..., integrator=pl.Tsit5(rtol=1e-9))`` lands here: the same consistent
initial conditions as the implicit path (analyses/simulate.py), then the joint-coordinate ODE
of the tree (assembly/joint_coordinates.py), integrated by Diffrax to the output times, and the
same :class:`Result` in absolute coordinates. Controllers with a sample period are held
between samples: the run is integrated from sample to sample (and output time), and each
tick updates the controller state, as in the implicit path.
"""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
import numpy as np

from ..assembly.joint_coordinates import joint_set
from ..errors import SolverError, Status
from ..solvers import ode
from ..solvers.driver import sample_controllers
from .placement import _any_traced
from .result import Result
from ..compile_cache import jit


def _output_times(t0, t_end, dt_output, output_times):
    if output_times is not None:
        times = np.asarray(output_times, float)
        if np.any(np.diff(times) <= 0):
            raise ValueError("output_times must be strictly increasing.")
        return (float(times[0]) if t0 == 0.0 and times[0] > 0 else t0), times
    dt_output = (t_end - t0) / 500.0 if dt_output is None else dt_output
    n = int(math.floor((t_end - t0) / dt_output + 1e-9))
    times = t0 + dt_output * np.arange(n + 1)
    if times[-1] < t_end - 1e-12 * max(1.0, abs(t_end)):
        times = np.append(times, t_end)
    return t0, times


@jit
def _start(dyn, q, v):
    x, u = dyn.reduce(q, v)
    return x, u


_absolute = jit(jax.vmap(lambda dyn, x, u: dyn.absolute(x, u), in_axes=(None, 0, 0)))


def _run_free(integrator, dyn, y0, z, times, tol, h, dt_max, fixed):
    ys, ns, nr, ok = ode.solve(integrator, dyn, y0, z, times[0], times[-1], tol, ts=times, dt0=h, dt_max=dt_max, fixed=fixed)
    return ys, jnp.broadcast_to(z, (times.shape[0],) + z.shape), ns, nr, ok


def _run_sampled(integrator, dyn, y0, z0, grid, tick, tol, h, dt_max, fixed):
    """Sample to sample (and output to output): one solve per interval of ``grid``; at a tick
    the controllers sample the state reached."""

    def seg(c, k):
        y, z, ns, nr, ok = c
        ys, a, b, good = ode.solve(integrator, dyn, y, z, grid[k], grid[k + 1], tol, dt0=h, dt_max=dt_max, fixed=fixed)
        y = jax.tree_util.tree_map(lambda w: w[-1], ys)
        q, v = dyn.absolute(y[0], y[1])
        z = jnp.where(tick[k + 1], sample_controllers(dyn.system, grid[k + 1], q, v, z), z)
        return (y, z, ns + a, nr + b, ok & good), (y, z)

    c0 = (y0, z0, jnp.array(0), jnp.array(0), jnp.array(True))
    (_, _, ns, nr, ok), (ys, zs) = jax.lax.scan(seg, c0, jnp.arange(grid.shape[0] - 1))
    ys = jax.tree_util.tree_map(lambda a, b: jnp.concatenate([a[None], b]), y0, ys)
    return ys, jnp.concatenate([z0[None], zs]), ns, nr, ok


_run_free_jit = jit(_run_free, xla="loop", static_argnums=(0, 7, 8))
_run_sampled_jit = jit(_run_sampled, xla="loop", static_argnums=(0, 8, 9))


def simulate_ode(system, t_end, dt_output=None, *, t0=0.0, output_times=None, integrator, q0=None, v0=None, dt_max=None, fixed_step=None, throw=True):
    """Integrate ``system`` in joint coordinates with ``integrator`` (a solvers.ode integrator).

    Closed loops, motions and couplers run in the index-1 form (solvers/ode.py): a warning
    says when the loop constraints drift beyond 1e-6; GeneralizedAlpha/HHT (which run on
    joint coordinates too with ``coordinates="joint"``) keep them exactly."""
    from ..solvers.initial import _consistent_state, initial_z, sample_period

    t0, times = _output_times(t0, t_end, dt_output, output_times)
    if not t_end > t0:
        raise ValueError(f"t_end ({t_end}) must be greater than t0 ({t0}).")
    dyn = joint_set(system)
    q, v, _, _, z0, _ = _consistent_state(system, q0, v0, t0, initial_z(system))
    x, u = _start(dyn, q, v)
    y0 = (x, u, jnp.zeros(2, x.dtype))
    times_j = jnp.asarray(np.concatenate([[t0], times[times > t0]]) if times[0] > t0 else times)
    Ts = sample_period(system)
    fixed = fixed_step is not None
    h = None if not fixed else jnp.asarray(fixed_step, jnp.float64)
    if Ts is None:
        ys, zs, ns, nr, ok = _run_free_jit(integrator.static, dyn, y0, z0, times_j, integrator.tol, h, dt_max, fixed)
        keep, t_out = np.arange(times_j.shape[0]), np.asarray(times_j)
    else:
        ticks = t0 + Ts * np.arange(1, int(math.floor((times[-1] - t0) / Ts + 1e-9)) + 1)
        grid = np.unique(np.concatenate([np.asarray(times_j), ticks]).round(12))
        is_tick = np.isin(grid.round(12), ticks.round(12))
        ys, zs, ns, nr, ok = _run_sampled_jit(
            integrator.static, dyn, y0, z0, jnp.asarray(grid), jnp.asarray(is_tick), integrator.tol, h, dt_max, fixed
        )
        keep = np.flatnonzero(np.isin(grid.round(12), np.asarray(times_j).round(12)))
        t_out = grid[keep]
    qs, vs = _absolute(dyn, ys[0][keep], ys[1][keep])
    traced = _any_traced((system.params, x))
    stats = np.zeros(4, int) if traced else np.array([int(ns), int(nr), 0, 0])
    status, msg = Status.SUCCESS, "success"
    if not traced and not bool(ok):
        status = Status.MAX_STEPS
        msg = f"{type(integrator).__name__} stopped before t = {times[-1]:.6g} s (step limit {integrator.max_steps} or non-finite state)."
    result = Result(system, t_out, qs, vs, ys[2][keep], zs[keep], stats=stats, status=status, message=msg, integrator=integrator)
    result.coordinates = "joint"
    if traced:
        result.traced_status = (jnp.where(ok, 0, int(Status.MAX_STEPS)), jnp.asarray(t0, jnp.float64), jnp.stack([ns, nr, 0 * ns, 0 * ns]))
    if dyn.tree.ct.n_rows and not traced:
        phi = float(np.abs(np.asarray(jax.vmap(dyn.constraints)(ys[0][keep], jnp.asarray(t_out)))).max())
        if phi > 1e-6:
            import warnings

            warnings.warn(
                f"{type(integrator).__name__} on '{system.topo.name}': the loop constraints ({', '.join(dyn.tree.cut)}) drifted to "
                f"|Φ| = {phi:.2g} (index-1 form). Tighten rtol, set stabilization=..., or use GeneralizedAlpha.",
                stacklevel=3,
            )
    if status != Status.SUCCESS and throw:
        raise SolverError(msg, result)
    return result
