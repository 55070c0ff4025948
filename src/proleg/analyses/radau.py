"""``simulate`` with :class:`proleg.Radau5` (solvers/radau.py): the index-2 (GGL) constrained
equations of motion in the coordinates ``coordinates=`` picks, the same :class:`Result`.

The same consistent initial conditions as the implicit path (analyses/simulate.py), reduced
to the coordinate set; one compiled loop of Radau IIA steps that land on controller sample
times (each tick updates the controller state, as in the implicit path), motion-law
breakpoints and t_end; outputs from the steps' collocation polynomials.
"""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
import numpy as np

from ..assembly.coordinates import coordinate_set
from ..errors import SolverError, Status
from ..solvers import radau
from ..solvers.initial import _consistent_state, initial_z, sample_controllers, sample_period
from .ode import _absolute, _output_times
from .placement import _any_traced
from .result import Result
from ..compile_cache import jit


def _run(cfg, dyn, q, v, lam, a, z, times, stops, is_tick, tol, h0, dt_max):
    def sample(t, x, xd, zz):
        return sample_controllers(dyn.system, t, *dyn.absolute(x, xd), zz)

    w = jnp.zeros(2, q.dtype)
    return radau.integrate(cfg, dyn, sample, q, v, lam, a, z, w, times, stops, is_tick, tol, h0, dt_max)


_run_jit = jit(_run, xla="loop", static_argnums=(0,))


@jit
def _reduce(dyn, q, v, qdd, lam):
    """The consistent absolute start (q, v, q̈, λ) in the coordinates ``dyn``."""
    x, xd = dyn.reduce(q, v)
    return x, xd, dyn.reduce_acceleration(x, xd, qdd, q), dyn.reduce_multipliers(lam)




def simulate_radau(system, t_end, dt_output=None, *, t0=0.0, output_times=None, integrator, coordinates="auto", q0=None, v0=None,
                   breakpoints=(), throw=True):
    """Integrate ``system`` with ``integrator`` (a :class:`proleg.Radau5`) in ``coordinates``; steps land on
    ``breakpoints`` [s] (motion laws', analyses/simulate.py ``motion_breakpoints``)."""
    t0, times = _output_times(t0, t_end, dt_output, output_times)
    if not times[-1] > t0:
        raise ValueError(f"t_end ({t_end}) must be greater than t0 ({t0}).")
    times = np.concatenate([[t0], times[times > t0]])
    q, v, qdd, lam, z0, _ = _consistent_state(system, q0, v0, t0, initial_z(system))
    dyn = coordinate_set(system, q, coordinates)
    if dyn.kind != "absolute":
        q, v, qdd, lam = _reduce(dyn, q, v, qdd, lam)
    t1 = float(times[-1])
    Ts = sample_period(system)
    ticks = t0 + Ts * np.arange(1, int(math.floor((t1 - t0) / Ts + 1e-9)) + 1) if Ts else np.zeros(0)
    bps = np.array([b for b in breakpoints if t0 < b < t1])
    stops = np.unique(np.concatenate([ticks[ticks < t1 - 1e-12], bps, [t1]]).round(12))
    is_tick = np.isin(stops, ticks.round(12))
    ig = integrator
    dt_max = ig.dt_max if ig.dt_max is not None else t1 - t0
    h0 = ig.dt_init if ig.dt_init is not None else min(1e-4 * (t1 - t0), dt_max)
    h0 = ig.fixed_step if ig.fixed_step is not None else h0
    f64 = jnp.float64
    qs, vs, ws, zs, st, stat, t_reached = _run_jit(
        ig.static, dyn, q, v, lam, qdd, z0, jnp.asarray(times), jnp.asarray(stops), jnp.asarray(is_tick), ig.tol,
        jnp.asarray(h0, f64), jnp.asarray(dt_max, f64),
    )
    traced = _any_traced((system.params, q))
    if dyn.kind != "absolute":
        qs, vs = _absolute(dyn, qs, vs)
    status, msg = Status.SUCCESS, "success"
    keep = len(times)
    if not traced and int(stat) != 0:
        status = Status(int(stat))
        keep = int(np.searchsorted(times, float(t_reached), side="right"))
        msg = f"Radau5 on '{system.topo.name}': {status.describe()} at t = {float(t_reached):.6g} s (rtol {ig.rtol:g})."
    stats = np.zeros(4, int) if traced else np.asarray(st).astype(int)
    result = Result(system, times[:keep], qs[:keep], vs[:keep], ws[:keep], zs[:keep], stats=stats, status=status, message=msg, integrator=integrator)
    result.coordinates = dyn.kind
    if traced:
        result.traced_status = (stat, t_reached, st)
    if status != Status.SUCCESS and throw:
        raise SolverError(msg, result)
    return result
