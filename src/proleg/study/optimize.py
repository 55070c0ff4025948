"""Optimisation of a study's outputs: optuna (TPE, CMA-ES, NSGA-II) by ask/tell, each batch of
trials run through the study's executor and store; and a gradient-based local refinement
(``jax.jacfwd`` through the simulation, L-BFGS-B in the unit box).

proleg's own CMA-ES (``sampler="cma"``) is :mod:`proleg.study.cma`. Resuming: with a store the trials live in ``STORE/optuna.db`` (optuna's RDB storage) under a
name derived from the study's definition and the objective; a rerun continues from the trials
told, and trials asked but never told (a killed driver) are evaluated again (their rows, if
stored, are found in the store and not recomputed).
"""

from __future__ import annotations

import hashlib
import json
import math

import numpy as np
import pandas as pd

from ..errors import ModelError
from .results import OptimizationResult as OptimizationResult
from .results import to_unit as to_unit
from .space import Choice, Fixed, LogRange, Range


def _distributions(space):
    import optuna

    dists = {}
    for k, d in space.dims.items():
        if isinstance(d, LogRange):
            dists[k] = optuna.distributions.FloatDistribution(d.lo, d.hi, log=True)
        elif isinstance(d, Range):
            dists[k] = optuna.distributions.FloatDistribution(d.lo, d.hi)
        elif isinstance(d, Choice):
            dists[k] = optuna.distributions.CategoricalDistribution(list(d.values))
    return dists


def _value(obj, row):
    v = row[obj] if isinstance(obj, str) else obj(row)
    return float(v)


def _constraint_values(constraints, row) -> list[float]:
    """optuna's convention: c ≤ 0 is feasible."""
    if callable(constraints):
        return [float(c) for c in np.atleast_1d(constraints(row))]
    out = []
    for name, (op, bound) in constraints.items():
        if op not in ("<=", ">="):
            raise ModelError(f"optimize: constraint on '{name}' must be ('<=', value) or ('>=', value); got {op!r}.")
        x = float(row[name])
        out.append(x - bound if op == "<=" else bound - x)
    return out


def optimize(study, objective, constraints=None, n_trials: int = 50, *, sampler="tpe", direction="minimize",
             seed: int | None = 0, batch: int | None = None, executor=None, store=None, storage=None, progress=None, enqueue=None,
             n_startup_trials: int | None = None, **run_kw) -> OptimizationResult:
    """Optimise ``objective`` (an output name, a function of a row, or a list of them for a
    Pareto front) over the study's space in ``n_trials`` trials, ``batch`` trials per executor
    batch (default 4). ``constraints``: {output: ("<=", value) | (">=", value)} or a function of a row
    returning values that are feasible when ≤ 0 (optuna's constraints_func; TPE and NSGA-II).
    ``sampler``: "tpe", "cmaes" (optuna's CMA-ES), "nsga2", "cma" or an optuna sampler. "cma"
    is proleg's CMA-ES (:mod:`proleg.study.cma`) for optima on a bound (a force at its rating:
    co-design) and with constraints (a feasibility-first penalty), resumed by replay from the
    store; ``batch`` is its population. ``enqueue``: parameter dicts
    evaluated as the first trials of a new optimisation (e.g. the current design);
    ``n_startup_trials``: TPE's random trials before it models (default n_trials / 3, 2 to 10)."""
    import optuna

    objs = list(objective) if isinstance(objective, (list, tuple)) else [objective]
    for o in objs:
        if isinstance(o, str) and o not in study.outputs:
            raise ModelError(f"optimize: objective '{o}' is not an output of the study; outputs: {list(study.outputs)}.")
    dirs = [direction] * len(objs) if isinstance(direction, str) else list(direction)
    if n_trials < 1:
        raise ModelError(f"optimize: n_trials must be ≥ 1 (got {n_trials}).")
    if constraints is not None and not callable(constraints):
        for name in constraints:
            if name not in study.outputs:
                raise ModelError(f"optimize: constraint on '{name}', which is not an output; outputs: {list(study.outputs)}.")
    # optuna ≥ 5 reads constraints set on the trial (set_constraint); older ones a constraints_func
    new_api = hasattr(optuna.trial.Trial, "set_constraint")
    cf = (lambda t: t.user_attrs.get("constraints", [0.0])) if constraints is not None and not new_api else None
    if isinstance(sampler, str):
        if sampler == "tpe":
            n0 = n_startup_trials if n_startup_trials is not None else min(10, max(2, n_trials // 3))
            smp = optuna.samplers.TPESampler(seed=seed, constraints_func=cf, n_startup_trials=n0)
        elif sampler == "cmaes":
            if constraints is not None:
                raise ModelError("optimize: optuna's CMA-ES sampler takes no constraints; use sampler='cma' (proleg's "
                                 "CMA-ES, constraints as a feasibility-first penalty), 'tpe' or 'nsga2'.")
            smp = optuna.samplers.CmaEsSampler(seed=seed)
        elif sampler == "cma":
            from .cma import optimize_cma

            return optimize_cma(study, objective, constraints, n_trials, direction=direction, seed=seed, batch=batch,
                                executor=executor, store=store, progress=progress, enqueue=enqueue, **run_kw)
        elif sampler == "nsga2":
            smp = optuna.samplers.NSGAIISampler(seed=seed, constraints_func=cf)
        else:
            raise ModelError(f"optimize: unknown sampler '{sampler}'; valid: 'tpe', 'cmaes', 'nsga2', 'cma' or an optuna sampler.")
    else:
        smp = sampler
    batch = batch or 4
    tag = json.dumps({"def": study.definition(), "obj": [o if isinstance(o, str) else getattr(o, "__name__", "fn") for o in objs],
                      "dirs": dirs, "sampler": sampler if isinstance(sampler, str) else type(sampler).__name__, "seed": seed}, sort_keys=True, default=str)
    name = "proleg-" + hashlib.sha1(tag.encode()).hexdigest()[:12]
    if storage is None and store is not None:
        from pathlib import Path

        Path(store).mkdir(parents=True, exist_ok=True)
        storage = f"sqlite:///{Path(store).resolve() / 'optuna.db'}"
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    ost = optuna.create_study(storage=storage, sampler=smp, study_name=name, directions=dirs, load_if_exists=True)
    if enqueue and not ost.trials:
        for p in enqueue:
            ost.enqueue_trial(dict(p))
    dists = _distributions(study.space)
    fixed = {k: d.value for k, d in study.space.dims.items() if isinstance(d, Fixed)}
    TS = optuna.trial.TrialState
    pending = [optuna.trial.Trial(ost, t._trial_id) for t in ost.get_trials(deepcopy=False) if t.state == TS.RUNNING]
    all_rows = []
    while True:
        told = sum(t.state in (TS.COMPLETE, TS.FAIL, TS.PRUNED) for t in ost.get_trials(deepcopy=False))
        if not pending:
            k = min(batch, n_trials - told)
            if k <= 0:
                break
            pending = [ost.ask(dists) for _ in range(k)]
        table = pd.DataFrame([{**{kk: t.params[kk] for kk in dists}, **fixed} for t in pending])[list(study.space.dims)]
        rows = study.evaluate(table, executor=executor, store=store, progress=progress, label="optimize", **run_kw)
        all_rows.append(rows)
        for t, row in zip(pending, rows.to_dict("records")):
            t.set_user_attr("key", row["key"])
            if row["status"] != "success":
                ost.tell(t, state=TS.FAIL)
                continue
            try:
                vals = [_value(o, row) for o in objs]
            except Exception:
                vals = [math.nan]
            if not all(math.isfinite(v) for v in vals):
                ost.tell(t, state=TS.FAIL)
                continue
            if constraints is not None:
                cv = _constraint_values(constraints, row)
                t.set_user_attr("constraints", cv)
                if new_api:
                    for ci, c in enumerate(cv):
                        t.set_constraint(f"c{ci}", c)
            ost.tell(t, vals if len(vals) > 1 else vals[0])
        pending = []
    rows = pd.concat(all_rows, ignore_index=True) if all_rows else pd.DataFrame()
    complete = [t for t in ost.trials if t.state == TS.COMPLETE]
    feasible = [t for t in complete if all(c <= 0 for c in t.user_attrs.get("constraints", [0.0]))]
    if len(objs) == 1:
        pool = feasible or complete
        best = (min if dirs[0] == "minimize" else max)(pool, key=lambda t: t.value) if pool else None
        bp, bv = ({**best.params, **fixed}, best.value) if best else ({}, None)
    else:
        front = ost.best_trials
        bp, bv = ({**front[0].params, **fixed} if front else {}), [t.values for t in front]
    return OptimizationResult(bp, bv, ost.trials_dataframe(), rows, ost)


def refine(study, start, objective: str, **kw) -> dict:
    """Gradient refinement through the simulation, with constraints and a resumable store:
    :func:`proleg.study.codesign.refine`."""
    from .codesign import refine as _refine

    return _refine(study, start, objective, **kw)
