"""Where a study's batches run: ``"vmap"`` (this process, through :func:`proleg.sweep`),
``"processes"`` (local worker processes) and ``"dask"`` (a ``distributed`` cluster).

A batch is evaluated by :func:`evaluate_batch` wherever it runs: the variants go through
:func:`proleg.sweep` in one compiled ``vmap`` batch (a builder's variants grouped by their
traced simulation, :func:`_shape_key`, one sweep per group), each output function is applied
to each variant's Result, and
every variant comes back as a row, also when its simulation, its build or an output failed
(``status`` and ``reason`` say what). Rows are written to the store by the driver only, as each
batch comes back: a batch lost with a killed worker is run again, never written twice.
"""

from __future__ import annotations

import functools
import hashlib
import math
import os
import socket
import threading
import time
import uuid
import warnings

import numpy as np

from ..errors import ModelError, Status

DEFAULT_TIMEOUT_S = 10.0  # connecting to a scheduler address
#: the start of :func:`proleg.analyses.sweep.batch_integrator`'s warning (regular expression)
SUBSTITUTED = r"sweep of .*cannot run variants in a vmap batch"


def default_executor(kind: str, backend: str | None = None, *, one_structure=None) -> str:
    """The executor of ``executor=None`` or ``"auto"`` for a study of ``kind`` ("system",
    "builder" or "function") on JAX's ``backend`` (default: this process's). ``one_structure``:
    whether a builder's designs build one structure (a bool, or a function returning it,
    called only where the answer matters: :func:`builds_share_structure` of the pending
    designs); None: not known.

    - a function study: "processes" (FE solves and closed forms are plain Python, one call
      per variant; worker processes use the cores);
    - on a GPU (any backend but the CPU): "vmap", for a System and for a builder alike: one
      process holds the device and runs each compiled group as one batch (worker processes
      would each take the device's memory, JAX preallocating 75 % of it per process);
    - on the CPU: "vmap" for a System, and for a builder whose designs build one structure
      (issue 42: the one group is one compile and one batch in this process, where each
      worker process would compile it again); "processes", the earlier default, kept for a
      builder whose designs may build several structures (several compiles, which worker
      processes run side by side; not measured again) or where that is not known.

    Measured (``bench/study_throughput.py --model hyq``, the HyQ 8-bushing drop over 1e6–1e10
    N/m, and bench/vmap_batch.py; figures in docs/performance.md): a vmap batch runs until its
    slowest lane, and variants whose step counts differ 3× run slower batched on CPU cores than
    one by one (``"processes"`` with ``lanes=1`` was the fastest there), while variants that
    step alike run about 5× faster batched than in a loop. A study cannot know beforehand which it is, so the
    CPU default of a System study stays "vmap"; for stiffness studies over decades on CPU
    cores pass ``executor="processes", lanes=1`` to :meth:`Study.run`. A builder study of one
    structure (``bench/builder_executor.py``: the HyQ 8-bushing leg over 16 cylinder lengths,
    0.1 s drop, each executor from a fresh compile cache, 2 CPUs shared, load 5–8; two rounds,
    bench/results/builder_executor.md) took 112 s and 74 s on "vmap" against 139 s and 117 s on
    "processes" as the leg is (its pin servo's initial state ``z0`` is a topology number its
    simulation reads, so each build is traced to be grouped), and 49 s and 54 s against 88 s
    and 163 s with ``z0`` declared structure (``--z0-structure``: builds grouped by a hash):
    one compile in one process beat two workers compiling the same group side by side, also
    where "processes" spread the per-build traces over the cores."""
    import jax

    if kind == "function":
        return "processes"
    if (backend or jax.default_backend()) != "cpu" or kind != "builder":
        return "vmap"
    if callable(one_structure):
        one_structure = one_structure()
    return "vmap" if one_structure else "processes"


def builds_share_structure(builder, rows, simulate_kw: dict) -> bool:
    """Whether a builder study's designs ``rows`` ([(key, {name: value})]) build one structure
    (:func:`default_executor`'s CPU choice): the builds of the first and the last design have
    one structure fingerprint of their simulation (:func:`_structure_fingerprint`: counts,
    kinds, names, shapes, code and closures, the numbers that shape the computation; no trace).
    Two builds and two hashes in this process: 0.9 s for the HyQ leg under load 8, plus the
    set-up of a process's first ``assemble`` (2.6 s from a warm compile cache, 14 s from a cold
    one), which a "vmap" study then does not pay again. False where either build fails or
    cannot be keyed. A probe, not a proof: designs in between that build another structure
    still run correctly under "vmap" (a group and a compile each), only one after another."""
    picks = rows[:1] if len(rows) < 2 else [rows[0], rows[-1]]
    keys = set()
    for _, vals in picks:
        try:
            keys.add(_structure_fingerprint(builder(**vals), simulate_kw))
        except Exception:  # noqa: BLE001 (a build that fails is the study's row to report, not the probe's)
            return False
    return len(keys) == 1 and None not in keys


class Job:
    """What a worker needs to evaluate a batch (pickled with cloudpickle)."""

    def __init__(self, target, kind, names, outputs, simulate_kw, apply=None, lanes=None):
        self.target, self.kind, self.names = target, kind, list(names)  # kind: "system", "builder" or "function"
        self.outputs, self.simulate_kw, self.apply = dict(outputs), dict(simulate_kw), apply
        self.lanes = lanes  # variants per compiled vmap call inside a batch (None: the whole batch)


def _worker_name() -> str:
    try:
        from distributed import get_worker

        return str(get_worker().address)
    except (ImportError, ValueError):
        return f"{socket.gethostname()}:{os.getpid()}"


def _shape_key(system, simulate_kw: dict) -> str:
    """Builds with equal keys share one compiled simulation: equal names, and the same traced
    simulation — ``jax.make_jaxpr`` of :func:`proleg.simulate` as a function of the params, its
    text (operations, shapes, literals) and the values of every constant it captured.

    That is what decides the compiled program, and nothing else: numbers that live in
    ``system.params`` (masses, marker geometry, stiffnesses, the initial pose) are its inputs
    and do not enter the key, so two builds that differ only in them share one compile, and the
    group's base System run with a member's params computes exactly the member's simulation.
    Numbers the Topology keeps static and the simulation uses are constants of the trace and
    split groups, as they must: a Motion's function of a builder argument, a controller's
    period or output limit, a PID's constant setpoint, a drive's data, the planar reduction's
    row combinations (canonical for the same joints, ``assembly.coordinates._canonical_basis``,
    so a longer link does not change them), Python branches on static values. Names (parts,
    markers, elements, joints) are in the key because outputs look them up.

    Cost: a hash per build where the structure's simulation reads no number of its topology
    (:func:`proleg.analyses.structure.simulation_key`, decided by one perturbed-trace check per
    structure: issue 42), else one trace of the simulation per build (about one ``assemble``:
    seconds); no compilation. A build whose trace fails gets a key of its own (its sweep then
    reports the error in its row)."""
    import jax

    from ..analyses.simulate import simulate, simulate_kwargs
    from ..assembly.system import System

    topo, kw = system.topo, simulate_kwargs(simulate_kw)
    skey = _structure_key(system, simulate_kw)
    if skey is not None:  # names, shapes and every static number are in the structure key
        return "structure-" + skey
    h = hashlib.sha1()
    names = [topo.name, topo.body_names, topo.marker_names, [getattr(j, "name", "") for j in topo.joints],
             [(g.kind, list(g.names)) for g in topo.groups + topo.extensions],
             [(k, tuple(np.shape(v)), str(np.asarray(v).dtype)) for k, v in sorted(system.params.items())]]
    h.update(repr(names).encode())

    def run(params):
        r = simulate(System(params, topo), progress=False, throw=False, **kw)
        return r.q, r.v, r.w, r.z, *r.traced_status

    try:
        closed = jax.make_jaxpr(run)(system.params)
    except Exception:  # not traceable here: a group of its own
        return uuid.uuid4().hex
    h.update(str(closed.jaxpr).encode())
    for c in _jaxpr_consts(closed):
        a = np.asarray(c)
        h.update(f"{a.shape}{a.dtype}".encode())
        h.update(np.ascontiguousarray(a).tobytes() if a.dtype != object else repr(a).encode())
    return h.hexdigest()


def _run_of(simulate_kw: dict):
    """The function of a System alone that groups a build (:func:`_simulated` with the study's
    simulate options)."""
    from ..analyses.simulate import simulate_kwargs

    kw = simulate_kwargs(simulate_kw)
    return functools.partial(_simulated, kw=tuple(sorted(kw.items())))


def _structure_key(system, simulate_kw: dict) -> str | None:
    """The build's :func:`proleg.analyses.structure.simulation_key` for the study's simulate
    options: a hash shared by every build of its structure, or None where the structure's
    simulation reads a number of its topology (then :func:`_shape_key` traces the build)."""
    from ..analyses.structure import simulation_key

    return simulation_key(system, _run_of(simulate_kw))


def _structure_fingerprint(system, simulate_kw: dict) -> str | None:
    """The structure fingerprint that :func:`proleg.analyses.structure.simulation_key` keys its
    decision by (the System's pytree structure with its topology's numbers left out, the leaves'
    shapes, the simulation's code and options), without that decision: equal for two builds of
    one structure whether or not its simulation reads a topology number. None: not keyable."""
    import jax

    from .. import compile_cache as cc

    leaves, td = jax.tree_util.tree_flatten(system)
    try:
        return cc.structure_fingerprint(cc._environment_key(), td, tuple(cc._aval(x) for x in leaves), _run_of(simulate_kw))
    except (cc.Unkeyable, TypeError):
        return None


def _simulated(system, kw):
    """What a build's simulation returns for grouping (:func:`_shape_key`): a module-level
    function of the System alone, so that its structure key holds no build's topology."""
    from ..analyses.simulate import simulate

    r = simulate(system, progress=False, throw=False, **dict(kw))
    return r.q, r.v, r.w, r.z, *r.traced_status


def _jaxpr_consts(closed) -> list:
    """The constants of a ClosedJaxpr and of every jaxpr nested in it (compile_cache.jaxpr_consts)."""
    from ..compile_cache import jaxpr_consts

    return jaxpr_consts(closed)


def _row(key, vals, batch, worker):
    return {"key": key, **{k: (v if isinstance(v, str) else _num(v)) for k, v in vals.items()}, "batch": batch, "worker": worker}


def _num(v):
    a = np.asarray(v, float)
    return float(a) if a.ndim == 0 else a.tolist()


def _outputs_of(job, res, i) -> tuple[dict, str, str]:
    """({output: value}, status, reason) of variant i of a SweepResult.

    A builder's group member gets the Result of the group's base System with its own params:
    the same names and the same simulation as its own build (:func:`_shape_key`), and the
    output post-processing compiled once per group rather than once per build. Only the
    model description (``r.system.topo.model``) is the base's: an output that needs a
    variant's description reads it from the variant's parameters."""
    st = res.status[i]
    nan = {k: math.nan for k in job.outputs}
    if st != Status.SUCCESS:
        return nan, st.name.lower(), f"{st.describe()} at t = {res.fail_time[i]:.6g} s"
    return _extract(job, res[i])


def _extract(job, r) -> tuple[dict, str, str]:
    """({output: value}, status, reason) of one evaluated variant ``r`` (a Result, or what a
    function study's function returned)."""
    out, status, reason = {}, "success", ""
    for name, fn in job.outputs.items():
        try:
            val = np.asarray(fn(r), float)
            if val.size != 1:
                raise ModelError(f"output '{name}' returned shape {val.shape}; an output must be one number (use e.g. .max() or [-1]).")
            out[name] = float(val.reshape(()))
        except Exception as exc:  # the row records the error; the study goes on
            out[name] = math.nan
            status = "output_error"
            reason += f"{name}: {type(exc).__name__}: {exc}; "
    return out, status, reason.rstrip("; ")


def evaluate_batch(job: Job, rows: list[tuple[str, dict]], *, workers: int = 1, batch_size: int | None = None) -> list[dict]:
    """Simulate ``rows`` ([(key, {name: value})]) and return one row dict per variant."""
    from ..analyses.sweep import sweep

    from .. import memguard

    memguard.release_if_needed()  # each build of a builder study may be a new compiled model
    batch, worker = uuid.uuid4().hex[:12], _worker_name()
    if job.kind == "function":
        return _evaluate_functions(job, rows, batch, worker)
    t0 = time.perf_counter()
    out: dict[str, dict] = {}
    groups: dict[str, tuple] = {}
    if job.kind == "builder":
        for key, vals in rows:
            try:
                system = job.target(**vals)
                groups.setdefault(_shape_key(system, job.simulate_kw), (system, []))[1].append((key, vals, system))
            except Exception as exc:
                out[key] = {**_row(key, vals, batch, worker), **{k: math.nan for k in job.outputs},
                            "status": "build_error", "reason": f"{type(exc).__name__}: {exc}"}
    else:
        groups["system"] = (job.target, [(key, vals, None) for key, vals in rows])
    for base, members in groups.values():
        memguard.release_if_needed()  # each group is a compiled model of its own
        if job.kind == "builder":
            names = sorted(base.params)
            params = {k: np.stack([np.asarray(m[2].params[k]) for m in members]) for k in names}
        else:
            params = {k: np.stack([np.asarray(m[1][k], float) for m in members]) for k in job.names}
        try:
            lanes = job.lanes or batch_size
            with warnings.catch_warnings():  # a substituted method: in the rows, and warned by the study's driver
                warnings.filterwarnings("ignore", message=SUBSTITUTED)
                res = sweep(base, params, workers=workers, batch_size=lanes, apply=job.apply, **job.simulate_kw)
            err = None
        except Exception as exc:  # the whole group failed (compilation, bad options): rows say why
            res, err = None, f"{type(exc).__name__}: {exc}"
        for i, (key, vals, _) in enumerate(members):
            row = _row(key, vals, batch, worker)
            if res is None:
                row.update({k: math.nan for k in job.outputs}, status="error", reason=err)
                row.update(steps=0, newton_iterations=0, fail_time=math.nan)
            else:
                vals_out, status, reason = _outputs_of(job, res, i)
                row.update(vals_out, status=status, reason=reason)
                row.update(steps=int(res.stats["steps"][i]), newton_iterations=int(res.stats["newton_iterations"][i]),
                           fail_time=float(res.fail_time[i]), integrator=res.integrator.describe(),
                           integrator_note=res.integrator_note or "")
            out[key] = row
    wall = time.perf_counter() - t0
    rows_out = [out[key] for key, _ in rows]
    for r in rows_out:
        r["wall_s"] = wall / max(1, len(rows))  # this call's wall time (builds, traces, compilation, run) per design
        r["batch_wall_s"] = wall
        r.setdefault("integrator", "")
        r.setdefault("integrator_note", "")
        r.setdefault("steps", 0)
        r.setdefault("newton_iterations", 0)
        r.setdefault("fail_time", math.nan)
        r["finished_at"] = time.time()
    return rows_out


def _evaluate_functions(job: Job, rows, batch, worker) -> list[dict]:
    """A function study's batch: one call per variant, each row timed on its own."""
    out = []
    for key, vals in rows:
        t0 = time.perf_counter()
        row = _row(key, vals, batch, worker)
        try:
            value = job.target(**vals)
        except Exception as exc:  # the row records the error; the study goes on
            row.update({k: math.nan for k in job.outputs}, status="error", reason=f"{type(exc).__name__}: {exc}")
        else:
            vals_out, status, reason = _extract(job, value)
            row.update(vals_out, status=status, reason=reason)
        wall = time.perf_counter() - t0
        row.update(wall_s=wall, batch_wall_s=wall, steps=0, newton_iterations=0, fail_time=math.nan, finished_at=time.time())
        out.append(row)
    return out


def run_payload(payload: bytes) -> list[dict]:
    """Worker entry point of the "processes" and "dask" executors: (job, rows) pickled."""
    import cloudpickle

    from .. import memguard

    job, rows = cloudpickle.loads(payload)
    out = evaluate_batch(job, rows)
    memguard.release_if_needed()  # a worker over many geometries keeps its maps and memory bounded
    return out


def _run_in_pool(payload: bytes) -> tuple[list[dict], bool]:
    """Entry point of a "processes" worker: (rows, recycle), recycle True when the worker is
    still above its memory thresholds after clearing its compiled code
    (:func:`proleg.memguard.should_recycle`): the driver then replaces it."""
    from .. import memguard

    out = run_payload(payload)
    return out, memguard.should_recycle()


def _init_worker(cache_dir: str | None, workers: int) -> None:
    """Initializer of a "processes" worker: the driver's compilation cache, and this worker's
    share of the machine's memory (:func:`proleg.memguard.set_worker_share`)."""
    from .. import memguard

    memguard.set_worker_share(workers)
    use_compilation_cache(cache_dir)


# ------------------------------------------------------------------------------------------
# drivers: each yields the rows of each finished batch
# ------------------------------------------------------------------------------------------
def run_vmap(job, batches, *, workers):
    """In this process: ``workers`` batches at a time through one :func:`sweep` call (its
    concurrent batches). Each batch keeps its own ``batch`` id, so a batch is ``batch_size``
    rows whatever ``workers`` is; ``batch_wall_s`` is the wall time of the call, shared by the
    batches it ran together."""
    for g in range(0, len(batches), workers):
        group = batches[g : g + workers]
        bs = max(len(b) for b in group)
        rows = [r for b in group for r in b]
        out = evaluate_batch(job, rows, workers=min(workers, len(group)), batch_size=bs)
        if len(group) > 1:
            i = 0
            for b in group:
                bid = uuid.uuid4().hex[:12]
                for r in out[i : i + len(b)]:
                    r["batch"] = bid
                i += len(b)
        yield out


#: Exit code of a spawned worker that, starting, ran the user's script again up to a study's
#: worker pool (sysexits' EX_CONFIG): the driver then raises :func:`main_guard_error` at once.
BOOTSTRAP_EXIT = 78


def main_guard_error(where: str | None = None) -> ModelError:
    """The error for a script whose study starts worker processes from its top level, without
    ``if __name__ == "__main__":`` (``where``: its file and line, where known)."""
    at = f" ({where})" if where else ""
    return ModelError(
        "Study: the worker processes start with 'spawn', which runs your script again in each worker; the study's run"
        f"{at} is not under `if __name__ == \"__main__\":`, so every worker would start the study again, and Python stops "
        "it ('An attempt has been made to start a new process before the current process has finished its bootstrapping "
        "phase'). Put the call under `if __name__ == \"__main__\":` (building the model may stay above it), or pass "
        "executor=\"vmap\" or \"local\" to run the study in this process."
    )


def spawn_reruns_main() -> str | None:
    """The file a spawned worker runs again as its main module (the script this process was
    started with), or None when it runs none (an interactive session, ``python -c``, Jupyter,
    ``python -m pkg`` whose main is a ``__main__`` module): multiprocessing's own rules
    (``multiprocessing.spawn.get_preparation_data``, ``_fixup_main_from_*``)."""
    import multiprocessing.spawn as spawn
    import sys

    main = sys.modules.get("__main__")
    path = getattr(main, "__file__", None)
    if main is None or not path:
        return None
    data = spawn.get_preparation_data("proleg-study")
    name = data.get("init_main_from_name")
    if name is not None:
        return None if name == "__main__" or name.endswith(".__main__") else path
    main_path = data.get("init_main_from_path")  # made absolute from the start directory (a later chdir)
    if main_path is None or os.path.splitext(os.path.basename(main_path))[0] == "ipython":
        return None
    return main_path


def unguarded_main_line() -> str | None:
    """Where this call starts from an unguarded top-level statement of the script that spawned
    workers would run again ("script.py, line 12"), or None.

    The call stack's frame of the main module's top level is at a line; the statement of the
    script (its syntax tree) that holds that line is what a spawned worker runs again, unless it
    is an ``if`` on ``__name__`` (the guard). Anything not known for sure (no such frame, a file
    that cannot be read or parsed) is None: no false alarm."""
    import ast
    import sys

    path = spawn_reruns_main()
    if path is None:
        return None
    main_globals = sys.modules["__main__"].__dict__
    frame = sys._getframe(1)
    while frame is not None and not (frame.f_code.co_name == "<module>" and frame.f_globals is main_globals):
        frame = frame.f_back
    if frame is None:
        return None
    line = frame.f_lineno
    try:
        with open(path, encoding="utf-8") as f:
            tree = ast.parse(f.read())
    except (OSError, SyntaxError, ValueError, UnicodeDecodeError):
        return None
    for stmt in tree.body:
        if stmt.lineno <= line <= (stmt.end_lineno or stmt.lineno):
            guarded = isinstance(stmt, ast.If) and any(isinstance(n, ast.Name) and n.id == "__name__" for n in ast.walk(stmt.test))
            return None if guarded else f"{os.path.basename(path)}, line {line}"
    return None


def check_can_spawn() -> None:
    """Before a study starts spawned workers ("processes", a Dask LocalCluster): raise
    :func:`main_guard_error` where they could not start.

    In the driver, where its script would start the study again in every worker (the
    study runs from an unguarded top-level line, :func:`unguarded_main_line`). In a spawned
    worker that is still starting (re-running the script: multiprocessing's ``_inheriting``)
    and has reached a study's pool: that worker exits with :data:`BOOTSTRAP_EXIT` after
    printing the reason, so that the driver raises the same error at once instead of
    retrying each batch as a crashed worker."""
    import multiprocessing as mp
    import sys

    if getattr(mp.current_process(), "_inheriting", False):
        print(f"proleg: {main_guard_error()}", file=sys.stderr, flush=True)
        raise SystemExit(BOOTSTRAP_EXIT)
    where = unguarded_main_line()
    if where is not None:
        raise main_guard_error(where)


_POOLS: dict = {}


def compilation_cache_dir() -> str | None:
    """This process's persistent JAX compilation cache folder (None: no cache)."""
    import jax

    return jax.config.jax_compilation_cache_dir


def use_compilation_cache(path: str | None) -> None:
    """Make this (worker) process use the persistent compilation cache folder ``path`` of the
    driver, where that folder exists here (the same machine, or a file system shared with the
    cluster): a shape compiled by one worker, or by the driver, is then read by the others
    instead of compiled again, and a worker's own compilations are kept across its batches and
    studies. Elsewhere the worker keeps its own cache (proleg's default folder)."""
    import jax

    if not path or not os.path.isdir(path) or jax.config.jax_compilation_cache_dir == path:
        return
    jax.config.update("jax_compilation_cache_dir", path)
    jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.5)
    jax.config.update("jax_persistent_cache_min_entry_size_bytes", 0)
    try:  # a cache already opened on another folder is reopened on this one
        from jax.experimental.compilation_cache import compilation_cache

        compilation_cache.reset_cache()
    except (ImportError, AttributeError):  # pragma: no cover - older jax
        pass


def _cache_plugin(path):
    """A Dask WorkerPlugin that runs :func:`use_compilation_cache` on every worker, also on
    workers that join later."""
    from distributed.diagnostics.plugin import WorkerPlugin

    class CompilationCache(WorkerPlugin):
        name = "proleg-compilation-cache"

        def __init__(self, path):
            self.path = path

        def setup(self, worker):
            use_compilation_cache(self.path)

    return CompilationCache(path)


#: Seconds a pool of the "processes" executor may stay idle before its workers end
#: (``PROLEG_POOL_IDLE_S``; 0 or less: kept until :func:`shutdown_pools` or exit). After a
#: 1,000-variant HyQ study two idle workers held 1.5 GB; an optimisation's batches and studies
#: run back to back reuse the pool well within this.
POOL_IDLE_S = float(os.environ.get("PROLEG_POOL_IDLE_S", "300"))
_POOL_LOCK = threading.Lock()
_BUSY: dict = {}  # workers -> number of runs using that pool now
_IDLE_TIMERS: dict = {}  # workers -> threading.Timer that ends that pool once idle


def process_pool(workers: int):
    """This process's pool of ``workers`` spawned worker processes (JAX is not fork-safe), kept
    between studies and between an optimisation's batches so that each worker imports proleg and
    compiles once; a broken pool is replaced. A pool idle for :data:`POOL_IDLE_S` ends
    (:func:`run_processes` marks it busy while it runs); :func:`shutdown_pools` (also at exit)
    ends them all."""
    import atexit
    import multiprocessing as mp
    from concurrent.futures import ProcessPoolExecutor

    with _POOL_LOCK:
        pool = _POOLS.get(workers)
        if pool is None or getattr(pool, "_broken", False) or getattr(pool, "_shutdown_thread", False):
            if not _POOLS:
                atexit.register(shutdown_pools)
            pool = _POOLS[workers] = ProcessPoolExecutor(max_workers=workers, mp_context=mp.get_context("spawn"),
                                                         initializer=_init_worker, initargs=(compilation_cache_dir(), workers))
        return pool


def _hold_pool(workers: int) -> None:
    with _POOL_LOCK:
        _BUSY[workers] = _BUSY.get(workers, 0) + 1
        timer = _IDLE_TIMERS.pop(workers, None)
        if timer is not None:
            timer.cancel()


def _release_pool(workers: int) -> None:
    """One run is done with the pool of ``workers``: when none is left, end the pool after
    :data:`POOL_IDLE_S` unless a run takes it again first."""

    def end_if_idle(pool):
        with _POOL_LOCK:
            if _IDLE_TIMERS.get(workers) is timer and not _BUSY.get(workers) and _POOLS.get(workers) is pool:
                _POOLS.pop(workers).shutdown(wait=False, cancel_futures=True)
                _IDLE_TIMERS.pop(workers, None)

    with _POOL_LOCK:
        _BUSY[workers] = max(0, _BUSY.get(workers, 0) - 1)
        pool = _POOLS.get(workers)
        if _BUSY[workers] or pool is None or POOL_IDLE_S <= 0:
            return
        timer = threading.Timer(POOL_IDLE_S, end_if_idle, (pool,))
        timer.daemon = True
        _IDLE_TIMERS[workers] = timer
        timer.start()


def shutdown_pools() -> None:
    """End the worker processes of the "processes" executor."""
    with _POOL_LOCK:
        while _IDLE_TIMERS:
            _IDLE_TIMERS.popitem()[1].cancel()
        while _POOLS:
            _POOLS.popitem()[1].shutdown(wait=False, cancel_futures=True)


_RECYCLED = {"pools": 0}


def _recycle_pool(workers: int, pool) -> None:
    """End ``pool`` (its batches are all back) and let :func:`process_pool` start a fresh one:
    a worker stayed above its memory thresholds after clearing its compiled code
    (:func:`proleg.memguard.should_recycle`). The whole pool is replaced, as
    ``ProcessPoolExecutor`` cannot replace one worker; its workers are waited for, so their
    memory is back before the new ones start."""
    with _POOL_LOCK:
        if _POOLS.get(workers) is pool:
            _POOLS.pop(workers)
    pool.shutdown(wait=True)
    _RECYCLED["pools"] += 1


def recycled_pools() -> int:
    """How many times this process replaced its worker pool because a worker stayed above its
    memory thresholds (:func:`_recycle_pool`)."""
    return _RECYCLED["pools"]


#: Deaths of a worker process (segfault, OOM killer, kill -9) while it evaluated one variant
#: alone, after which that variant is stored as failed (status "worker_died") and the study goes
#: on (``PROLEG_MAX_WORKER_DEATHS``).
MAX_WORKER_DEATHS = max(1, int(os.environ.get("PROLEG_MAX_WORKER_DEATHS", "2") or 2))


def _exit_codes(pool, wait_s: float = 2.0) -> str:
    """How the pool's dead workers ended ("SIGKILL", "exit code 1"), as far as it still knows.

    The pool's manager thread reaps the dead worker (``join``) while this thread reads its exit
    code: a read between the thread's ``waitpid`` and its storing the code finds none (the
    process is already reaped). The codes are therefore read again for up to ``wait_s`` seconds
    until one is known; "killed" if none ever is."""
    import signal

    procs = list((getattr(pool, "_processes", None) or {}).values())
    deadline = time.monotonic() + wait_s
    while True:
        out = []
        for p in procs:
            code = getattr(p, "exitcode", None)
            if code:
                try:
                    out.append(signal.Signals(-code).name if code < 0 else f"exit code {code}")
                except ValueError:
                    out.append(f"exit code {code}")
        if out or not procs or time.monotonic() > deadline:
            return ", ".join(sorted(set(out))) or "killed"
        time.sleep(0.02)


def _worker_died_rows(job, batch, reason) -> list[dict]:
    rows = []
    for key, vals in batch:
        row = _row(key, vals, "", "")
        row.update({k: math.nan for k in job.outputs}, status="worker_died", reason=reason, wall_s=math.nan,
                   steps=0, newton_iterations=0, fail_time=math.nan, finished_at=time.time())
        rows.append(row)
    return rows


def run_processes(job, batches, *, workers, max_deaths: int | None = None, max_empty_breaks: int = 3):
    """Local worker processes (:func:`process_pool`), ``workers`` batches in flight at a time.

    A worker that dies (segfault, OOM killer, kill -9) breaks the pool; it is replaced and the
    batches that were in flight are run again, each alone, so that a further death is
    attributed to the batch that caused it. A batch that kills its worker when alone is split
    in halves, down to single variants; a variant that kills its worker ``max_deaths`` times
    (default :data:`MAX_WORKER_DEATHS`) when alone becomes a row with status "worker_died" and
    the reason, and the study goes on. Every other variant comes back exactly once. A worker that
    stays above its memory thresholds after clearing its compiled code asks to be replaced: no
    new batch goes to its pool, and once the batches in flight are back the pool is ended and a
    fresh one started (:func:`_recycle_pool`). A pool that
    breaks ``max_empty_breaks`` times with nothing in flight (workers that cannot start) ends the
    run with a ModelError; what is not done stays pending in the store."""
    from collections import deque
    from concurrent.futures import FIRST_COMPLETED, wait
    from concurrent.futures.process import BrokenProcessPool

    import cloudpickle

    check_can_spawn()
    max_deaths = max_deaths or MAX_WORKER_DEATHS
    queue, suspects = deque(batches), deque()  # suspects: were in flight when a worker died; run alone
    deaths: dict = {}  # variant key -> deaths of its worker while it ran alone
    empty_breaks = 0
    _hold_pool(workers)
    try:
        while queue or suspects:
            alone = bool(suspects)
            pool = process_pool(workers)
            inflight: dict = {}
            try:
                if alone:
                    fut = pool.submit(_run_in_pool, cloudpickle.dumps((job, suspects[0])))
                    inflight[fut] = suspects[0]
                    rows, recycle = fut.result()
                    inflight.clear()
                    suspects.popleft()
                    if recycle:
                        _recycle_pool(workers, pool)
                    yield rows
                    continue
                def submit():  # a batch leaves the queue only once it is in flight
                    inflight[pool.submit(_run_in_pool, cloudpickle.dumps((job, queue[0])))] = queue[0]
                    queue.popleft()

                recycle = False  # a worker asked to be replaced: no new batch goes to this pool
                while queue and len(inflight) < workers:
                    submit()
                while inflight:
                    done, _ = wait(list(inflight), return_when=FIRST_COMPLETED)
                    for f in done:
                        rows, asked = f.result()  # raises BrokenProcessPool if a worker died
                        del inflight[f]
                        recycle = recycle or asked
                        yield rows
                        if queue and not recycle:
                            submit()
                if recycle:
                    _recycle_pool(workers, pool)
            except BrokenProcessPool:
                how = _exit_codes(pool)
                with _POOL_LOCK:
                    if _POOLS.get(workers) is pool:
                        _POOLS.pop(workers, None)
                pool.shutdown(wait=False, cancel_futures=True)
                if f"exit code {BOOTSTRAP_EXIT}" in how:  # a worker ran the script's study again (check_can_spawn)
                    raise main_guard_error() from None
                if alone:
                    b = suspects.popleft()
                    if len(b) > 1:  # bisect towards the variant that kills its worker
                        h = len(b) // 2
                        suspects.extendleft([b[h:], b[:h]])
                    else:
                        key = b[0][0]
                        deaths[key] = deaths.get(key, 0) + 1
                        if deaths[key] >= max_deaths:
                            yield _worker_died_rows(job, b, f"the worker process died {deaths[key]} times evaluating this variant alone ({how})")
                        else:
                            suspects.appendleft(b)
                elif inflight:
                    suspects.extend(inflight.values())
                else:
                    empty_breaks += 1
                    if empty_breaks >= max_empty_breaks:
                        n = sum(len(b) for b in queue)
                        raise ModelError(f"Study: the worker processes died {empty_breaks} times with no batch running ({how}); "
                                         f"{n} variants were not run (they stay pending in the store).") from None
    finally:
        _release_pool(workers)


def connect(scheduler=None, *, workers: int = 2, timeout_s: float = DEFAULT_TIMEOUT_S):
    """A ``distributed.Client``: to ``scheduler`` (address or Client), or to a new
    LocalCluster of ``workers`` single-threaded worker processes. Returns (client, owned)."""
    try:
        from distributed import Client, LocalCluster
    except ImportError as exc:  # pragma: no cover
        raise ModelError("Study: executor 'dask' needs dask[distributed]: pip install 'proleg[study]'.") from exc
    if scheduler is not None and not isinstance(scheduler, str):
        return scheduler, False
    if scheduler:
        try:
            return Client(scheduler, timeout=f"{timeout_s}s"), True
        except (OSError, TimeoutError) as exc:
            raise ModelError(
                f"Study: no Dask scheduler answered at '{scheduler}' within {timeout_s:g} s ({type(exc).__name__}). "
                "Start one (`dask scheduler` and `dask worker ADDRESS`), check the address, or leave the scheduler out for a LocalCluster."
            ) from None
    check_can_spawn()  # the LocalCluster's workers are spawned processes too
    cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None)
    return Client(cluster), True


def run_dask(job, batches, *, client):
    """Each batch a Dask task; a task lost with a worker is rescheduled by Dask. Every worker
    first takes the driver's compilation cache folder (:func:`use_compilation_cache`): a
    shape is compiled by XLA once and read from the cache by every later batch and worker
    (each batch still traces and lowers its simulation, seconds, as :func:`proleg.sweep`
    builds its function per call)."""
    import cloudpickle
    from distributed import as_completed

    client.register_plugin(_cache_plugin(compilation_cache_dir()))
    futs = [client.submit(run_payload, cloudpickle.dumps((job, b)), pure=False) for b in batches]
    for f in as_completed(futs):
        yield f.result()
