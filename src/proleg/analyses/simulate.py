"""Dynamic simulation (Adams SIMULATE/DYNAMIC): the driver over the integrator protocol
(solvers/base.py). It checks the arguments, picks the method (``integrator="auto"``,
solvers/auto.py) or takes the one named, hands it a :class:`~proleg.solvers.base.RunRequest`
and turns its :class:`~proleg.solvers.base.Solution` into a :class:`Result`."""

from __future__ import annotations

import dataclasses
import math
import sys
from dataclasses import dataclass

import jax
import jax.numpy as jnp
import numpy as np

from ..assembly.system import System
from ..errors import Interrupted, ModelError, SolverError, Status
from ..solvers import driver as _driver  # noqa: F401  (registers the α-methods' run loop)
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
    if integrator is None or isinstance(integrator, str):
        from ..solvers.auto import Auto

        integrator = Auto()
    run = run if run is not None else RunOptions()
    unknown = sorted(set(flat) - set(_INTEGRATOR_KEYS) - set(_RUN_KEYS) - {"jacobian_refresh"})
    if unknown:
        raise TypeError(f"simulate() got unexpected keyword argument(s) {unknown}.")
    integ = {k: flat[k] for k in _INTEGRATOR_KEYS if k in flat}
    if "jacobian_refresh" in flat:  # False forced a fresh matrix every step: no reuse
        integ["jacobian_reuse"] = bool(integ.get("jacobian_reuse", getattr(integrator, "jacobian_reuse", False)) and flat["jacobian_refresh"])
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
                    f"release: pass {arg}={cls}({new}).", DeprecationWarning, stacklevel=5,
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
    integrator="auto",
    coordinates: str = "auto",
    q0=None,
    v0=None,
    run: RunOptions | None = None,
    progress: bool | None = None,
    throw: bool | None = None,
    on_chunk=None,
    store=None,
    **options,
) -> Result:
    """Integrate ``system`` from ``t0`` to ``t_end``; outputs every ``dt_output`` (or at ``output_times``).

    Parameters
    ----------
    t_end, t0 : float [s]
    dt_output : float [s], optional — output spacing (default (t_end − t0)/500); or
        ``output_times`` (strictly increasing [s]), or ``saveat=SaveAt(dt=..., times=...)``.
        Outputs do not limit the steps: they come from the steps' dense output.
    integrator : "auto" (default: :class:`proleg.Auto` picks the method from the model —
        solvers/auto.py has the table: Tsit5 on joint coordinates for smooth loop-free trees,
        Radau5 for closed loops at tight tolerances, generalized-α for contacts, stiff and
        switching elements, controllers and flexible bodies), or any
        :class:`proleg.AbstractIntegrator` carrying its options:
        :class:`GeneralizedAlpha`, :class:`HHT`, :class:`Tsit5`, :class:`Dopri5`,
        :class:`Kvaerno5`, :class:`Radau5`, or your own subclass (solvers/base.py).
        ``result.stats["integrator"]`` says what ran and why.
    rtol, atol, dt_init, dt_min, dt_max, fixed_step : options for the method ``"auto"`` picks
        (:class:`proleg.Auto`), e.g. ``simulate(system, 1.0, rtol=1e-9)``. With a named
        integrator they are deprecated (one release): give them to the integrator object.
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
        ``result.coordinates`` says which ran. The order-5 ODE methods always run on joint
        coordinates.
    q0, v0 : initial coordinates and velocities (default: the modelled pose and velocities),
        made consistent with the constraints
    run : :class:`RunOptions` (progress, throw, on_chunk, chunk, free_running); ``progress``,
        ``throw`` and ``on_chunk`` may also be given directly
    device : None (default: a single run goes to the CPU even where JAX's default device is a
        GPU, which is ~8× slower for one variant; inside ``jit``/``vmap`` JAX places it), a
        platform name ("cpu", "gpu", ...), "default", or a ``jax.Device`` (analyses/placement.py)

    Works under ``jax.vmap`` and ``jax.jacfwd`` (the Python loop over chunks is static).
    """
    from ..solvers.auto import Auto
    from ..solvers.base import AbstractIntegrator, RunRequest

    times_in = saveat.times if saveat is not None else output_times
    dt_out = saveat.dt if saveat is not None else dt_output
    integrator, run = _resolve(integrator, run, options)
    ig = integrator
    check_simulate(system, dict(
        t_end=t_end, t0=t0, dt_output=dt_out, output_times=times_in, q0=q0, v0=v0, store=store,
        **{k: getattr(ig, k) for k in ("rtol", "atol", "atol_p", "dt_init", "dt_min", "dt_max", "fixed_step", "max_newton") if hasattr(ig, k)},
        chunk=run.chunk,
    ))
    progress = run.progress if progress is None else progress
    throw = run.throw if throw is None else throw
    on_chunk = run.on_chunk if on_chunk is None else on_chunk
    if store is not None:
        on_chunk = ChunkStore(store, on_chunk)
    if saveat is None:
        saveat = SaveAt(dt=dt_output, times=output_times)
    if saveat.times is not None:
        times = saveat.output_times(t0, t_end)
        t0 = float(times[0]) if t0 == 0.0 and times[0] > 0 else t0
    if not t_end > t0:
        raise ValueError(f"t_end ({t_end}) must be greater than t0 ({t0}).")
    if saveat.times is None:
        times = saveat.output_times(t0, t_end)
    if isinstance(ig, Auto):
        ig, why = ig.choose(system, float(times[-1]) - t0, coordinates)
    elif isinstance(ig, AbstractIntegrator):
        why = "named by the caller"
    else:
        raise ModelError(f"simulate: integrator must be 'auto' or a proleg integrator (GeneralizedAlpha(), Tsit5(), Radau5(), ... or a "
                         f"subclass of proleg.AbstractIntegrator), got {integrator!r}.")
    if ig.coordinates == "joint" and coordinates not in ("auto", "joint"):
        raise ModelError(f"simulate: {type(ig).__name__} runs on joint coordinates, but coordinates='{coordinates}' was asked for. "
                         "Leave coordinates='auto', or use GeneralizedAlpha or Radau5 for other coordinates.")
    traced_in = _any_traced((system.params, q0, v0))
    z0 = initial_z(system)
    post = _compile_post(system, len(times), z0) if not traced_in and run.prepare_outputs else None
    bar = _Bar(system.topo.name, progress) if not traced_in and progress is not False else None
    request = RunRequest(
        t0=float(t0), times=times, q0=q0, v0=v0, coordinates=coordinates, breakpoints=motion_breakpoints(system),
        chunk=run.chunk, free_running=run.free_running,
        on_chunk=None if on_chunk is None else (lambda sol: on_chunk(_result(system, sol, ig, why))),
        progress=bar, on_start=lambda q, v, z: _warn_unstable_servos(system, q, v, t0, z),
    )
    sol = ig.run(system, request)
    result = _result(system, sol, ig, why)
    if post is not None and len(result.t) == len(times):
        result._compiled_post = post
    traced = sol.traced_status is not None
    if traced:  # status, failure time and counters as arrays (a Result's own fields need concrete values)
        result.traced_status = sol.traced_status
    else:
        # the same tuple from the concrete run: a batched caller (sweep, study) whose batch does
        # not reach the state (one variant, nothing varied) runs this path under vmap and reads it
        st = result.stats
        result.traced_status = (np.asarray(int(result.status)), np.asarray(float(result.t[-1]) if len(result.t) else float(t0)),
                                np.asarray([st["steps"], st["rejected"], st["newton_iterations"], st["jacobians"]], np.int32))
        q_ic, v_ic = sol.start
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
    if not traced:
        _warn_stick_slip(system, result)
    if isinstance(on_chunk, ChunkStore) and not traced:
        on_chunk.write(result)  # the last chunk, or the one that failed
    if result.status == Status.INTERRUPTED:
        raise Interrupted(f"simulate of '{system.topo.name}': {result.message}", result)
    if result.status != Status.SUCCESS and throw:
        raise SolverError(result.message, result)
    return result


def _resolve(integrator, run, options):
    """(integrator or Auto, RunOptions) from simulate's ``integrator``, ``run`` and flat options."""
    from ..solvers.auto import Auto

    run = run if run is not None else RunOptions()
    if integrator is None or (isinstance(integrator, str) and integrator == "auto"):
        integrator = Auto()
    elif isinstance(integrator, str):
        raise ModelError(f"simulate: integrator={integrator!r} is not a method name; give 'auto' or an integrator object, "
                         "e.g. proleg.Tsit5(), proleg.Radau5(), proleg.GeneralizedAlpha().")
    if not options:
        return integrator, run
    if isinstance(integrator, Auto):
        flat = dict(options)
        runk = {k: flat.pop(k) for k in _RUN_KEYS if k in flat}
        if "jacobian_refresh" in flat:  # False forced a fresh matrix every step: no reuse
            flat["jacobian_reuse"] = bool(flat.get("jacobian_reuse", False) and flat.pop("jacobian_refresh"))
        names = {f.name for f in dataclasses.fields(Auto)}
        unknown = sorted(set(flat) - names)
        if unknown:
            raise TypeError(f"simulate() got unexpected keyword argument(s) {unknown}.")
        if runk:
            _, run = simulate_options(integrator=None, run=run, warn=True, **runk)
        return dataclasses.replace(integrator, **flat), run
    fields = {f.name for f in dataclasses.fields(integrator)} if dataclasses.is_dataclass(integrator) else set()
    from ..solvers.galpha import AbstractAlphaIntegrator

    if not isinstance(integrator, AbstractAlphaIntegrator):
        bad = sorted(k for k in options if k not in fields and k not in _RUN_KEYS)
        if bad:
            raise ModelError(f"simulate: {bad} are not options of {type(integrator).__name__} "
                             f"(give its options to the integrator object, e.g. {type(integrator).__name__}(rtol=1e-8)).")
        flat = {k: v for k, v in options.items() if k in fields}
        _warn_flat(type(integrator).__name__, list(flat), "integrator")
        _, run = simulate_options(integrator=None, run=run, warn=True, **{k: v for k, v in options.items() if k in _RUN_KEYS})
        return dataclasses.replace(integrator, **flat), run
    return simulate_options(integrator, run, warn=True, **options)


def _warn_flat(cls, keys, arg):
    if keys:
        import warnings

        warnings.warn(
            f"simulate({', '.join(k + '=...' for k in keys)}) is deprecated and will be removed in the next "
            f"release: pass {arg}={cls}({', '.join(k + '=...' for k in keys)}).", DeprecationWarning, stacklevel=5,
        )


def _result(system, sol, integrator, why) -> Result:
    r = Result(system, sol.t, sol.q, sol.v, sol.w, sol.z, stats=sol.stats, status=sol.status, message=sol.message, integrator=integrator)
    r.coordinates = sol.coordinates
    r.stats["integrator"] = integrator.describe()
    r.stats["integrator_reason"] = why
    return r


class _Bar:
    """The run's progress bar (analyses/progress.py :class:`RunProgress`: "compiling…" until the
    first chunk returns), shown when asked, or when stderr is a terminal and the run has several
    chunks. The integrator's run calls start/update/stop (solvers/base.py RunRequest.progress)."""

    def __init__(self, name, show):
        self.name, self.show, self.bar = name, show, None

    def start(self, nchunks, t0, t_end):
        show = self.show if self.show is not None else (sys.stderr.isatty() and nchunks > 1)
        if show:
            from .progress import RunProgress

            self.bar = RunProgress(self.name, t0, t_end).start()

    def update(self, t):
        if self.bar is not None:
            self.bar.update(t)

    def stop(self):
        if self.bar is not None:
            self.bar.stop()


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


#: a run that rejects at least this fraction of its step attempts (and at least STICK_SLIP_MIN_REJECTED
#: steps) with a friction contact in the model gets :func:`_warn_stick_slip`'s warning
STICK_SLIP_REJECTED = 0.25
STICK_SLIP_MIN_REJECTED = 200


def _warn_stick_slip(system, result):
    """One ProlegWarning when a run with friction contacts rejected many of its steps: near a
    contact's stick–slip transition the friction force swings between ±μF_n within v_stiction,
    a tangential stiffness of about μ F_n / v_stiction that the error control resolves with tiny,
    often rejected steps (issue 43: a planar leg's 1 s drop took 118,758 steps, 42,759 of them
    rejected, at v_stiction = 1 mm/s, v_friction = 1 cm/s, and 1,240 steps at 1 and 5 cm/s).
    Reads the step counters the driver keeps; nothing is computed."""
    st = result.stats
    ns, nr = int(st.get("steps", 0)), int(st.get("rejected", 0))
    if nr < STICK_SLIP_MIN_REJECTED or nr < STICK_SLIP_REJECTED * (ns + nr):
        return
    model = getattr(system.topo, "model", None)
    slip = [c for c in getattr(model, "contacts", ()) if float(getattr(c, "mu_static", 0.0) or 0.0) > 0 and hasattr(c, "v_stiction")]
    if not slip:
        return
    import warnings

    from ..errors import ProlegWarning

    slip.sort(key=lambda c: float(c.v_stiction))
    named = ", ".join(f"'{c.name}' (v_stiction {c.v_stiction:g}, v_friction {c.v_friction:g} m/s)" for c in slip[:4])
    more = f" and {len(slip) - 4} more" if len(slip) > 4 else ""
    warnings.warn(
        f"simulate of '{system.topo.name}': {nr} of {ns + nr} steps were rejected ({100 * nr / (ns + nr):.0f} %), with friction "
        f"contacts {named}{more}. Near a stick–slip transition the friction force changes by μ·F_n within v_stiction, which "
        "the step control resolves with tiny steps. Larger transition velocities (e.g. v_stiction=0.01–0.1, v_friction=0.05–1 m/s) "
        "usually cut the steps many-fold at the price of a slow creep (about v_stiction · F_t/(μ F_n)).",
        ProlegWarning, stacklevel=4,  # the caller of simulate (through @placed)
    )
