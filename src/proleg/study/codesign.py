"""Gradient co-design through the simulation: :meth:`proleg.study.Study.refine` with
constraints on any output, over hardware parameters and motion-law variables together
(issue 30).

The objective and every constrained output are differentiated together by ``jax.jacfwd``
through the simulation (forward mode: the adaptive integrator is a ``while_loop``), one pass per
iterate, in the unit box of the parameters' ranges (log10 for a LogRange). Without constraints
the optimiser is L-BFGS-B; with constraints SLSQP (sequential quadratic programming, bounds
and inequalities), each constraint scaled by its bound so that one tolerance fits all.

Restart-safe: with ``store=`` every evaluation (the point, the outputs and their gradients)
is appended to ``STORE/refine.parquet`` under a tag of the study's definition, the objective,
the constraints and the start. SLSQP and L-BFGS-B are deterministic functions of the values
they are given, so a rerun replays the stored evaluations (no simulation) and continues from
where a killed run stopped.

Choosing values: ``maxiter`` 30 (each iterate costs one simulation with its forward-mode
tangents, about (1 + number of parameters) simulations' work); ``ftol`` 1e-9 on the objective
scaled by its start value, i.e. the objective to about 9 digits, far below what an
error-controlled simulation resolves (rtol 1e-6 by default), so the run ends on ``maxiter`` or
on SLSQP's own step test; ``active_tol`` 1e-3 (a constraint whose slack is within 0.1 % of its
bound is reported as binding).
"""

from __future__ import annotations

import hashlib
import json
import math
import os
from pathlib import Path

import numpy as np
import pandas as pd

from ..errors import ModelError
from .space import LogRange

CONSTRAINT_OPS = ("<=", ">=")


def checked_constraints(study, constraints, who: str) -> dict:
    """{output: (op, bound)} validated against the study's outputs."""
    if constraints is None:
        return {}
    if not isinstance(constraints, dict):
        raise ModelError(f"{who}: constraints must be {{output: ('<=', value) | ('>=', value)}}; got {type(constraints).__name__}.")
    out = {}
    for name, spec in constraints.items():
        if name not in study.outputs:
            raise ModelError(f"{who}: constraint on '{name}', which is not an output; outputs: {list(study.outputs)}.")
        if not (isinstance(spec, tuple | list) and len(spec) == 2 and spec[0] in CONSTRAINT_OPS):
            raise ModelError(f"{who}: constraint on '{name}' must be ('<=', value) or ('>=', value); got {spec!r}.")
        bound = float(spec[1])
        if not math.isfinite(bound):
            raise ModelError(f"{who}: constraint on '{name}' has a non-finite bound {spec[1]!r}.")
        out[name] = (spec[0], bound)
    return out


def slack(op: str, bound: float, value: float) -> float:
    """Scaled slack: ≥ 0 feasible, in units of max(|bound|, 1e-12)."""
    s = max(abs(bound), 1e-12)
    return (bound - value) / s if op == "<=" else (value - bound) / s


def binding(row: dict, constraints: dict, space: dict, tol: float = 0.02, edge: float = 0.01) -> list[str]:
    """What binds at an optimum ``row`` ({name: value}): each constraint ({output: (op, bound)})
    whose scaled :func:`slack` is within ``tol`` of zero, then each design variable of ``space``
    ({name: (lo, hi)}) within ``edge`` of its range's span from a bound (``"name = lo"`` / ``"= hi"``)."""
    out = [c for c, (op, b) in constraints.items() if abs(slack(op, b, float(row[c]))) <= tol]
    for k, (lo, hi) in space.items():
        span = hi - lo
        if float(row[k]) <= lo + edge * span:
            out.append(f"{k} = lo")
        elif float(row[k]) >= hi - edge * span:
            out.append(f"{k} = hi")
    return out


class _Log:
    """Evaluations of one refinement (point u → outputs and Jacobian), kept in memory and, with
    a store, in ``STORE/refine.parquet`` (rewritten atomically after each new evaluation)."""

    def __init__(self, store, tag: str, names: list[str], outs: list[str]):
        self.file = None if store is None else Path(store) / "refine.parquet"
        self.tag, self.names, self.outs = tag, names, outs
        self.cache: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}
        self.rows: list[dict] = []
        self.stored = 0
        if self.file is not None and self.file.exists():
            old = pd.read_parquet(self.file)
            self.rows = old.to_dict("records")
            for r in self.rows:
                if r["tag"] == tag:
                    u = np.asarray(json.loads(r["u"]), float)
                    self.cache[u.tobytes()] = (np.asarray(json.loads(r["y"]), float), np.asarray(json.loads(r["jac"]), float))
                    self.stored += 1

    def get(self, u):
        return self.cache.get(np.asarray(u, float).tobytes())

    def put(self, u, y, jac, params: dict):
        u = np.asarray(u, float)
        self.cache[u.tobytes()] = (y, jac)
        if self.file is None:
            return
        row = {"tag": self.tag, "u": json.dumps(u.tolist()), "y": json.dumps(np.asarray(y, float).tolist()),
               "jac": json.dumps(np.asarray(jac, float).tolist()), **{k: float(v) for k, v in params.items()},
               **{f"out:{o}": float(v) for o, v in zip(self.outs, y)}}
        self.rows.append(row)
        self.file.parent.mkdir(parents=True, exist_ok=True)
        tmp = self.file.with_suffix(f".tmp{os.getpid()}")
        pd.DataFrame(self.rows).to_parquet(tmp, index=False)
        os.replace(tmp, self.file)


def _transform(study, names):
    dims = [study.space.dims[k] for k in names]

    def to_value(j, u):
        d = dims[j]
        if isinstance(d, LogRange):
            a, b = math.log10(d.lo), math.log10(d.hi)
            return 10.0 ** (a + (b - a) * u)
        return d.lo + (d.hi - d.lo) * u

    return to_value


def refine(study, start, objective: str, *, direction="minimize", maxiter: int = 30, constraints=None, names=None,
           store=None, ftol: float = 1e-9, active_tol: float = 1e-3) -> dict:
    """Refine ``start`` ({name: value}, or an :class:`~proleg.study.optimize.OptimizationResult`:
    its best trial) by gradients through the simulation (module docstring).

    Parameters
    ----------
    objective : an output name; ``direction`` "minimize" or "maximize"
    constraints : {output: ("<=", bound) | (">=", bound)}, e.g. {"peak_torque": ("<=", 77.0)}
    names : the continuous parameters to vary (default all of the space's ranges); the others
        stay at ``start``
    store : a folder: the evaluations are kept there and a rerun resumes (module docstring)

    Returns
    -------
    dict with ``params`` (every space parameter), ``value`` (the objective there),
    ``start_value``, ``outputs`` {objective and constrained outputs: value}, ``binding`` (the
    constraints within ``active_tol`` of their bound, and ``"<param> = lo|hi"`` for parameters on
    a bound), ``feasible``, ``iterations``, ``evaluations`` (simulations run by this call; a
    resumed run replays the stored ones without simulating), ``stored_before`` (evaluations the
    store held at the start), ``success`` and ``message`` (the optimiser's).
    """
    import jax
    import jax.numpy as jnp
    from scipy.optimize import minimize

    from ..analyses.simulate import simulate, simulate_kwargs
    from ..assembly.system import System
    from .results import OptimizationResult, to_unit

    if isinstance(start, OptimizationResult):
        if not start.best_params:
            raise ModelError("refine: the optimisation has no completed trial to start from.")
        start = start.best_params
    if study.kind != "system":
        raise ModelError(f"refine: a {study.kind} study is not differentiable through its {study.kind}; refine needs a System study.")
    if objective not in study.outputs:
        raise ModelError(f"refine: objective '{objective}' is not an output; outputs: {list(study.outputs)}.")
    if direction not in ("minimize", "maximize"):
        raise ModelError(f"refine: direction must be 'minimize' or 'maximize'; got {direction!r}.")
    cons = checked_constraints(study, constraints, "refine")
    names = list(names) if names is not None else study.space.continuous
    bad = [k for k in names if k not in study.space.continuous]
    if bad:
        raise ModelError(f"refine: {bad} are not continuous ranges of the space; refinable: {study.space.continuous}.")
    if not names:
        raise ModelError("refine: the space has no continuous parameter to refine.")
    missing = [k for k in study.space.dims if k not in start]
    if missing:
        raise ModelError(f"refine: start lacks {missing}; give every parameter of the space.")
    start = {k: start[k] for k in study.space.dims}
    outs = [objective, *[c for c in cons if c != objective]]
    to_value = _transform(study, names)
    apply = study.apply or System.with_params
    kw = simulate_kwargs(study.simulate)

    def values(u):
        return {**start, **{k: to_value(j, u[j]) for j, k in enumerate(names)}}

    def f(u):
        sysv = apply(study.target, {k: jnp.asarray(v, jnp.float64) for k, v in values(u).items()})
        r = simulate(sysv, progress=False, throw=False, **kw)
        return jnp.stack([jnp.asarray(study.outputs[o](r), jnp.float64).reshape(()) for o in outs])

    fg = jax.jit(lambda u: (f(u), jax.jacfwd(f)(u)))
    tag = hashlib.sha1(json.dumps({"def": study.definition(), "objective": objective, "direction": direction, "names": names,
                                   "constraints": cons, "start": {k: (v if isinstance(v, str) else float(v)) for k, v in start.items()}},
                                  sort_keys=True, default=str).encode()).hexdigest()[:16]
    log = _Log(store, tag, names, outs)
    nsim = [0]

    def evaluate(u):
        u = np.asarray(u, float)
        hit = log.get(u)
        if hit is not None:
            return hit
        nsim[0] += 1
        y, jac = fg(jnp.asarray(u))
        y, jac = np.asarray(y, float), np.asarray(jac, float)
        log.put(u, y, jac, {k: float(v) for k, v in values(u).items() if not isinstance(v, str)})
        return y, jac

    u0 = to_unit(study, names, start)
    y0, _ = evaluate(u0)
    if not np.all(np.isfinite(y0)):
        raise ModelError(f"refine: the outputs at the start are not finite ({dict(zip(outs, y0))}); the simulation failed there.")
    sign = 1.0 if direction == "minimize" else -1.0
    scale = max(abs(float(y0[0])), 1e-12)

    def fun(u):
        y, jac = evaluate(u)
        return sign * y[0] / scale, sign * jac[0] / scale

    ineq = []
    for i, (name, (op, bound)) in enumerate(cons.items()):
        k = outs.index(name)
        s = max(abs(bound), 1e-12)
        sg = 1.0 if op == ">=" else -1.0  # SLSQP's inequality: g(u) ≥ 0
        ineq.append({"type": "ineq", "fun": lambda u, k=k, sg=sg, b=bound, s=s: sg * (evaluate(u)[0][k] - b) / s,
                     "jac": lambda u, k=k, sg=sg, s=s: sg * evaluate(u)[1][k] / s})
    bounds = [(0.0, 1.0)] * len(names)
    if ineq:
        res = minimize(fun, u0, jac=True, bounds=bounds, constraints=ineq, method="SLSQP", options={"maxiter": maxiter, "ftol": ftol})
    else:
        res = minimize(fun, u0, jac=True, bounds=bounds, method="L-BFGS-B", options={"maxiter": maxiter, "ftol": ftol})
    u = np.clip(res.x, 0.0, 1.0)
    y, _ = evaluate(u)
    best = {k: (v if isinstance(v, str) else float(v)) for k, v in values(u).items()}
    binds = [c for c, (op, b) in cons.items() if abs(slack(op, b, float(y[outs.index(c)]))) <= active_tol]
    binds += [f"{k} = {'lo' if u[j] <= 1e-6 else 'hi'}" for j, k in enumerate(names) if u[j] <= 1e-6 or u[j] >= 1 - 1e-6]
    feasible = all(slack(op, b, float(y[outs.index(c)])) >= -active_tol for c, (op, b) in cons.items())
    return {"params": best, "value": float(y[0]), "start_value": float(y0[0]), "outputs": dict(zip(outs, map(float, y))),
            "binding": binds, "feasible": feasible, "iterations": int(res.nit), "evaluations": nsim[0], "stored_before": log.stored, "success": bool(res.success), "message": str(res.message)}
