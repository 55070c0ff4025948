"""Adaptive (or fixed-step) time stepping over a chunk of output times, as one compiled loop.

The loop is a ``lax.while_loop`` that chooses between accept and reject (note §4, §7): the
step is a pure function of (state, h), so a rejection simply retries from the same state with
a smaller h. Steps are clipped to output times and to controller sample times, so outputs are
exact solver states, and controllers see zero-order-held inputs.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import partial

import jax
import jax.numpy as jnp

from ..errors import Status
from .galpha import StepOptions, StepState, step


@dataclass(frozen=True)
class DriverOptions:
    step: StepOptions = StepOptions()
    dt_min: float = 1e-10
    dt_max: float = 1e-2
    fixed_step: float | None = None
    max_steps: int = 2_000_000  # per chunk
    sample_period: float | None = None  # controller clock [s]


def sample_controllers(system, t, q, v, z, first=False):
    """Controller sample: z ← update(t, q, v, z) for every sampled element."""
    for g in system.topo.extensions:
        if hasattr(g, "sample"):
            z = g.sample(system.params, t, q, v, z, system, first)
    return z


# Compiled once per model (the System's topology is static): the first sample of a run, or the
# static controller law in statics.
sample_controllers_first = jax.jit(partial(sample_controllers, first=True))


def _sample_update(dyn, st: StepState):
    """A controller sample. The held commands jump, so the accelerations are re-initialised from
    the KKT system at the new commands (like a restart), instead of being smeared over a step."""
    from .initial import kkt_accelerations

    z = sample_controllers(dyn.system, st.t, *dyn.absolute(st.q, st.v), st.z)
    qdd, lam = kkt_accelerations(dyn, st.q, st.v, st.t, z)
    _, vjp = jax.vjp(lambda qq: dyn.constraints(qq, st.t), st.q)
    g = vjp(lam)[0] - dyn.generalized_forces(st.q, st.v, st.t, z)
    return st._replace(z=z, qdd=qdd, a=qdd, lam=lam, g=g, pw=dyn.power_terms(st.q, st.v, st.t, z))


@partial(jax.jit, static_argnums=(1, 2, 7))
def advance(dyn, integrator, dopts: DriverOptions, st: StepState, h, out_times, n_valid, free_running=False):
    """Integrate from ``st`` through ``out_times[:n_valid]``; record q, v, w, z at each.

    ``dyn``: the coordinate set the state is in (assembly/coordinates.py).

    A ``lax.scan`` over the output times with, inside, a ``lax.while_loop`` of step attempts
    up to the next output time: outputs are scan results (no dynamic buffer updates), and
    under ``jax.vmap`` only the small step state is carried per lane by the inner loop.

    ``free_running``: one ``lax.while_loop`` of step attempts over all the output times instead,
    writing each output into its buffer row when reached. Under ``jax.vmap`` the lanes then
    do not wait for each other at every output time (the loop runs as many attempts as the
    slowest lane needs in all, not the sum over outputs of the slowest lane per interval, ~2×
    fewer on bench/vmap_batch.py); one lane's work is the same. ``sweep`` uses it.

    Returns (state, h, number of outputs reached, buffers, stats, status, fail_time, worst_row).
    """
    K = out_times.shape[0]
    fixed = dopts.fixed_step is not None
    Ts = dopts.sample_period
    eps_t = 1e-12

    def reached(t, te):
        return t >= te - eps_t * jnp.maximum(1.0, jnp.abs(te))

    def next_event(t, te):
        if Ts is not None:
            ts = (jnp.floor(t / Ts + 1e-9) + 1.0) * Ts
            te = jnp.minimum(te, ts)
        return te

    def attempt(te, c):
        st, h, (ns, nr, nn, nj), status, ft, worst, rejected = c
        rem = next_event(st.t, te) - st.t
        h_des = jnp.asarray(dopts.fixed_step) if fixed else h
        h_take = jnp.where(h_des >= rem * (1 - 1e-9), rem, jnp.where(2 * h_des > rem, 0.5 * rem, h_des))
        clipped = h_take < h_des
        new, err, iters, conv, wrow, stale_fail, built = step(dyn, integrator, st, h_take, dopts.step)
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
        # Accepted: the new state; rejected: the old one, but with the newest Newton matrix.
        jac_fields = ("Jfac", "jac_h", "jac_ok", "jac_hold", "jac_pen")
        st2 = StepState(*[
            getattr(new, f) if f in jac_fields else jnp.where(accept, getattr(new, f), getattr(st, f)) for f in StepState._fields
        ])
        # Controller sample at its clock ticks.
        if Ts is not None:
            at_tick = accept & (jnp.abs(st2.t / Ts - jnp.round(st2.t / Ts)) < 1e-9 * jnp.maximum(1.0, st2.t / Ts))
            st2 = jax.lax.cond(at_tick, lambda s: _sample_update(dyn, s), lambda s: s, st2)
        too_small = (~accept) & (h_next < dopts.dt_min) if not fixed else ~accept & ~stale_fail
        new_status = jnp.where(
            too_small, jnp.where(conv, int(Status.STEP_TOO_SMALL), int(Status.NEWTON_FAILED)), status
        )
        new_status = jnp.where(ns + nr >= dopts.max_steps, int(Status.MAX_STEPS), new_status)
        ft = jnp.where(too_small, st.t + h_take, ft)
        worst = jnp.where(too_small, wrow, worst)
        stats = (ns + accept.astype(ns.dtype), nr + (~accept).astype(nr.dtype), nn + iters, nj + built.astype(nj.dtype))
        return st2, jnp.maximum(h_next, dopts.dt_min * 0.5), stats, new_status, ft, worst, ~accept

    def reach(carry, xs):
        te, valid = xs
        c, k = carry

        def cond(c):
            st, status = c[0], c[3]
            return valid & (status == 0) & ~reached(st.t, te)

        c = jax.lax.while_loop(cond, partial(attempt, te), c)
        st, status = c[0], c[3]
        k = k + (valid & (status == 0)).astype(k.dtype)
        return (c, k), (st.q, st.v, st.w, st.z)

    z0 = jnp.array(0)
    init = (st, jnp.asarray(h, jnp.float64), (z0, z0, z0, z0), jnp.array(0), st.t * 0.0, z0, jnp.array(False))
    if free_running:

        def cond(c):
            inner, k, _ = c
            return (k < n_valid) & (inner[3] == 0)

        def body(c):
            inner, k, bufs = c
            te = out_times[k]
            inner = attempt(te, inner)
            s = inner[0]
            hit = (inner[3] == 0) & reached(s.t, te)
            bufs = tuple(b.at[k].set(jnp.where(hit, x, b[k])) for b, x in zip(bufs, (s.q, s.v, s.w, s.z)))
            return inner, k + hit.astype(k.dtype), bufs

        bufs0 = tuple(jnp.full((K,) + x.shape, jnp.nan, x.dtype) for x in (st.q, st.v, st.w, st.z))
        (st, h, stats, status, ft, worst, _), k, bufs = jax.lax.while_loop(cond, body, (init, z0, bufs0))
        return st, h, k, bufs, stats, status, ft, worst
    valid = jnp.arange(K) < n_valid
    ((st, h, stats, status, ft, worst, _), k), bufs = jax.lax.scan(reach, (init, z0), (out_times, valid))
    return st, h, k, bufs, stats, status, ft, worst
