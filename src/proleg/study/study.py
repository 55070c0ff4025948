"""``Study``: a design of experiments over one System (or a builder of Systems), run in
batches on an executor, stored row by row in a resumable Parquet store.

Example::

    study = pl.study.Study(system, space={"spring.stiffness": (10.0, 1000.0), "spring.damping": [0.1, 0.5, 1.0]},
                           outputs={"x_end": lambda r: r.part("lower").position[-1, 0]},
                           simulate=dict(t_end=1.0, dt_output=0.01))
    table = study.run(design="lhs", n=64, seed=1, executor="vmap", store="results/my-study")

``table`` has one row per variant: ``key`` (hash of the parameter values), the parameters,
the outputs, ``status`` ("success", the solver's status such as "step_too_small",
"output_error", "build_error", "error" or "worker_died") with ``reason``, ``wall_s`` (the
design's share of its batch's wall time [s]: the batch's time, builds and compilation
included, divided by its designs), ``batch_wall_s`` (the batch's call [s]), ``steps``,
``newton_iterations``, ``fail_time`` [s], ``integrator`` (the method the row ran) and
``integrator_note``, ``worker`` and ``batch``; docs/guide/studies.md describes each. Rerunning
with the same store skips every variant already stored.

With no integrator named in ``simulate``, each row runs the method :func:`proleg.simulate`
would choose (analyses/sweep.py ``batch_integrator``), so a row is
``simulate(system.with_params(row))`` to round-off; a batch that must run another method says
so (``integrator_note``, ``table.attrs["integrator_notes"]`` and a warning).

A study of a plain function (an FE solve, an analytic model, anything that is not a
simulation) is made with :meth:`Study.function`: the same designs, executors, store, resume,
optimisation and Sobol indices, each variant one call ``fn(**params)``.
"""

from __future__ import annotations

import hashlib
import inspect
import sys
import time

import numpy as np
import pandas as pd

from ..assembly.system import System
from ..errors import ModelError, ProlegWarning
from . import executors as ex
from .design import make_design
from .space import Choice, Fixed, Space
from .store import Store, variant_key

EXECUTORS = ("vmap", "processes", "dask", "local")  # "local": in this process, one variant after another
RESERVED = ("key", "status", "reason", "wall_s", "batch_wall_s", "worker", "batch", "steps", "newton_iterations", "fail_time",
            "integrator", "integrator_note", "finished_at")


def code_hash(fn) -> str:
    """A stable hash of a function's code (bytecode, constants, names), for the definition."""
    h = hashlib.sha1()

    def add(code):
        h.update(code.co_code)
        h.update(repr(code.co_names).encode())
        for c in code.co_consts:
            add(c) if inspect.iscode(c) else h.update(repr(c).encode())

    code = getattr(fn, "__code__", None)
    if code is None:
        h.update(repr(fn).encode())
    else:
        add(code)
    return h.hexdigest()[:12]


def system_fingerprint(system: System) -> dict:
    """Model name, sizes and a hash of every parameter array."""
    h = hashlib.sha1()
    for k in sorted(system.params):
        h.update(k.encode())
        h.update(np.ascontiguousarray(np.asarray(system.params[k], float)).tobytes())
    return {"model": system.topo.name, "nq": int(system.nq), "nc": int(system.nc), "params_sha1": h.hexdigest()[:16]}


class Study:
    """A design study of ``system_or_builder`` over ``space`` with named scalar ``outputs``.

    Parameters
    ----------
    system_or_builder : System, or a function of the space's parameters (keywords) returning a
        System (for what changes topology or geometry). A batch's builds are grouped by their
        traced simulation (``executors._shape_key``): builds that differ only in parameter
        values (a link length, a stiffness) share one compiled ``vmap`` batch; a number the
        compiled code captures (a Motion's function of a builder argument) splits them. Each
        build costs its ``assemble`` and a hash where its structure's simulation reads no number
        of its topology (decided once per structure), else a trace of its simulation
    space : {name: (lo, hi) | LogRange(lo, hi) | [choices] | fixed value}; names of
        ``system.with_params`` (or the builder's keywords)
    outputs : {name: function(Result) -> float}; an output that raises is recorded in its row
        (status "output_error") and the study goes on
    simulate : keywords of :func:`proleg.simulate` (``t_end`` required)
    apply : optional traceable ``apply(system, {name: value}) -> System`` mapping the parameters
        to the System (default ``System.with_params``), for derived parameters
    """

    kind = "system"  # "system", "builder" or "function" (Study.function)

    def __init__(self, system_or_builder, space, outputs, simulate=None, *, apply=None, name: str | None = None):
        self.target = system_or_builder
        self.kind = "system" if isinstance(system_or_builder, System) else "builder"
        if self.is_builder and not callable(system_or_builder):
            raise ModelError(f"Study: expected a System or a builder function; got {type(system_or_builder).__name__}.")
        self.space = Space(space)
        self.apply = apply
        if not self.is_builder and apply is None:
            self.space.check_names(system_or_builder.param_names(), f"model '{system_or_builder.topo.name}'",
                                   shown=system_or_builder.public_param_names())
            for k, d in self.space.dims.items():
                vals = d.values if isinstance(d, Choice) else ([d.value] if isinstance(d, Fixed) else [])
                if any(isinstance(v, str) for v in vals):
                    raise ModelError(f"Study: '{k}' has text values {list(vals)}; a System parameter takes numbers (text choices need a builder).")
        if self.is_builder:
            check_signature(system_or_builder, self.space, "Study")
        self.outputs = _checked_outputs(outputs, self.space, "Study", "outputs={'x_end': lambda r: r.part('lower').position[-1, 0]}",
                                        "a function of the Result")
        self.simulate = dict(simulate or {})
        if "t_end" not in self.simulate:
            raise ModelError("Study: simulate needs t_end [s], e.g. simulate=dict(t_end=1.0, dt_output=0.01).")
        self.name = name or (getattr(system_or_builder, "topo", None) and system_or_builder.topo.name) or getattr(system_or_builder, "__name__", "study")

    @classmethod
    def function(cls, fn, space, outputs, *, name: str | None = None) -> Study:
        """A study of ``fn(**params)`` — an FE solve, a closed form, any evaluation that is not a
        simulation — with the designs, executors, store, resume, :meth:`optimize` and
        :meth:`sobol` of a simulation study. ``outputs``: a list of names (keys of the mapping
        or attributes of the object ``fn`` returns) or {name: function(returned value) -> float}.
        A call that raises is a row with status "error" and the reason; the study goes on.
        ``fn`` must be picklable by cloudpickle for the "processes" and "dask" executors
        (the default is "processes"; "local" runs in this process).

        Example::

            st = pl.study.Study.function(lambda a, b: {"f": (a - 1) ** 2 + b}, {"a": (0.0, 2.0), "b": [0.0, 1.0]}, ["f"])
            best = st.optimize("f", n_trials=20, executor="local")
        """
        if not callable(fn) or isinstance(fn, System):
            raise ModelError(f"Study.function: expected a function of the parameters; got {type(fn).__name__} (a System study is Study(system, ...)).")
        if isinstance(outputs, (list, tuple)):
            if not outputs or not all(isinstance(o, str) for o in outputs):
                raise ModelError(f"Study.function: outputs must be names (strings) or {{name: function}}; got {outputs!r}.")
            outputs = {o: _Pick(o) for o in outputs}
        self = cls.__new__(cls)
        self.target, self.kind, self.apply, self.simulate = fn, "function", None, {}
        self.space = Space(space)
        check_signature(fn, self.space, "Study.function")
        self.outputs = _checked_outputs(outputs, self.space, "Study.function", "outputs=['stiffness']",
                                        "a name or a function of the returned value")
        self.name = name or getattr(fn, "__name__", "study")
        return self

    @property
    def is_builder(self) -> bool:
        """Whether the target is a builder function of the parameters (``kind == "builder"``)."""
        return self.kind == "builder"

    # -- definition ------------------------------------------------------------------------
    def definition(self) -> dict:
        """What makes two studies the same (compared on resume)."""
        if self.kind != "system":  # {"function" | "builder": qualified name, "code": hash}
            target = {self.kind: getattr(self.target, "__qualname__", repr(self.target)), "code": code_hash(self.target)}
        else:
            target = system_fingerprint(self.target)
        d = {
            "target": target,
            "space": self.space.spec(),
            "outputs": {k: (fn.name if isinstance(fn, _Pick) else code_hash(fn)) for k, fn in self.outputs.items()},
            "simulate": {k: (v if isinstance(v, (int, float, str, bool, type(None))) else repr(v)) for k, v in self.simulate.items()},
        }
        if self.apply is not None:
            d["apply"] = code_hash(self.apply)
        return d

    def design(self, design="lhs", n: int | None = None, seed: int | None = 0) -> pd.DataFrame:
        """The design's variants (parameters) with their ``key``, duplicates dropped."""
        df = make_design(self.space, design, n, seed)
        df.insert(0, "key", [variant_key(r) for r in df.to_dict("records")])
        return df.drop_duplicates("key", ignore_index=True)

    # -- running ---------------------------------------------------------------------------
    def run(self, design="lhs", n: int | None = None, seed: int | None = 0, *, executor: str | None = None,
            store=None, batch_size: int | None = None, workers: int | None = None, scheduler=None,
            progress: bool | None = None, on_batch=None, lanes: int | None = None) -> pd.DataFrame:
        """Run the design and return its rows (one per variant, in design order).

        ``executor``: "vmap", "processes", "dask" (``scheduler``: an address such as
        "tcp://host:8786" or a ``distributed.Client``; default a LocalCluster of ``workers``
        processes) or "local" (this process, one batch at a time); None or "auto":
        :func:`~proleg.study.executors.default_executor` ("vmap" for a System, for a builder
        on a GPU, and on the CPU for a builder whose first and last designs build one
        structure; "processes" for other builders on the CPU and for a function study).
        "processes" and a LocalCluster spawn their workers, which run the user's script again:
        a study run from an unguarded top-level line of a script (no
        ``if __name__ == "__main__":``) is a ModelError at once. ``store``: a folder; what it
        holds is not run again, what finishes is written batch by batch. ``batch_size``
        variants per batch, each batch one ``batch`` id (default: on the CPU the pending ones
        split over the workers, at most 256). ``workers``: batches at a time (default: the
        cores for "vmap", 2 for "processes" and "dask", 1 for "local").
        ``lanes``: variants per compiled ``vmap`` call inside a batch (default: the whole batch;
        ``lanes=1`` simulates a batch's variants one after the other, each at its own step
        sizes, which on CPU cores is the faster way when variants differ much in stiffness:
        a vmap batch runs until its slowest lane, bench/README.md). It is an execution choice,
        not part of the study's definition. ``on_batch(rows)`` is called after each batch is stored.
        """
        table = self.design(design, n, seed)
        label = f"design={design if isinstance(design, str) else 'table'} n={n} seed={seed}"
        return self.evaluate(table, executor=executor, store=store, batch_size=batch_size, workers=workers,
                             scheduler=scheduler, progress=progress, on_batch=on_batch, label=label, lanes=lanes)

    def evaluate(self, table: pd.DataFrame, *, executor=None, store=None, batch_size=None, workers=None,
                 scheduler=None, progress=None, on_batch=None, label="table", lanes=None) -> pd.DataFrame:
        """Evaluate the variants of ``table`` (columns: the space's parameters, optional ``key``)."""
        if "key" not in table.columns:
            table = table.copy()
            table.insert(0, "key", [variant_key({k: r[k] for k in self.space.dims}) for r in table.to_dict("records")])
        auto = executor is None or executor == "auto"  # resolved once the pending designs are known
        if not auto and (not isinstance(executor, str) or executor not in EXECUTORS):
            raise ModelError(f"Study: unknown executor {executor!r}; valid: {[*EXECUTORS, 'auto']}.")
        if lanes is not None and (not isinstance(lanes, int) or isinstance(lanes, bool) or lanes < 1):
            raise ModelError(f"Study: lanes must be a positive integer or None (got {lanes!r}).")
        st = Store(store).open(self.definition()) if store is not None else None
        if st is not None:
            st.add_plan(list(table["key"]), label)
        done = st.read() if st is not None else pd.DataFrame()
        done_keys = set(done["key"]) if len(done) else set()
        todo = [(r["key"], {k: r[k] for k in self.space.dims}) for r in table.to_dict("records") if r["key"] not in done_keys]
        new_rows = []
        if todo:
            if auto:
                executor = ex.default_executor(self.kind, one_structure=lambda: ex.builds_share_structure(self.target, todo, self.simulate))
            new_rows = self._execute(todo, executor, st, batch_size, workers, scheduler, progress, on_batch, lanes)
        allrows = pd.concat([done, pd.DataFrame(new_rows)], ignore_index=True) if len(done) else pd.DataFrame(new_rows)
        allrows = allrows.drop_duplicates("key", keep="first").set_index("key")
        out = allrows.loc[list(table["key"])].reset_index()
        cols = ["key", *self.space.dims, *self.outputs, "status", "reason", "wall_s"]
        out = out[cols + [c for c in out.columns if c not in cols]]
        _integrator_attrs(out, self.name)
        return out

    def _execute(self, todo, executor, st, batch_size, workers, scheduler, progress, on_batch, lanes=None):
        from ..analyses.sweep import default_batch_size, default_workers

        if workers is None:  # "local": one batch at a time, so that a batch is batch_size designs in one call
            workers = default_workers() if executor == "vmap" else 1 if executor == "local" else 2
        if not isinstance(workers, int) or workers < 1:
            raise ModelError(f"Study: workers must be a positive integer (got {workers!r}).")
        bs = int(batch_size) if batch_size else default_batch_size(len(todo), workers)
        batches = [todo[i : i + bs] for i in range(0, len(todo), bs)]
        names = list(self.space.dims)
        job = ex.Job(self.target, self.kind, names, self.outputs, self.simulate, self.apply, lanes)
        client = owned = None
        if executor in ("vmap", "local"):
            gen = ex.run_vmap(job, batches, workers=workers)
        elif executor == "processes":
            gen = ex.run_processes(job, batches, workers=workers)
        else:
            client, owned = ex.connect(scheduler, workers=workers)
            gen = ex.run_dask(job, batches, client=client)
        rows_all = []
        bar = _progress(progress, len(todo), f"{self.name} [{executor}]")
        try:
            for rows in gen:
                if st is not None:
                    st.write(rows)
                rows_all += rows
                if bar is not None:
                    bar.advance(len(rows), sum(r["status"] != "success" for r in rows))
                if on_batch is not None:
                    on_batch(rows)
        finally:
            if bar is not None:
                bar.stop()
            if owned and client is not None:
                cluster = getattr(client, "cluster", None)
                client.close()
                if cluster is not None:
                    cluster.close()
        return rows_all

    # -- analyses (optimize.py, sensitivity.py) ---------------------------------------------
    def optimize(self, objective, constraints=None, n_trials: int = 50, **kw):
        """Optimise with optuna through the same executors and store (:func:`proleg.study.optimize.optimize`)."""
        from .optimize import optimize

        return optimize(self, objective, constraints, n_trials, **kw)

    def refine(self, start, objective: str, **kw):
        """Gradient-based refinement from ``start`` (parameters, or the result of
        :meth:`optimize`: from its best trial), with ``constraints={output: ("<=", bound)}`` on
        any output and a resumable ``store`` (:func:`proleg.study.codesign.refine`)."""
        from .optimize import refine

        return refine(self, start, objective, **kw)

    def local_sensitivity(self, at: dict | None = None, **kw) -> pd.DataFrame:
        """d output / d parameter at ``at`` through the simulation (:func:`proleg.study.sensitivity.local_sensitivity`)."""
        from .sensitivity import local_sensitivity

        return local_sensitivity(self, at, **kw)

    def sobol(self, n: int = 256, **kw) -> pd.DataFrame:
        """Sobol' first-order and total indices from a Saltelli design (:func:`proleg.study.sensitivity.sobol`)."""
        from .sensitivity import sobol

        return sobol(self, n, **kw)

    def __repr__(self):
        return f"Study({self.name!r}: {list(self.space.dims)} -> {list(self.outputs)})"


def _integrator_attrs(table: pd.DataFrame, name: str) -> None:
    """``table.attrs["integrators"]``: {method: rows} of the simulated rows, and
    ``table.attrs["integrator_notes"]``: why a batch ran another method than ``simulate``
    would (:func:`proleg.analyses.sweep.batch_integrator`), each also a warning: a row that is
    not ``simulate``'s answer is never silent."""
    import warnings

    if "integrator" not in table.columns:
        return
    used = table["integrator"].fillna("").astype(str)
    table.attrs["integrators"] = {k: int(v) for k, v in used[used != ""].value_counts().items()}
    # rows read from a store written before the method was recorded (batches then ran
    # generalized-alpha where no integrator was named), beside rows that record theirs
    ran = ~table["status"].isin(["build_error", "error", "worker_died"])
    old = int((ran & (used == "")).sum())
    if old and (used != "").any():
        warnings.warn(f"Study '{name}': {old} stored row(s) do not record their method (stored by an earlier proleg, whose batches "
                      f"ran GeneralizedAlpha where no integrator was named), beside rows that ran {sorted(table.attrs['integrators'])}: "
                      "the table may mix methods. Run the study into a new store to have every row be simulate()'s answer.",
                      ProlegWarning, stacklevel=4)
    notes = table["integrator_note"].fillna("").astype(str) if "integrator_note" in table.columns else pd.Series([], dtype=str)
    table.attrs["integrator_notes"] = sorted(set(notes[notes != ""]))
    for note in table.attrs["integrator_notes"]:
        n = int((notes == note).sum())
        warnings.warn(f"Study '{name}': {n} row(s) ran another method than simulate() would: {note}", ProlegWarning, stacklevel=4)


def check_signature(fn, space: Space, who: str) -> None:
    """Refuse a space that ``fn`` (a builder or a function study's function, called as
    ``fn(**row)``) cannot take, before any variant runs: a name that is not one of its keyword
    arguments (with the close matches), or a required argument the space does not give.

    A function that takes ``**kwargs`` accepts any name: only its required named arguments are
    checked. One without a signature Python can read (a builtin, some C extensions) is not
    checked; its rows then say what went wrong."""
    try:
        sig = inspect.signature(fn)
    except (TypeError, ValueError):
        return
    params = list(sig.parameters.values())
    named = [p for p in params if p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY)]
    label = getattr(fn, "__name__", type(fn).__name__)
    what = f"{who}'s {'builder' if who == 'Study' else 'function'} '{label}'"
    if not any(p.kind is p.VAR_KEYWORD for p in params):
        space.check_names([p.name for p in named], f"{what} (its keyword arguments: {', '.join(p.name for p in named) or 'none'})")
    missing = [p.name for p in named if p.default is p.empty and p.name not in space.dims]
    if missing:
        raise ModelError(f"{who}: {what} needs {', '.join(repr(m) for m in missing)}, which the space does not give; every variant "
                         f"would fail to build. Add {'them' if len(missing) > 1 else 'it'} to the space (a fixed value, e.g. "
                         f"{{'{missing[0]}': 0.25}}, is held for every variant) or give {'them' if len(missing) > 1 else 'it'} a default.")


def _checked_outputs(outputs, space, who: str, example: str, what: str) -> dict:
    """The study's {name: function}, each callable, none named like a column."""
    if not isinstance(outputs, dict) or not outputs:
        raise ModelError(f"{who}: give at least one output, e.g. {example}.")
    for k, fn in outputs.items():
        if not callable(fn):
            raise ModelError(f"{who}: output '{k}' is not {what} (got {type(fn).__name__}).")
        if k in RESERVED or k in space.dims:
            raise ModelError(f"{who}: output name '{k}' clashes with a column ({'reserved' if k in RESERVED else 'a parameter'}); rename it.")
    return dict(outputs)


class _Pick:
    """Output ``name`` of a function study: ``value[name]`` of a mapping, else ``value.name``
    (``value.metrics[name]`` for proleg's analysis objects)."""

    def __init__(self, name):
        self.name = name

    def __call__(self, value):
        if isinstance(value, dict):
            return value[self.name]
        metrics = getattr(value, "metrics", None)
        if isinstance(metrics, dict) and self.name in metrics:
            return metrics[self.name]
        return getattr(value, self.name)


class _Bar:
    """rich progress bar: variants done / total, failures, rate [variants/s] and ETA."""

    def __init__(self, total, label, console=None):
        from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn

        self.t0, self.done = time.perf_counter(), 0
        self.p = Progress(TextColumn(f"[bold]{label}[/]"), BarColumn(), MofNCompleteColumn(), TextColumn("{task.fields[rate]}"),
                          TextColumn("[red]{task.fields[failed]}[/]"), TimeElapsedColumn(), TextColumn("ETA"), TimeRemainingColumn(),
                          console=console)
        self.task = self.p.add_task("study", total=total, rate="", failed="")
        self.failed = 0
        self.p.start()

    def advance(self, n, failed):
        self.done += n
        self.failed += failed
        rate = self.done / max(time.perf_counter() - self.t0, 1e-9)
        self.p.update(self.task, advance=n, rate=f"{rate:.3g} variants/s", failed=f"{self.failed} failed" if self.failed else "")

    def stop(self):
        self.p.stop()


def _progress(progress, total, label):
    show = progress if progress is not None else sys.stderr.isatty()
    return _Bar(total, label) if show else None


