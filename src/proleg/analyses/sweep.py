"""Parameter sweeps: many variants of one model in one compiled, vectorised run (``jax.vmap``).

``sweep(system, {"spring.stiffness": ks}, t_end=1.0)`` simulates one variant per value (the
model's structure is shared, so there is one compilation) and returns a :class:`SweepResult`:
``len(res)`` variants, ``res.status`` / ``res.stats`` per variant, ``res[i]`` the i-th variant's
ordinary :class:`~proleg.analyses.result.Result` (every output accessor), and ``res.to_frame()``
a long pandas table with the swept values beside each variant's outputs.

The method is :func:`proleg.simulate`'s: with no integrator named, the one ``simulate`` would
choose for the model and the run (:func:`batch_integrator`, the same chooser), so ``res[i]`` is
``simulate(system.with_params(row_i))`` to round-off: the same method, steps and tolerances.
``res.integrator`` and ``res.integrator_reason`` say which and why; ``res.integrator_note`` is
set (and a warning issued) where the batch had to run another method.

Speed on the CPU. proleg turns XLA-CPU's YNNPACK fusions off at import
(``proleg.XLA_CPU_DEFAULTS``): under ``vmap`` the small 3×3 products of the element code become
batched dots that YNNPACK runs lane by lane (1–2 ms per fusion for 1,000 lanes); the plain XLA
loops are ~3× faster per lane-step on the bench model (bench/vmap_batch.py). Batches run
concurrently, up to one fewer than the cores (``workers``, :func:`max_concurrent_batches`: a
batched LAPACK call needs a free thread of XLA's pool), each factoring its Newton matrices
lane by lane (``GeneralizedAlpha(lu_per_lane=True)``, for the α-methods). Each variant steps
through its output times on its own (``RunOptions(free_running=True)``; Diffrax's pairs always
do), but the batch's loop runs until the slowest variant is done: variants with very different
step counts waste work, so group them.
On a GPU the same call runs every variant in parallel (bench/gpu_batch.py).
"""

from __future__ import annotations

import dataclasses
import math

import jax
import jax.numpy as jnp
import numpy as np

from ..assembly.system import System
from .. import sigint
from ..errors import ModelError, ProlegWarning, Status
from .checks import check_simulate, check_sweep_values
from .result import Result
from ..solvers.galpha import AbstractAlphaIntegrator, GeneralizedAlpha
from .simulate import RunOptions, simulate, simulate_kwargs
from ..compile_cache import compile_lowered, xla_options

# Default largest batch on the CPU: per lane-step, 1,000 lanes cost 18 µs, 500 13 µs, and two
# workers ran 1,000 variants 15 % faster in batches of 250 than of 500 (bench/vmap_batch.py).
CPU_BATCH_CAP = 256
# Default largest batch elsewhere (GPU): it bounds the memory of one batch (q and v outputs:
# ~0.6 GB for 25,000 lanes of the bench model at 101 outputs) at no cost in speed: on an
# H100, 100,000 variants of bench/vmap_batch.py's model ran at 10,325/s in batches of 25,000
# and 9,654/s in one batch of 100,000 (bench/README.md).
ACCEL_BATCH_CAP = 25_000


def default_batch_size(n: int, workers: int, backend: str | None = None) -> int:
    """Variants per batch when ``sweep`` is given no ``batch_size``: ``n`` split evenly over
    ``workers``, capped at ``CPU_BATCH_CAP`` on the CPU and ``ACCEL_BATCH_CAP`` elsewhere."""
    backend = backend or jax.default_backend()
    cap = CPU_BATCH_CAP if backend == "cpu" else ACCEL_BATCH_CAP
    return max(1, min(math.ceil(n / min(workers, n)), cap))


def default_workers() -> int:
    """Concurrent batches for :func:`sweep`: on the CPU the cores this process may use (its
    affinity mask where the OS has one), elsewhere 1 (a GPU runs one batch at a time)."""
    import os

    if jax.default_backend() != "cpu":
        return 1
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not Linux
        return max(1, os.cpu_count() or 1)


def max_concurrent_batches(backend: str | None = None) -> int:
    """How many batches :func:`sweep` runs at once in threads: on the CPU one fewer than the
    cores this process may use (at least 1), elsewhere 1.

    Why not one per core: XLA-CPU runs each batch on its intra-op thread pool, which has one
    thread per core, and a batched LAPACK call left in a vmapped simulation (jaxlib's
    ``ParallelBatchMap``; ``lu_per_lane`` removes the Newton step's but not every solve, e.g.
    the consistent initial conditions) queues its lanes on that same pool and waits for them.
    With every pool thread running a batch, nobody runs the lanes: each batch waits on a futex
    forever (gdb on the HyQ 8-bushing leg, two batches of 2 on 2 cores: both pool threads in
    ``LuDecompositionKernel`` → ``ParallelBatchMap`` → ``BlockingCounter::Wait``). One free
    thread is enough for the queued lanes to run. (That was with XLA's default pool, a thread
    per core; ``import proleg`` now sets it to one thread, ``PJRT_NPROC=1``, and each batch runs
    on the thread that started it. The rule is kept as it was measured.)"""
    if (backend or jax.default_backend()) != "cpu":
        return 1
    return max(1, default_workers() - 1)


class SweepResult:
    """Variants of one model simulated together (:func:`sweep`).

    ``values``: {parameter name: array (n_variants, ...)}; ``t`` (n_out,); ``q``, ``v``, ``w``,
    ``z``: (n_variants, n_out, ...); ``status``: a :class:`~proleg.errors.Status` per variant;
    ``variants``: each row's index in the sweep (all of them, unless it was interrupted);
    ``fail_time`` [s] (NaN for the variants that did not fail); ``stats``: {"steps", "rejected",
    "newton_iterations", "jacobians"} arrays (n_variants,). ``wall_time`` [s] of the batch run
    and ``compile_time`` [s] of its compilation. ``integrator``: the method every variant ran,
    ``integrator_reason``: why (as ``result.stats["integrator_reason"]`` of simulate),
    ``integrator_note``: None, or why it is not the method simulate would run.
    """

    def __init__(self, system, values, t, q, v, w, z, status, fail_time, stats, integrator, coordinates):
        self.system, self.values, self.t = system, values, np.asarray(t)
        self.q, self.v, self.w, self.z = q, v, w, z
        self.status = [Status(int(s)) for s in np.asarray(status)]
        self.fail_time = np.where(np.asarray(status) == 0, np.nan, np.asarray(fail_time, float))
        st = np.asarray(stats)
        self.stats = {k: st[:, i] for i, k in enumerate(("steps", "rejected", "newton_iterations", "jacobians"))}
        self.integrator, self.coordinates = integrator, coordinates
        self.integrator_reason = self.integrator_note = None  # set by sweep (batch_integrator)
        self.wall_time = self.compile_time = None
        self.apply = System.with_params  # how a variant's values become its System (sweep's apply)

    def __len__(self):
        return len(self.status)

    @property
    def ok(self) -> np.ndarray:
        """(n_variants,) bool: the variants that ran to t_end."""
        return np.array([s == Status.SUCCESS for s in self.status])

    def system_of(self, i: int) -> System:
        """The i-th variant's System (``system.with_params`` of its values, or sweep's ``apply``)."""
        return self.apply(self.system, {k: v[i] for k, v in self.values.items()})

    def __getitem__(self, i: int) -> Result:
        """The i-th variant as an ordinary Result (outputs up to its failure time, if it failed)."""
        i = int(range(len(self))[i])
        keep = self.t <= self.fail_time[i] + 1e-12 if self.status[i] != Status.SUCCESS else slice(None)
        st = self.status[i]
        msg = "success" if st == Status.SUCCESS else f"{st.describe()} at t = {self.fail_time[i]:.6g} s (variant {i} of a sweep)."
        stats = [self.stats[k][i] for k in ("steps", "rejected", "newton_iterations", "jacobians")]
        r = Result(
            self.system_of(i), self.t[keep], jnp.asarray(self.q[i][keep]), jnp.asarray(self.v[i][keep]),
            jnp.asarray(self.w[i][keep]), jnp.asarray(self.z[i][keep]), stats=stats, status=st, message=msg,
            integrator=self.integrator,
        )
        r.coordinates = self.coordinates
        if hasattr(self.integrator, "describe"):  # as simulate's result says what ran and why
            r.stats["integrator"] = self.integrator.describe()
            r.stats["integrator_reason"] = self.integrator_reason if self.integrator_note is None else self.integrator_note
        return r

    def to_frame(self):
        """Long pandas table: a ``variant`` column, the swept values (scalar parameters; vector
        ones as ``name[k]``), then each variant's :meth:`Result.to_frame` columns."""
        import pandas as pd

        frames = []
        for i in range(len(self)):
            f = self[i].to_frame()
            f.insert(0, "variant", i)
            for k, (name, val) in enumerate(self.values.items()):
                x = np.asarray(val[i])
                if x.ndim == 0:
                    f.insert(1 + k, name, float(x))
                else:
                    for j, xj in enumerate(x.ravel()):
                        f.insert(1 + k, f"{name}[{j}]", float(xj))
            frames.append(f)
        return pd.concat(frames, ignore_index=True)


def _values(system: System, params: dict, apply=None) -> tuple[dict, int]:
    """Checked {name: (n, *shape) float array} and n."""
    if not params:
        raise ModelError("sweep: no parameters to sweep. Pass e.g. {'spring.stiffness': [10.0, 100.0]}.")
    out, n = {}, None
    for name, vals in params.items():
        arr = np.asarray(vals, float)
        if arr.ndim == 0 or arr.shape[0] == 0:
            raise ModelError(f"sweep: parameter '{name}' needs an array of values, one per variant (got {vals!r}).")
        if not np.all(np.isfinite(arr)):
            raise ModelError(f"sweep: parameter '{name}' has NaN or inf values; every variant needs finite values.")
        if n is None:
            n = arr.shape[0]
        elif arr.shape[0] != n:
            raise ModelError(f"sweep: parameter '{name}' has {arr.shape[0]} values but the others have {n}; give one value per variant.")
        out[name] = arr
    # Every name and per-variant shape is checked by with_params itself (it names the element).
    (apply or System.with_params)(system, {k: v[0] for k, v in out.items()})
    if apply is None:  # the model's physical checks, per variant (a negative mass in variant 3)
        check_sweep_values(system, out)
    return out, n


def sweep(
    system: System, params: dict, t_end: float, dt_output: float | None = None, *, batch_size: int | None = None,
    workers: int | None = None, apply=None, **simulate_kw,
) -> SweepResult:
    """Simulate one variant of ``system`` per row of ``params`` ({name: values}, the names of
    ``system.with_params``, each with one value per variant), all in one compiled ``jax.vmap``
    batch. ``batch_size`` splits a long sweep into batches of that many variants (one
    compilation: the last batch is padded). ``workers`` batches run at the same time, each in
    its own thread (default: on the CPU, one per core this process may use; elsewhere 1; at most
    :func:`max_concurrent_batches` at once, one fewer than the cores, so 1 on 2 cores); with
    ``batch_size`` unset the variants are split into ``workers`` equal batches of at most
    ``CPU_BATCH_CAP`` (256) variants on the CPU, ``ACCEL_BATCH_CAP`` (25,000) on a GPU
    (:func:`default_batch_size`). Other keywords go to :func:`proleg.simulate` (``integrator``,
    tolerances, ``fixed_step``, ``coordinates``, ...); with no integrator named the batch runs
    the method ``simulate`` would choose (:func:`batch_integrator`). A variant that fails is reported in
    ``status`` with the time it stopped; the others are unaffected. ``apply(system, values)``
    (traceable; default ``System.with_params``) maps a variant's values to its System, for
    parameters that are functions of the swept ones (proleg.study uses it).

    Checks first (analyses/checks.py): the simulate arguments, and each variant's values
    against the model's physical rules (a negative mass in variant 3 is a ModelError naming
    variant 3). Ctrl-C raises :class:`proleg.Interrupted` whose ``.result`` is a SweepResult of
    the finished batches (``.result.variants``: their indices in the sweep).
    """
    import time
    from concurrent.futures import ThreadPoolExecutor

    check_simulate(system, {"t_end": t_end, "dt_output": dt_output, **simulate_kw}, "sweep")
    values, n = _values(system, params, apply)
    apply = apply or System.with_params
    workers = default_workers() if workers is None else workers
    if not isinstance(workers, int) or isinstance(workers, bool) or workers < 1:
        raise ValueError(f"sweep: workers must be a positive integer (got {workers!r}).")
    for k in ("progress", "throw", "on_chunk"):
        if k in simulate_kw:
            raise TypeError(f"sweep: '{k}' is not available in a sweep (variants run together).")
    names = list(values)
    if batch_size is None:
        bs = default_batch_size(n, workers)
    else:
        bs = max(1, min(int(batch_size), n))
    n_batches = math.ceil(n / bs)
    threads = min(workers, n_batches, max_concurrent_batches())
    concurrent = threads > 1
    meta = {}

    run_kw = simulate_kwargs(simulate_kw)
    integ, why, note = batch_integrator(system, t_end, dt_output, run_kw)
    if isinstance(integ, AbstractAlphaIntegrator):  # the only methods with a batched LU to factor lane by lane
        integ = dataclasses.replace(integ, lu_per_lane=concurrent)
    run_kw["integrator"] = integ
    run_kw["run"] = dataclasses.replace(run_kw.get("run") or RunOptions(), chunk=1_000_000, free_running=True)

    def one(vals):
        res = simulate(apply(system, dict(zip(names, vals))), t_end, dt_output, progress=False, throw=False, **run_kw)
        meta["t"], meta["integrator"], meta["coordinates"] = res.t, res.integrator, res.coordinates
        return (res.q, res.v, res.w, res.z, *res.traced_status)

    t0 = time.perf_counter()
    first = [jnp.asarray(values[k][:bs]) for k in names]
    cpu = all(d.platform == "cpu" for x in first for d in x.devices())  # XLA options measured for its CPU compiler
    fn = compile_lowered(jax.jit(jax.vmap(one)).lower(first), xla_options("loop") if cpu else None)
    t_compile = time.perf_counter() - t0

    def run(b):
        lo, hi = b * bs, min((b + 1) * bs, n)
        chunk = [np.concatenate([values[k][lo:hi], np.repeat(values[k][hi - 1 : hi], bs - (hi - lo), 0)]) for k in names]
        out = jax.block_until_ready(fn([jnp.asarray(c) for c in chunk]))
        return [np.asarray(o)[: hi - lo] for o in out]

    t0 = time.perf_counter()
    done = {}  # batch index -> outputs, kept when Ctrl-C stops the sweep
    try:
        with sigint.deferred() as stop:  # Ctrl-C acted on between batches, never lost (sigint.py)
            if concurrent:
                # XLA releases the GIL while a batch runs, and with proleg's scheduler setting each
                # batch keeps to one core: concurrent batches use the others (bench/vmap_batch.py).
                # Their Newton matrices are factored lane by lane (``lu_per_lane``), and one pool
                # thread stays free for any other batched LAPACK call (max_concurrent_batches).
                from concurrent.futures import FIRST_COMPLETED, wait

                pool = ThreadPoolExecutor(threads)
                try:
                    futures = {pool.submit(run, b): b for b in range(n_batches)}
                    running = set(futures)
                    while running:  # polled: a recorded Ctrl-C is seen within 0.2 s
                        finished, running = wait(running, timeout=0.2, return_when=FIRST_COMPLETED)
                        for f in finished:
                            done[futures[f]] = f.result()
                        stop.check()
                finally:
                    pool.shutdown(wait=False, cancel_futures=True)
            else:
                for b in range(n_batches):
                    done[b] = run(b)
                    stop.check()
    except KeyboardInterrupt:
        batches = sorted(done)
        idx = np.concatenate([np.arange(b * bs, min((b + 1) * bs, n)) for b in batches]) if batches else np.arange(0)
        res = _assemble_result(system, {k: v[idx] for k, v in values.items()}, [done[b] for b in batches], meta, apply)
        if res is not None:  # None when no batch finished
            res.variants = idx
            res.integrator_reason, res.integrator_note = why, note
        from ..errors import Interrupted

        raise Interrupted(
            f"sweep interrupted (Ctrl-C) after {len(batches)} of {n_batches} batches; .result holds the "
            f"{idx.size} finished variants (.result.variants: their indices in the sweep).", res,
        ) from None
    res = _assemble_result(system, values, [done[b] for b in range(n_batches)], meta, apply)
    res.wall_time, res.compile_time = time.perf_counter() - t0, t_compile
    res.integrator_reason, res.integrator_note = why, note
    return res


def batch_integrator(system: System, t_end: float, dt_output: float | None, run_kw: dict):
    """(integrator, reason, note): the method a batch of ``system``'s variants runs.

    The one :func:`proleg.simulate` runs for ``simulate(system.with_params(row), t_end,
    dt_output, **run_kw)``, chosen by the same chooser (:meth:`proleg.Auto.choose`, from the
    model and the run's length) when none is named, so that every row of a sweep or study is
    the answer ``simulate`` gives for that row: the same method, steps and tolerances. The
    α-methods, Radau5 and Diffrax's pairs all run under ``jax.vmap``. An integrator class that
    declares ``batches = False`` cannot: its batch runs ``GeneralizedAlpha`` with the same
    tolerances instead, ``note`` says so (None otherwise) and a warning is issued, never
    silently. ``reason`` is why the method was chosen (``result.stats["integrator_reason"]``
    of ``simulate``)."""
    import warnings

    from ..solvers.auto import Auto
    from ..solvers.base import AbstractIntegrator

    integ = run_kw.get("integrator")
    if integ is None or (isinstance(integ, str) and integ == "auto"):
        integ = Auto()
    if isinstance(integ, Auto):
        ig, why = integ.choose(system, _run_span(t_end, dt_output, run_kw), run_kw.get("coordinates", "auto"))
    elif isinstance(integ, AbstractIntegrator):
        ig, why = integ, "named by the caller"
    else:  # not an integrator: simulate's own check names it
        return integ, "", None
    if getattr(ig, "batches", True):
        return ig, why, None
    keep = {k: getattr(ig, k) for k in ("rtol", "atol", "dt_max", "fixed_step") if getattr(ig, k, None) is not None}
    alt = GeneralizedAlpha(**keep)
    note = (f"{type(ig).__name__} ({why}) cannot run variants in a vmap batch; this batch runs {alt.describe()} instead, "
            f"so its rows differ from simulate() by that method's error. Name a method that batches "
            f"(integrator=proleg.GeneralizedAlpha(), proleg.Tsit5(), ...) to choose it yourself.")
    warnings.warn(f"sweep of '{system.topo.name}': {note}", ProlegWarning, stacklevel=3)
    return alt, why, note


def _run_span(t_end: float, dt_output: float | None, run_kw: dict) -> float:
    """The run's length [s] as :func:`proleg.simulate` measures it for its choice of method:
    from the start (``t0``, or the first output time where only ``output_times`` are given) to
    the last output time."""
    from .simulate import SaveAt

    saveat = run_kw.get("saveat") or SaveAt(dt=dt_output, times=run_kw.get("output_times"))
    t0 = float(run_kw.get("t0", 0.0))
    times = saveat.output_times(t0, t_end)
    if saveat.times is not None and t0 == 0.0 and times[0] > 0:
        t0 = float(times[0])
    return float(times[-1]) - t0


def _assemble_result(system, values, parts, meta, apply):
    if not parts:
        return None
    q, v, w, z, status, ft, stats = (np.concatenate(p, 0) for p in zip(*parts))
    res = SweepResult(system, values, meta["t"], q, v, w, z, status, ft, stats, meta["integrator"], meta["coordinates"])
    res.apply = apply
    res.variants = np.arange(len(res))
    return res
