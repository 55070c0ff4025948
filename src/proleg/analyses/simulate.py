"""Dynamic simulation (Adams SIMULATE/DYNAMIC): consistent initial conditions, then the
error-controlled implicit integrator over the requested output times."""

from __future__ import annotations

import contextlib
import dataclasses
import math
import sys
from dataclasses import dataclass

import jax
import jax.numpy as jnp
import numpy as np

from ..assembly.coordinates import coordinate_set
from ..assembly.system import System
from ..errors import Interrupted, ModelError, SolverError, Status
from .. import compile_cache
from ..compile_cache import cached_jit
from ..solvers.driver import DriverOptions, knot
from ..solvers.driver import advance as _advance_jit
from ..solvers.galpha import GeneralizedAlpha, StepState
from ..solvers.initial import _consistent_state, consistent_state, initial_z, sample_period  # noqa: F401 (re-exported)
from .checks import check_simulate
from .placement import _any_traced, placed
from .result import ChunkStore, Result


def _ic_report(system, q, v):
    q_user = np.asarray(system.params["q_init"])
    v_user = np.asarray(system.params["v_init"])
    nb = system.topo.nbody
    qa, qu = np.asarray(q)[: 7 * nb].reshape(nb, 7), q_user[: 7 * nb].reshape(nb, 7)
    va, vu = np.asarray(v)[: 7 * nb].reshape(nb, 7), v_user[: 7 * nb].reshape(nb, 7)
    out = []
    for b, name in enumerate(system.topo.body_names):
        pu = qu[b, 3:] / np.linalg.norm(qu[b, 3:])
        dr = float(np.linalg.norm(qa[b, :3] - qu[b, :3]))
        dp = float(2 * min(np.linalg.norm(qa[b, 3:] - pu), np.linalg.norm(qa[b, 3:] + pu)))
        dv = float(np.linalg.norm(va[b, :3] - vu[b, :3]))
        if max(dr, dp, dv) > 1e-9:
            out.append({"part": name, "moved [m]": dr, "rotated [rad]": dp, "velocity change [m/s]": dv})
    return out


def motion_breakpoints(system: System) -> tuple:
    """Times [s] where a motion law's derivatives jump, as declared by ``Motion(breakpoints=...)``:
    the integrator steps to each exactly instead of interpolating across it."""
    return tuple(sorted({float(b) for o in system.topo.ct.owners for b in (getattr(o, "breakpoints", None) or ())}))


@dataclass(frozen=True)
class SaveAt:
    """Which outputs :func:`simulate` returns (Diffrax's ``SaveAt``): every ``dt`` [s] from t0 to
    t_end (plus t_end), or at the strictly increasing ``times`` [s]. Outputs between steps come
    from the dense output of the steps (solvers/driver.py), so asking for many costs little."""

    dt: float | None = None
    times: tuple | np.ndarray | None = None

    def output_times(self, t0: float, t_end: float) -> np.ndarray:
        if self.times is not None:
            times = np.asarray(self.times, float).ravel()
            if times.size == 0 or np.any(np.diff(times) <= 0) or not np.all(np.isfinite(times)):
                raise ModelError("SaveAt times (output_times) must be finite and strictly increasing [s].")
            return times
        dt = (t_end - t0) / 500.0 if self.dt is None else float(self.dt)
        if not dt > 0:
            raise ModelError(f"SaveAt dt (dt_output) must be positive [s], got {self.dt}.")
        n = int(math.floor((t_end - t0) / dt + 1e-9))
        times = t0 + dt * np.arange(n + 1)
        if times[-1] < t_end - 1e-12 * max(1.0, abs(t_end)):
            times = np.append(times, t_end)
        return times


@dataclass(frozen=True)
class RunOptions:
    """How :func:`simulate` runs (not what it computes).

    Parameters
    ----------
    progress : show a progress bar (default: on when stderr is a terminal and the run has
        several chunks)
    throw : raise :class:`SolverError` on failure (its ``.result`` holds what was computed);
        otherwise return a Result whose ``status``/``message`` say what happened
    on_chunk : callable(Result) called after each chunk (e.g. to write partial results)
    chunk : output times per compiled call: the unit of progress, ``on_chunk`` and
        interruption. Default: 2048 (256 blocks of ``DriverOptions.out_block`` outputs), every
        call padded to that length so that all runs of a model share one compiled loop whatever
        their output times (with ``free_running``: at most 2048, not padded)
    free_running : under ``jax.vmap``, let each variant step through all its output times
        without waiting for the others at each one (solvers/driver.py ``advance``; what
        :func:`proleg.sweep` uses); the same results, ~2× fewer batch iterations
    prepare_outputs : compile the post-processing of the outputs (accelerations, multipliers,
        joint reactions, element outputs, energies: analyses/result.py ``post_batch``) in a
        second thread while the run compiles and runs, so that the first ``result.to_frame()``
        (or ``.joint()``, ``.element()``, ``.energy``) compiles nothing. Default: on for a
        single (not traced) run. Off saves that compile where only states are read.
    """

    progress: bool | None = None
    throw: bool = True
    on_chunk: object = None
    chunk: int | None = None
    free_running: bool = False
    prepare_outputs: bool = True


# Old keyword spellings of simulate (one release, with a DeprecationWarning): where they live now.
_INTEGRATOR_KEYS = ("rtol", "atol", "atol_p", "dt_init", "dt_min", "dt_max", "fixed_step", "max_newton", "jacobian_reuse", "lu_per_lane")
_RUN_KEYS = ("chunk", "free_running")


def simulate_options(integrator=None, run=None, *, warn: bool = False, **flat):
    """Group flat options (``rtol=``, ``dt_max=``, ``chunk=``, ...) into the integrator object and
    :class:`RunOptions`; returns (integrator, run). For option dictionaries from files (a study's
    or model file's ``simulate:`` section), where flat keys are the format; :func:`simulate`
    itself accepts them for one release with a DeprecationWarning (``warn=True``)."""
    integrator = integrator if integrator is not None else GeneralizedAlpha()
    run = run if run is not None else RunOptions()
    unknown = sorted(set(flat) - set(_INTEGRATOR_KEYS) - set(_RUN_KEYS) - {"jacobian_refresh"})
    if unknown:
        raise TypeError(f"simulate() got unexpected keyword argument(s) {unknown}.")
    integ = {k: flat[k] for k in _INTEGRATOR_KEYS if k in flat}
    if "jacobian_refresh" in flat:  # False forced a fresh matrix every step: no reuse
        integ["jacobian_reuse"] = bool(integ.get("jacobian_reuse", integrator.jacobian_reuse) and flat["jacobian_refresh"])
    runk = {k: flat[k] for k in _RUN_KEYS if k in flat}
    if warn:
        import warnings

        iname = type(integrator).__name__
        old_i = [k for k in flat if k not in _RUN_KEYS]
        old_r = [k for k in flat if k in _RUN_KEYS]
        for keys, cls, arg in ((old_i, iname, "integrator"), (old_r, "RunOptions", "run")):
            if keys:
                new = ", ".join(f"{'jacobian_reuse' if k == 'jacobian_refresh' else k}=..." for k in keys)
                warnings.warn(
                    f"simulate({', '.join(k + '=...' for k in keys)}) is deprecated and will be removed in the next "
                    f"release: pass {arg}={cls}({new}).", DeprecationWarning, stacklevel=4,
                )
    if integ:
        integrator = dataclasses.replace(integrator, **integ)
    if runk:
        run = dataclasses.replace(run, **runk)
    return integrator, run


def simulate_kwargs(kw: dict) -> dict:
    """``kw`` for :func:`simulate` with flat option keys (``rtol``, ``dt_max``, ``chunk``, ...)
    moved into ``integrator=`` and ``run=`` (no warning: for option dictionaries from files and
    studies, whose flat keys are their format)."""
    old = set(_INTEGRATOR_KEYS) | set(_RUN_KEYS) | {"jacobian_refresh"}
    flat = {k: v for k, v in kw.items() if k in old}
    if not flat:
        return dict(kw)
    rest = {k: v for k, v in kw.items() if k not in old}
    integrator, run = simulate_options(rest.pop("integrator", None), rest.pop("run", None), **flat)
    return {**rest, "integrator": integrator, "run": run}


@placed
def simulate(
    system: System,
    t_end: float,
    dt_output: float | None = None,
    *,
    t0: float = 0.0,
    output_times=None,
    saveat: SaveAt | None = None,
    integrator=None,
    coordinates: str = "auto",
    q0=None,
    v0=None,
    run: RunOptions | None = None,
    progress: bool | None = None,
    throw: bool | None = None,
    on_chunk=None,
    store=None,
    **deprecated,
) -> Result:
    """Integrate ``system`` from ``t0`` to ``t_end``; outputs every ``dt_output`` (or at ``output_times``).

    Parameters
    ----------
    t_end, t0 : float [s]
    dt_output : float [s], optional — output spacing (default (t_end − t0)/500); or
        ``output_times`` (strictly increasing [s]), or ``saveat=SaveAt(dt=..., times=...)``.
        Outputs do not limit the steps: they come from the steps' dense output.
    integrator : :class:`GeneralizedAlpha` (default, ρ∞ = 0.8) or :class:`HHT`, carrying its
        options: tolerances, step limits, fixed step, Newton settings
        (:class:`proleg.solvers.galpha.AbstractIntegrator`), e.g.
        ``GeneralizedAlpha(rtol=1e-8, atol=1e-9, dt_max=1e-3)``; or :class:`Tsit5`, :class:`Dopri5`,
        :class:`Kvaerno5` (order 5, Diffrax, error control on positions and velocities) for
        loop-free trees, which run in joint coordinates (solvers/ode.py, analyses/ode.py); or
        :class:`Radau5` (order 5, implicit, the index-2 constrained equations in any coordinates:
        closed loops, stiff models; solvers/radau.py)
    store : path, optional — stream the outputs to a Parquet dataset (a folder of one file per
        chunk, each written atomically) as the run goes; ``pandas.read_parquet(store)`` reads what
        was finished even if the process died (:class:`proleg.analyses.result.ChunkStore`);
        :func:`proleg.read_store` rebuilds the Result. Ctrl-C raises :class:`proleg.Interrupted`
        whose ``.result`` holds the finished chunks.
    coordinates : "auto" (default), "absolute", "planar" or "joint" — the coordinates the integrator
        runs on (assembly/coordinates.py). "auto" runs a planar mechanism (one whose joints confine
        every part to a plane: ``system.topo.planar`` says whether and why) on 3 coordinates per
        part, an exact reduction, several times faster; "joint" runs joint coordinates of the
        joints' spanning tree (assembly/joint_coordinates.py); results are always absolute.
        ``result.coordinates`` says which ran. "auto" never picks "joint": measured slower
        including compile on every model tried (assembly/coordinates.py ``auto_coordinates``
        has the figures).
    q0, v0 : initial coordinates and velocities (default: the modelled pose and velocities),
        made consistent with the constraints
    run : :class:`RunOptions` (progress, throw, on_chunk, chunk, free_running); ``progress``,
        ``throw`` and ``on_chunk`` may also be given directly
    device : None (default: a single run goes to the CPU even where JAX's default device is a
        GPU, which is ~8× slower for one variant; inside ``jit``/``vmap`` JAX places it), a
        platform name ("cpu", "gpu", ...), "default", or a ``jax.Device`` (analyses/placement.py)

    The keywords ``rtol, atol, atol_p, dt_init, dt_min, dt_max, fixed_step, max_newton,
    jacobian_reuse, jacobian_refresh, lu_per_lane`` (now options of the integrator) and
    ``chunk, free_running`` (now :class:`RunOptions`) still work for one release, with a
    DeprecationWarning naming the new place.

    Works under ``jax.vmap`` and ``jax.jacfwd`` (the Python loop over chunks is static).
    """
    times = saveat.times if saveat is not None else output_times  # the Radau5 and ODE paths' output request
    dt_out = saveat.dt if saveat is not None else dt_output
    if getattr(integrator, "dae", False):  # Radau5: index-2 constrained equations (analyses/radau.py)
        from .radau import simulate_radau

        check_simulate(system, dict(t_end=t_end, dt_output=dt_out, t0=t0, output_times=times, q0=q0, v0=v0))
        if deprecated:
            raise ModelError(f"simulate: {sorted(deprecated)} are not keywords of simulate with Radau5: give them to the "
                             "integrator object, e.g. Radau5(rtol=1e-8, dt_max=1e-3).")
        return simulate_radau(system, t_end, dt_out, t0=t0, output_times=times, integrator=integrator, coordinates=coordinates,
                              q0=q0, v0=v0, breakpoints=motion_breakpoints(system), throw=True if throw is None else throw)
    if getattr(integrator, "ode", False):  # Tsit5, Dopri5, Kvaerno5: joint-coordinate ODE (analyses/ode.py)
        from .ode import simulate_ode

        check_simulate(system, dict(t_end=t_end, dt_output=dt_out, t0=t0, output_times=times, q0=q0, v0=v0,
                                    dt_max=deprecated.get("dt_max"), fixed_step=deprecated.get("fixed_step")))
        unknown = sorted(set(deprecated) - {"dt_max", "fixed_step"})
        if unknown:
            raise ModelError(f"simulate: {unknown} are options of GeneralizedAlpha/HHT, not of {type(integrator).__name__} "
                             "(give rtol/atol to the integrator object, e.g. Tsit5(rtol=1e-8)).")
        return simulate_ode(
            system, t_end, dt_out, t0=t0, output_times=times, integrator=integrator, q0=q0, v0=v0,
            dt_max=deprecated.get("dt_max"), fixed_step=deprecated.get("fixed_step"), throw=True if throw is None else throw,
        )
    integrator, run = simulate_options(integrator, run, warn=True, **deprecated)
    ig = integrator
    check_simulate(system, dict(
        t_end=t_end, t0=t0, dt_output=saveat.dt if saveat is not None else dt_output,
        output_times=saveat.times if saveat is not None else output_times, q0=q0, v0=v0, store=store,
        rtol=ig.rtol, atol=ig.atol, atol_p=ig.atol_p, dt_init=ig.dt_init, dt_min=ig.dt_min, dt_max=ig.dt_max,
        fixed_step=ig.fixed_step, max_newton=ig.max_newton, chunk=run.chunk,
    ))
    progress = run.progress if progress is None else progress
    throw = run.throw if throw is None else throw
    on_chunk = run.on_chunk if on_chunk is None else on_chunk
    if store is not None:
        on_chunk = ChunkStore(store, on_chunk)
    chunk, free_running = run.chunk, run.free_running
    if saveat is None:
        saveat = SaveAt(dt=dt_output, times=output_times)
    if saveat.times is not None:
        times = saveat.output_times(t0, t_end)
        t0 = float(times[0]) if t0 == 0.0 and times[0] > 0 else t0
    if not t_end > t0:
        raise ValueError(f"t_end ({t_end}) must be greater than t0 ({t0}).")
    if saveat.times is None:
        times = saveat.output_times(t0, t_end)
    fixed_step = ig.fixed_step
    dopts = DriverOptions(
        step=ig.step_options(),
        dt_min=float(ig.dt_min),
        # a static option: strip round-off so t_end changes do not recompile
        dt_max=float(ig.dt_max if ig.dt_max is not None else f"{min(t_end - t0, 1e-2):.10g}"),
        fixed_step=None if fixed_step is None else float(fixed_step),
        sample_period=sample_period(system),
        breakpoints=motion_breakpoints(system),
    )
    dt_init = ig.dt_init
    integrator = ig.method  # what the compiled step depends on; the options are in dopts
    z0 = initial_z(system)
    post = None
    trail = contextlib.ExitStack()  # closed in the finally below
    if not _any_traced((system.params, q0, v0)):
        # the executables this run loads, for a later process to start loading early
        trail.enter_context(compile_cache.trail(system, coordinates, integrator, dopts, len(times), run.chunk,
                                                free_running, q0 is None, v0 is None))
        if run.prepare_outputs:
            post = _compile_post(system, len(times), z0)
    try:
        q, v, qdd, lam, z0, (pw, g0) = _consistent_state(system, q0, v0, t0, z0)
        q_ic, v_ic = q, v
        traced = _any_traced((system.params, q))
        if not traced:
            _warn_unstable_servos(system, q, v, t0, z0)
        dyn = coordinate_set(system, q, coordinates)
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
        h = np.asarray(dt_init if dt_init is not None else (fixed_step or min(1e-4, dopts.dt_max)), f64)
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
        show = progress if progress is not None else (sys.stderr.isatty() and nchunks > 1 and not traced)
        bar = None
        if show and not traced:
            from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

            bar = Progress(TextColumn(f"[bold]{system.topo.name}[/] t ="), TextColumn("{task.fields[t]:.4f} s"), BarColumn(), TimeElapsedColumn(), transient=True)
            bar.start()
            task = bar.add_task("sim", total=float(t_end - t0), t=t0)
        partial_result = None
        tr_status, tr_ft, tr_stats = np.asarray(0), np.asarray(t0, f64), np.zeros(4, i32)
        try:
            for c in range(nchunks):
                tc = out_t[c * K : (c + 1) * K]
                n_valid = len(tc)
                tpad = np.concatenate([tc, np.full(K - n_valid, tc[-1])])
                st, h, k, bufs, (ns, nr, nn, nj), stat, ft, wr, seg = advance(
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
                    bar.update(task, completed=float(st.t) - t0, t=float(st.t))
                if int(stat) != 0:
                    status, fail_t, worst = Status(int(stat)), float(ft), dyn.absolute_row(int(wr))
                    break
                if on_chunk is not None:
                    partial_result = _build(system, rec_t, rec, stats, status, "running", ig)
                    on_chunk(partial_result)
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
        result = _build(system, rec_t, rec, stats, status, msg, ig)
        result.coordinates = dyn.kind
        if post is not None and len(result.t) == len(times):
            result._compiled_post = post
        if traced:  # status, failure time and counters as arrays (a Result's own fields need concrete values)
            result.traced_status = (tr_status, tr_ft, tr_stats)
        if not traced:
            result.initial_changes = _ic_report(system, q_ic, v_ic) if q0 is None and v0 is None else []
            moved = [c for c in result.initial_changes if max(c["moved [m]"], c["rotated [rad]"]) > 1e-6]
            if moved:
                import warnings

                warnings.warn(
                    f"Initial conditions of '{system.topo.name}': to satisfy the joints, proleg moved "
                    + ", ".join(f"'{c['part']}' by {c['moved [m]']:.3g} m / {c['rotated [rad]']:.3g} rad" for c in moved)
                    + " from the modelled pose (result.initial_changes lists all changes).",
                    stacklevel=2,
                )
        if isinstance(on_chunk, ChunkStore) and not traced:
            on_chunk.write(result)  # the last chunk, or the one that failed
        if status == Status.INTERRUPTED:
            raise Interrupted(f"simulate of '{system.topo.name}': {msg}", result)
        if status != Status.SUCCESS and throw:
            raise SolverError(msg, result)
        return result
    finally:
        trail.close()


_POST_POOL = None


def _compile_post(system, n: int, z0):
    """Start compiling the outputs' post-processing for ``n`` outputs in a second thread (on the
    device this call runs on); returns a Future of the compiled executable."""
    global _POST_POOL
    from concurrent.futures import ThreadPoolExecutor

    from .result import element_units, post_batch

    if _POST_POOL is None:
        _POST_POOL = ThreadPoolExecutor(1, thread_name_prefix="proleg-outputs")
    dev = jax.config.jax_default_device
    f64 = jnp.float64
    shapes = (jax.ShapeDtypeStruct((n, system.nq), f64), jax.ShapeDtypeStruct((n, system.nq), f64),
              jax.ShapeDtypeStruct((n,), f64), jax.ShapeDtypeStruct((n, z0.shape[0]), z0.dtype))

    def compile_():
        if dev is None:
            fn = post_batch.compile_for(system, *shapes)
        else:
            with jax.default_device(dev):
                fn = post_batch.compile_for(system, *shapes)
        # the rest of what the first table needs, while the run goes on
        element_units(system, z0.shape[0])
        import pandas  # noqa: F401  (~0.3 s)

        return fn

    return _POST_POOL.submit(compile_)


def _warn_unstable_servos(system, q, v, t0, z0):
    """A warning for each PID that is unstable as sampled (control/servo.py): such a servo rings
    at half its sample rate, and the run crawls with tiny steps without saying why."""
    import warnings

    from ..control.servo import servo_stability, servo_warnings

    for msg in servo_warnings(servo_stability(system, q, v, t0, z0)):
        warnings.warn(msg, stacklevel=3)


@cached_jit
def _reduced_start(dyn, q, v, qdd, lam):
    """The consistent absolute start (q, v, q̈, λ) in the coordinates ``dyn`` (x, ẋ, ẍ, λ_x) and
    the HHT history term g = Φ_xᵀλ_x − Q = −M ẍ."""
    x, xd = dyn.reduce(q, v)
    xdd = dyn.reduce_acceleration(x, xd, qdd, q)
    return x, xd, xdd, dyn.reduce_multipliers(lam), -dyn.mass_action(x, xdd)


def _advance_absolute(dyn, integrator, dopts, st, h, out_times, n_valid, free_running=False, t_stop=None, seg=None):
    """The integration loop (solvers/driver.py ``advance``) with its recorded (q, v) in absolute
    coordinates: one executable (a separate conversion was one more compile and load per model)."""
    out = _advance_jit(dyn, integrator, dopts, st, h, out_times, n_valid, free_running, t_stop, seg)
    if dyn.kind == "absolute":
        return out
    bufs = out[3]
    q, v = jax.vmap(dyn.absolute)(bufs[0], bufs[1])
    return (*out[:3], (q, v, *bufs[2:]), *out[4:])


_advance_absolute.__name__ = "advance"  # JAX's compile logs and the cache files name the loop
# The integration loop, its trace and lowering kept across processes.
advance = cached_jit(_advance_absolute, static_argnums=(1, 2, 7), xla="loop")


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


def _build(system, rec_t, rec, stats, status, msg, integrator):
    t = np.concatenate(rec_t)
    xp = jnp if _any_traced(rec) else np
    arrs = {k: xp.concatenate(v, 0) for k, v in rec.items()}
    return Result(system, t, arrs["q"], arrs["v"], arrs["w"], arrs["z"], stats=stats, status=status, message=msg, integrator=integrator)
