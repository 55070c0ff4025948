"""Adaptive (or fixed-step) time stepping over a chunk of output times, as one compiled loop.

The loop is a ``lax.while_loop`` that chooses between accept and reject (note §4, §7): the
step is a pure function of (state, h), so a rejection simply retries from the same state with
a smaller h.

Steps are chosen by accuracy and by the discontinuities the model declares, never by the
output times: a step is clipped only to controller sample times (so controllers see
zero-order-held inputs and their jumps are stepped to, not interpolated across), to motion-law
breakpoints (``Motion(breakpoints=...)``), and to the end of the run. Outputs come from the
dense output of the accepted step that contains them (:func:`dense_output`).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import partial
from typing import NamedTuple

import jax
import jax.numpy as jnp

from ..errors import Status
from ..assembly.coordinates import Absolute
from ..assembly.system import element_power
from .galpha import StepOptions, StepState, lu_apply, rarely, step, with_power
from .initial import kkt_accelerations, sample_controllers, sample_state
from ..compile_cache import cached_jit, jit, tracing


@dataclass(frozen=True)
class DriverOptions:
    step: StepOptions = StepOptions()
    dt_min: float = 1e-10
    dt_max: float = 1e-2
    fixed_step: float | None = None
    max_steps: int = 2_000_000  # per chunk
    sample_period: float | None = None  # controller clock [s]
    breakpoints: tuple = ()  # times [s] where a motion law's derivatives jump (stepped to exactly)
    # Outputs evaluated together, vectorised, from one step's dense output (``advance``). A fixed
    # 8, not one per output spacing, so that runs with other output times share the compiled
    # loop: 8 rows cost about what 1 does (bench/dense_output.py's runs, least CPU of 6 at load
    # ~1.3: 1 ms outputs 0.36 s with 8, 0.38 s with 1; 0.1 ms outputs, ten per step, 0.41 s with
    # 8, 0.38 s with 10).
    out_block: int = 8


# Compiled once per model (the System's topology is static): the first sample of a run, or the
# static controller law in statics.
sample_controllers_first = jit(partial(sample_controllers, first=True))


def _sample_update(dyn, st: StepState, hht: bool):
    """A controller sample. The held commands jump, so the accelerations are re-initialised from
    the KKT system at the new commands (like a restart), instead of being smeared over a step."""
    return _restart(dyn, st, sample_state(dyn, st.t, st.q, st.v, st.z), hht)


def _tick_joint(dyn, st: StepState, new: StepState, h, hht: bool):
    """A step that ends on a controller tick, in joint coordinates: the step's powers (old
    commands), the sample, and the restart's dynamics (new commands) from one pass of the
    tree's kinematics, where :func:`_sample_update` after a step with its own powers traces
    it three times. Returns (the step with its powers, the state after the sample)."""
    tp = dyn.tree_pass(new.q, new.v)
    new = with_power(st, new, h, element_power(dyn.system, tp.bk, tp.mk, new.t, new.z))
    z = sample_controllers(dyn.system, new.t, None, None, new.z, kin=(tp.bk, tp.mk))
    return new, _restart(dyn, new, z, hht, dyn.dynamics(new.q, new.v, _right_limit(new.t), z, tp=tp))


def _right_limit(t):
    """The time just after t at which a restart evaluates laws that jump at t (:func:`_restart`)."""
    return t + 1e-12 * jnp.maximum(1.0, jnp.abs(t))


def _restart(dyn, st: StepState, z, hht: bool, mqp=None):
    """Re-initialise the accelerations, multipliers and HHT history from the KKT system at
    (t, q, v, z): after a controller sample or at a motion-law breakpoint, where the
    accelerations jump (the a_n history would otherwise ring, decaying as ρ∞ⁿ). The
    accelerations are those just after t (the right limit of a law whose second derivative
    jumps at t: evaluated at t + 1e-12·max(1, |t|)).

    HHT's history term g = Φ_qᵀλ − Q is formed from the KKT system's own Φ_q and Q, so it is the
    right limit too, consistent with q̈ and λ (it was a second force evaluation and a constraint
    vjp at t: ~1,000 of the HyQ drop loop's 7,841 traced operations); generalized-α does not
    use g and keeps it as it is."""
    t_right = _right_limit(st.t)
    Pq = jax.jacfwd(lambda qq: dyn.constraints(qq, t_right))(st.q)
    if mqp is not None:  # (M, Q, powers) at (q, v, t_right, z), given by the caller
        M, Q, pw = mqp
    elif hasattr(dyn, "dynamics"):
        # M, Q and the powers from one pass of the kinematics (joint coordinates); the powers
        # at t_right, the right limit the next step's trapezoidal rule starts from.
        M, Q, pw = dyn.dynamics(st.q, st.v, t_right, z)
    else:
        M, Q, pw = None, dyn.generalized_forces(st.q, st.v, t_right, z), dyn.power_terms(st.q, st.v, st.t, z)
    qdd, lam = kkt_accelerations(dyn, st.q, st.v, t_right, z, M=M, Pq=Pq, Q=Q)
    g = Pq.T @ lam - Q if hht else st.g
    return st._replace(z=z, qdd=qdd, a=qdd, lam=lam, g=g, pw=pw, jerk_h=st.jerk_h * 0.0)


class Knot(NamedTuple):
    """One end of an accepted step, what the dense output needs: t, q, v, q̈ (the accelerations
    that hold on this step: before a controller sample at its right end, after one at its left),
    w (integrated energies) and z (controller state; at the right end, after a sample there)."""

    t: jnp.ndarray
    q: jnp.ndarray
    v: jnp.ndarray
    qdd: jnp.ndarray
    w: jnp.ndarray
    z: jnp.ndarray
    pw: jnp.ndarray  # powers (dissipated, input) [W] the step's trapezoidal rule used at this end


def knot(st: StepState, z=None) -> Knot:
    return Knot(st.t, st.q, st.v, st.qdd, st.w, st.z if z is None else z, st.pw)


def dense_output(dyn, a: Knot, b: Knot, t, fac=None):
    """(q, v, w, z) at ``t`` in [a.t, b.t] from the accepted step a → b.

    Positions: the cubic Hermite interpolant of q with the end slopes v; velocities: the cubic
    Hermite interpolant of v with the end slopes q̈ (the accelerations of the step's own
    equations of motion at both ends). Each is exact for cubics, so with exact end values its
    error is h⁴/384·max|q⁗| (positions) and h⁴/384·max|v⁗| (velocities), O(h⁴), one order above
    the method's local error O(h³) (note §4): the interpolation adds less than the step's
    tolerance. The interpolated Euler parameters are normalised (p/|p|, ṗ − p pᵀṗ), so each
    output is a unit quaternion as the solver's own states are. w (energies) is the integral of
    the trapezoidal rule's own integrand, the power linear between its end values,
    w(s) = w_a + h (s P_a + s²/2 (P_b − P_a)) (w_b at s = 1, as the step), z (controller state) is held: piecewise constant
    between samples, the post-sample value exactly at a sample time. At t = b.t the output is
    the solver's state b exactly.

    ``fac``: the LU factors of the step's Newton matrix [[J, Φ_qᵀ], [Φ_q, 0]]. The interpolated
    positions are then moved back onto the constraints by one projection with them,
    Δq = −J⁻¹Φ_qᵀ(Φ_q J⁻¹Φ_qᵀ)⁻¹ Φ(q, t) (two triangular solves and one evaluation of Φ; no
    new matrix): the Hermite polynomial leaves the constraint manifold by its own error (a
    few 1e-9 m at tolerance 1e-9 on tests/test_core_pendulum.py's 90° swing), the projection
    brings |Φ| down by the factor O(h) between the matrix's Φ_q and the one at the output
    (there to 7e-13).
    """
    h = b.t - a.t
    s = jnp.clip(jnp.where(h > 0, (t - a.t) / jnp.where(h > 0, h, 1.0), 1.0), 0.0, 1.0)
    at_end = s >= 1.0 - 1e-12
    s2, s3 = s * s, s * s * s
    h00, h10, h01, h11 = 2 * s3 - 3 * s2 + 1, s3 - 2 * s2 + s, -2 * s3 + 3 * s2, s3 - s2
    q = h00 * a.q + h10 * h * a.v + h01 * b.q + h11 * h * b.v
    v = h00 * a.v + h10 * h * a.qdd + h01 * b.v + h11 * h * b.qdd
    if getattr(dyn, "kind", "") == "absolute":
        q, v = _normalize_parameters(q, v, dyn.system.topo.nbody)
    if fac is not None:
        nq = q.shape[0]
        phi = Absolute.of(dyn).constraints(q, t)
        dx = lu_apply(fac, jnp.concatenate([jnp.zeros(nq, q.dtype), -phi]))
        q = q + jnp.where(jnp.all(jnp.isfinite(dx)), dx[:nq], 0.0)
    q = jnp.where(at_end, b.q, q)
    v = jnp.where(at_end, b.v, v)
    w = a.w + h * (s * a.pw + 0.5 * s2 * (b.pw - a.pw))
    w = jnp.where(at_end, b.w, w)
    z = jnp.where(at_end, b.z, a.z)
    return q, v, w, z


def dense_outputs(dyn, seg, times, fac=None):
    """:func:`dense_output` at each of ``times`` (M,) from one step ``seg`` = (a, b), vectorised:
    one evaluation of the (batched) constraints and two triangular solves with M right-hand
    sides for the projection, instead of M of each."""
    return jax.vmap(lambda t: dense_output(dyn, *seg, t, fac))(times)


def _unset(shape, dtype):
    """An output buffer before it is written: NaN (0 for integer states)."""
    return jnp.full(shape, jnp.nan if jnp.issubdtype(dtype, jnp.inexact) else 0, dtype)


def _normalize_parameters(q, v, nb):
    if nb == 0:
        return q, v
    qb, vb = q[: 7 * nb].reshape(nb, 7), v[: 7 * nb].reshape(nb, 7)
    p = qb[:, 3:] / jnp.linalg.norm(qb[:, 3:], axis=1, keepdims=True)
    pd = vb[:, 3:] - p * jnp.sum(p * vb[:, 3:], axis=1, keepdims=True)
    qb = jnp.concatenate([qb[:, :3], p], 1).reshape(-1)
    vb = jnp.concatenate([vb[:, :3], pd], 1).reshape(-1)
    return jnp.concatenate([qb, q[7 * nb :]]), jnp.concatenate([vb, v[7 * nb :]])


def advance(dyn, integrator, dopts: DriverOptions, st: StepState, h, out_times, n_valid, free_running=False, t_stop=None, seg=None):
    """Integrate from ``st`` through ``out_times[:n_valid]``; record q, v, w, z at each.
    Traced inside :data:`advance_absolute`'s compile, not a jit of its own: a nested jit of a
    module function would keep every model's topology in JAX's trace cache
    (:func:`proleg.compile_cache.traced_raw`).

    ``dyn``: the coordinate set the state is in (assembly/coordinates.py). ``t_stop``: the end
    of the run (steps never go past it; default: the last output time). ``seg``: the last
    accepted step (Knot, Knot) of the previous chunk, whose dense output serves the first
    outputs of this chunk that it already passed (default: none, ``st`` at both ends).

    A ``lax.scan`` over blocks of ``dopts.out_block`` (M) output times with, inside, a
    ``lax.while_loop`` of step attempts until the block's last output is reached; after each
    attempt, the block's outputs that the accepted step reached are read from its dense output
    at once, vectorised over the M times (:func:`dense_outputs`; skipped when it reached none).
    Outputs are scan results (no dynamic buffer updates), and under ``jax.vmap`` only the step
    state and one block are carried per lane by the inner loop. Per output this costs a
    fraction of one vectorised interpolation and projection, not a loop iteration, a while
    loop and a projection each (bench/dense_output.py). Steps are never clipped to output
    times, only to the events of ``dopts`` and to ``t_stop``.

    ``free_running``: one ``lax.while_loop`` of step attempts over all the output times instead,
    writing the outputs each accepted step passed into their buffer rows, M rows at a time.
    Under ``jax.vmap`` the lanes then do not wait for each other at every output time (the
    loop runs as many attempts as the slowest lane needs in all, not the sum over outputs of
    the slowest lane per interval, ~2× fewer on bench/vmap_batch.py); one lane's work is the
    same. ``sweep`` uses it.

    Returns (state, h, number of outputs reached, buffers, stats, status, fail_time, worst_row,
    last accepted step).
    """
    K = out_times.shape[0]
    M = max(1, int(dopts.out_block))
    fixed = dopts.fixed_step is not None
    Ts = dopts.sample_period
    bps = jnp.asarray(sorted(dopts.breakpoints), jnp.float64) if dopts.breakpoints else None
    eps_t = 1e-12
    t_stop = out_times[jnp.maximum(n_valid - 1, 0)] if t_stop is None else jnp.asarray(t_stop, jnp.float64)
    if seg is None:
        seg = (knot(st), knot(st))

    def reached(t, te):
        return t >= te - eps_t * jnp.maximum(1.0, jnp.abs(te))

    def next_event(t):
        te = t_stop
        if Ts is not None:
            ts = (jnp.floor(t / Ts + 1e-9) + 1.0) * Ts
            te = jnp.minimum(te, ts)
        if bps is not None:
            after = bps > t + eps_t * jnp.maximum(1.0, jnp.abs(t))
            te = jnp.minimum(te, jnp.min(jnp.where(after, bps, jnp.inf)))
        return te

    def on_tick(t):
        """t is a controller clock tick (to round-off of the landing on it)."""
        return jnp.abs(t / Ts - jnp.round(t / Ts)) < 1e-9 * jnp.maximum(1.0, t / Ts)

    def attempt(c):
        st, h, (ns, nr, nn, nj), status, ft, worst, rejected, seg = c
        rem = next_event(st.t) - st.t
        h_des = jnp.asarray(dopts.fixed_step) if fixed else h
        # Land on the event when within 1e-6·h of it (fixed steps accumulate round-off in t).
        h_take = jnp.where(h_des * (1 + 1e-6) >= rem, rem, jnp.where(2 * h_des > rem, 0.5 * rem, h_des))
        clipped = h_take < h_des
        # Joint coordinates with sampled controllers: the powers of a step that ends on a tick
        # come with the sample and the restart from one pass of the kinematics (_tick_joint).
        merged = Ts is not None and hasattr(dyn, "tree_pass")
        new, err, iters, conv, wrow, stale_fail, built = step(dyn, integrator, st, h_take, dopts.step, power=not merged)
        if fixed:
            accept = conv
            h_next = h
        else:
            accept = conv & (err <= 1.0)
            fmax = jnp.where(rejected, 1.0, 2.0)
            fac = jnp.clip(0.9 * jnp.maximum(err, 1e-10) ** (-1.0 / 3.0), 0.2, fmax)
            # Keep h when the proposed increase is small: every change of h excites the
            # ρ∞-decaying oscillation of the a_n history and leads to avoidable rejections.
            fac = jnp.where((fac >= 1.0) & (fac < 1.2), 1.0, fac)
            h_acc = jnp.where(clipped, jnp.maximum(h_take * fac, h), h_take * fac)
            h_rej = jnp.where(conv, h_take * jnp.minimum(fac, 1.0), jnp.where(stale_fail, h_take, 0.25 * h_take))
            # The step sequence is not differentiated (derivatives are those of the discrete map).
            h_next = jax.lax.stop_gradient(jnp.clip(jnp.where(accept, h_acc, h_rej), 0.0, dopts.dt_max))
        after = new
        if merged:

            def plain(n):
                n = with_power(st, n, h_take, dyn.power_terms(n.q, n.v, n.t, n.z))
                return n, n

            new, after = jax.lax.cond(accept & on_tick(new.t), lambda n: _tick_joint(dyn, st, n, h_take, integrator.hht), plain, new)
        # Accepted: the new state; rejected: the old one, but with the newest Newton matrix.
        jac_fields = ("Jfac", "jac_h", "jac_ok", "jac_hold", "jac_pen")
        st2 = StepState(*[
            getattr(new, f) if f in jac_fields else jnp.where(accept, getattr(after, f), getattr(st, f)) for f in StepState._fields
        ])
        # Controller sample at its clock ticks.
        if Ts is not None and not merged:
            st2 = jax.lax.cond(accept & on_tick(st2.t), lambda s: _sample_update(dyn, s, integrator.hht), lambda s: s, st2)
        if bps is not None:
            at_bp = accept & jnp.any(jnp.abs(st2.t - bps) <= 1e-9 * jnp.maximum(1.0, jnp.abs(bps)))
            st2 = jax.lax.cond(at_bp, lambda s: _restart(dyn, s, s.z, integrator.hht), lambda s: s, st2)
        # The accepted step for the dense output: its accelerations are those before a sample
        # at its end; z after it (the output at a sample time shows the new command).
        seg = jax.tree_util.tree_map(lambda n, o: jnp.where(accept, n, o), (knot(st), knot(new, st2.z)), seg)
        too_small = (~accept) & (h_next < dopts.dt_min) if not fixed else ~accept & ~stale_fail
        new_status = jnp.where(
            too_small, jnp.where(conv, int(Status.STEP_TOO_SMALL), int(Status.NEWTON_FAILED)), status
        )
        new_status = jnp.where(ns + nr >= dopts.max_steps, int(Status.MAX_STEPS), new_status)
        ft = jnp.where(too_small, st.t + h_take, ft)
        worst = jnp.where(too_small, wrow, worst)
        stats = (ns + accept.astype(ns.dtype), nr + (~accept).astype(nr.dtype), nn + iters, nj + built.astype(nj.dtype))
        return st2, jnp.maximum(h_next, dopts.dt_min * 0.5), stats, new_status, ft, worst, ~accept, seg

    def emit(c, times, todo, block):
        """The rows of ``block`` (outputs at ``times``, (M,)) still ``todo`` that the last
        accepted step reached, from its dense output all at once: (block, rows written)."""
        new = todo & (c[3] == 0) & reached(c[0].t, times)

        def fill(block):
            out = dense_outputs(dyn, c[7], times, c[0].Jfac)
            return tuple(jnp.where(new.reshape((-1,) + (1,) * (o.ndim - 1)), o, b) for o, b in zip(out, block))

        # Most step attempts reach no output when outputs are sparser than the steps.
        return rarely(jnp.any(new), fill, block, block), new

    z0 = jnp.array(0)
    init = (st, jnp.asarray(h, jnp.float64), (z0, z0, z0, z0), jnp.array(0), st.t * 0.0, z0, jnp.array(False), seg)
    like = (st.q, st.v, st.w, st.z)
    # Output times in blocks of M, padded with the last time (rows past n_valid are never written).
    Kb = -(-K // M) * M
    t_pad = jnp.concatenate([out_times, jnp.full(Kb - K + M, out_times[K - 1])])
    if free_running:

        def write(c):
            inner, k, bufs = c
            todo = k + jnp.arange(M) < n_valid
            rows = tuple(jax.lax.dynamic_slice_in_dim(b, k, M) for b in bufs)
            rows, new = emit(inner, jax.lax.dynamic_slice_in_dim(t_pad, k, M), todo, rows)
            bufs = tuple(jax.lax.dynamic_update_slice_in_dim(b, r, k, 0) for b, r in zip(bufs, rows))
            return inner, k + jnp.sum(new).astype(k.dtype), bufs

        def write_reached(c):
            def more(c):
                inner, k, _ = c
                return (k < n_valid) & (inner[3] == 0) & reached(inner[0].t, t_pad[k])

            return jax.lax.while_loop(more, write, c)

        def cond(c):
            inner, k, _ = c
            return (k < n_valid) & (inner[3] == 0)

        def body(c):
            inner, k, bufs = c
            return write_reached((attempt(inner), k, bufs))

        bufs0 = tuple(_unset((Kb + M,) + x.shape, x.dtype) for x in like)
        c = write_reached((init, z0, bufs0))
        (st, h, stats, status, ft, worst, _, seg), k, bufs = jax.lax.while_loop(cond, body, c)
        return st, h, k, tuple(b[:K] for b in bufs), stats, status, ft, worst, seg

    def reach(carry, xs):
        times, valid = xs
        c, k = carry
        block, done = emit(c, times, valid, tuple(_unset((M,) + x.shape, x.dtype) for x in like))

        def cond(cb):
            return jnp.any(valid & ~cb[2]) & (cb[0][3] == 0)

        def body(cb):
            c, block, done = cb
            c = attempt(c)
            block, new = emit(c, times, valid & ~done, block)
            return c, block, done | new

        c, block, done = jax.lax.while_loop(cond, body, (c, block, done))
        return (c, k + jnp.sum(done).astype(k.dtype)), block

    valid = (jnp.arange(Kb) < n_valid).reshape(-1, M)
    ((st, h, stats, status, ft, worst, _, seg), k), bufs = jax.lax.scan(reach, (init, z0), (t_pad[:Kb].reshape(-1, M), valid))
    bufs = tuple(b.reshape((Kb,) + b.shape[2:])[:K] for b in bufs)
    return st, h, k, bufs, stats, status, ft, worst, seg


# ---------------------------------------------------------------------------------------------
# The α-methods' run (GeneralizedAlpha, HHT): consistent start, the start reduced to the
# coordinate set, then the compiled loop over chunks of output times.


@cached_jit
def _reduced_start(dyn, q, v, qdd, lam):
    """The consistent absolute start (q, v, q̈, λ) in the coordinates ``dyn`` (x, ẋ, ẍ, λ_x) and
    the HHT history term g = Φ_xᵀλ_x − Q = −M ẍ."""
    x, xd = dyn.reduce(q, v)
    xdd = dyn.reduce_acceleration(x, xd, qdd, q)
    return x, xd, xdd, dyn.reduce_multipliers(lam), -dyn.mass_action(x, xdd)


def _advance_absolute(dyn, integrator, dopts, st, h, out_times, n_valid, free_running=False, t_stop=None, seg=None):
    """The integration loop (:func:`advance`) with its recorded (q, v) in absolute coordinates:
    one executable (a separate conversion was one more compile and load per model)."""
    out = advance(dyn, integrator, dopts, st, h, out_times, n_valid, free_running, t_stop, seg)
    if dyn.kind == "absolute":
        return out
    bufs = out[3]
    q, v = jax.vmap(dyn.absolute)(bufs[0], bufs[1])
    return (*out[:3], (q, v, *bufs[2:]), *out[4:])


_advance_absolute.__name__ = "advance"  # JAX's compile logs and the cache files name the loop
# The integration loop, its trace and lowering kept across processes.
advance_absolute = cached_jit(_advance_absolute, static_argnums=(1, 2, 7), xla="loop")


def alpha_options(ig, system, t0: float, t_end: float, breakpoints=()) -> DriverOptions:
    """The driver's options of an α-method ``ig`` for a run from t0 to t_end [s]."""
    from .initial import sample_period

    fixed_step = ig.fixed_step
    return DriverOptions(
        step=ig.step_options(),
        dt_min=float(ig.dt_min),
        # a static option: strip round-off so t_end changes do not recompile
        dt_max=float(ig.dt_max if ig.dt_max is not None else f"{min(t_end - t0, 1e-2):.10g}"),
        fixed_step=None if fixed_step is None else float(fixed_step),
        sample_period=sample_period(system),
        breakpoints=tuple(breakpoints),
    )


def run_alpha(ig, system, request):
    """Integrate ``system`` with the α-method ``ig`` (GeneralizedAlpha or HHT) over ``request``
    (solvers/base.py): the Solution, or a partial one with status INTERRUPTED on Ctrl-C."""
    import contextlib
    import math

    import numpy as np

    from .. import compile_cache, sigint
    from ..assembly.coordinates import coordinate_set
    from .base import Solution
    from .initial import _consistent_state, initial_z

    times = np.asarray(request.times, float)
    t0 = float(request.t0)
    t_end = float(times[-1])
    dopts = alpha_options(ig, system, t0, t_end, request.breakpoints)
    integrator = ig.method  # what the compiled step depends on; the options are in dopts
    chunk, free_running = request.chunk, request.free_running
    q0, v0 = request.q0, request.v0
    z0 = initial_z(system)
    params_traced = tracing((system.params, q0, v0))
    trail = contextlib.ExitStack()
    if not params_traced:  # the executables this run loads, for a later process to start loading early
        trail.enter_context(compile_cache.trail(system, request.coordinates, integrator, dopts, len(times), chunk,
                                                free_running, q0 is None, v0 is None))
    with trail:
        q, v, qdd, lam, z0, (pw, g0) = _consistent_state(system, q0, v0, t0, z0)
        q_ic, v_ic = q, v
        traced = tracing((system.params, q))
        if not traced and request.on_start is not None:
            request.on_start(q, v, z0)
        dyn = coordinate_set(system, q, request.coordinates)
        if dyn.kind != "absolute":
            q, v, qdd, lam, g0 = _reduced_start(dyn, q, v, qdd, lam)
        n_newton = dyn.nq + dyn.nc
        # Constants as NumPy arrays: JAX would compile a small executable for each eager op.
        f64, i32 = np.float64, np.int32
        st = StepState(
            t=np.asarray(t0, f64), q=q, v=v, a=qdd, qdd=qdd, lam=lam,
            h_prev=np.asarray(1.0, f64), w=np.zeros(2), pw=pw, z=z0, g=g0,
            Jfac=(np.zeros((n_newton, n_newton)), np.arange(n_newton, dtype=i32)), jac_h=np.asarray(0.0, f64),
            jac_ok=np.asarray(False), jac_hold=np.asarray(0, i32), jac_pen=np.asarray(0, i32),
            jerk=np.zeros(np.shape(q)), jerk_h=np.asarray(0.0, f64),
        )
        h = np.asarray(ig.dt_init if ig.dt_init is not None else (dopts.fixed_step or min(1e-4, dopts.dt_max)), f64)
        st = st._replace(h_prev=h)
        seg = (knot(st), knot(st))  # the last accepted step (dense output); none yet

        out_t = times[1:] if times[0] == t0 else times
        t_stop = np.asarray(out_t[-1], f64)  # steps never go past the last output
        K = int(chunk or 256 * dopts.out_block)
        if chunk or free_running:  # the default pads shorter runs: one compilation for all output times
            K = min(K, max(1, len(out_t)))
        nchunks = int(math.ceil(len(out_t) / K))
        host = (lambda x: x) if traced else np.asarray  # a concrete run records NumPy arrays
        rec = {"q": [host(q_ic)[None]], "v": [host(v_ic)[None]], "w": [np.zeros((1, 2))], "z": [host(z0)[None]]}
        rec_t = [np.array([t0])]
        stats = np.zeros(4, int)
        status, fail_t, worst = Status.SUCCESS, None, None
        tr_status, tr_ft, tr_stats = np.asarray(0), np.asarray(t0, f64), np.zeros(4, i32)

        def solution(status_, msg):
            t = np.concatenate(rec_t)
            xp = jnp if traced else np
            a = {k: xp.concatenate(r, 0) for k, r in rec.items()}
            return Solution(t, a["q"], a["v"], a["w"], a["z"], stats.copy(), status_, msg, dyn.kind, start=(q_ic, v_ic))

        bar = request.progress if not traced else None
        if bar is not None:
            bar.start(nchunks, t0, t_end)
        ctrl_c = contextlib.nullcontext(sigint.Pending(False)) if traced else sigint.deferred()
        try:
            with ctrl_c as stop:  # Ctrl-C acted on between chunks, never lost (sigint.py says why)
                for c in range(nchunks):
                    tc = out_t[c * K : (c + 1) * K]
                    n_valid = len(tc)
                    tpad = np.concatenate([tc, np.full(K - n_valid, tc[-1])])
                    st, h, k, bufs, (ns, nr, nn, nj), stat, ft, wr, seg = advance_absolute(
                        dyn, integrator, dopts, st, h, tpad, n_valid, free_running, t_stop, seg
                    )
                    if traced:
                        rec_t.append(tc)
                        for key, b in zip(("q", "v", "w", "z"), bufs):
                            rec[key].append(b[:n_valid])
                        # Kept as (traced) arrays: the first failure and the counters (sweep.py reads them).
                        first = tr_status == 0
                        tr_status, tr_ft = jnp.where(first, stat, tr_status), jnp.where(first, ft, tr_ft)
                        tr_stats = tr_stats + jnp.stack([ns, nr, nn, nj])
                        continue
                    k = int(k)
                    stats += np.array([int(ns), int(nr), int(nn), int(nj)])
                    rec_t.append(tc[:k])
                    for key, b in zip(("q", "v", "w", "z"), bufs):
                        rec[key].append(np.asarray(b)[:k])
                    if bar is not None:
                        bar.update(float(st.t))
                    if int(stat) != 0:
                        status, fail_t, worst = Status(int(stat)), float(ft), dyn.absolute_row(int(wr))
                        break
                    if request.on_chunk is not None:
                        request.on_chunk(solution(status, "running"))
                    stop.check()
                stop.check()  # a Ctrl-C during the last chunk: the whole run, reported as interrupted
        except KeyboardInterrupt:
            if traced:
                raise
            n = min(len(rec_t), *(len(r) for r in rec.values()))  # drop a chunk recorded in part
            del rec_t[n:]
            for r in rec.values():
                del r[n:]
            status, fail_t = Status.INTERRUPTED, float(rec_t[-1][-1])
        finally:
            if bar is not None:
                bar.stop()
    msg = "success"
    if status == Status.INTERRUPTED:
        msg = f"{status.describe()} at t = {fail_t:.6g} s; the result holds the outputs up to there."
    elif status != Status.SUCCESS:
        msg = _failure_message(system, status, fail_t, worst)
    sol = solution(status, msg)
    if traced:  # status, failure time and counters as arrays (a Result's own fields need concrete values)
        sol.traced_status = (tr_status, tr_ft, tr_stats)
    return sol


def _failure_message(system, status, t, worst):
    topo = system.topo
    where = "unknown element"
    if worst is not None:
        if worst >= topo.nq:
            elem, lab = topo.ct.labels[worst - topo.nq]
            where = f"constraint '{elem}' ({lab})"
        else:
            b = min(worst // 7, topo.nbody - 1)
            where = f"part '{topo.body_names[b]}'"
            near = [g for g in topo.extensions if hasattr(g, "elements_on_body")]
            names = sorted({n for g in near for n in g.elements_on_body(topo.body_names[b])})
            if names:
                where += f" (contact/element: {', '.join(names)})"
    return f"{status.describe()} at t = {t:.6g} s; worst offender: {where}."


def _register():
    from .base import RUNNERS

    RUNNERS["alpha"] = run_alpha


_register()
