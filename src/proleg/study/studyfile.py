"""YAML study files (validated with pydantic).

Example::

    name: pendulum-spring
    model: pendulum.yaml             # a model file (relative to this file) ...
    # robot: hyq_leg                 # ... or a built-in robot: proleg.robots.<robot>(**robot_args)
    # robot_args: {joints: bushings8}
    space:
      spring.stiffness: {range: [10, 1000]}
      spring.damping: {log: [0.1, 1.0]}
      spring.free_length: {choices: [0.98, 1.0]}
      upper.mass: 1.0                # fixed
    outputs:                         # Python expressions of the Result r (np, jnp available)
      x_end: "r.part('lower').position[-1, 0]"
    simulate: {t_end: 0.2, dt_output: 0.01}
    design: {kind: lhs, n: 64, seed: 1}   # grid (n levels), lhs, sobol, or table: file.csv
    executor: auto                   # auto | vmap | processes | dask
    scheduler: null                  # tcp://host:8786 for a Dask cluster
    store: results/pendulum-spring   # relative to this file

Output expressions are evaluated as Python (a study file is code, like a script: run only the
files you trust).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Literal

import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from ..errors import ModelError


class DesignSpec(BaseModel):
    model_config = ConfigDict(extra="forbid")
    kind: Literal["grid", "lhs", "sobol", "table"] = "lhs"
    n: int | None = Field(None, ge=1)
    seed: int | None = 0
    table: str | None = None


class StudyFile(BaseModel):
    model_config = ConfigDict(extra="forbid")
    name: str | None = None
    model: str | None = None
    robot: str | None = None
    robot_args: dict[str, Any] = {}
    space: dict[str, Any]
    outputs: dict[str, str]
    simulate: dict[str, Any]
    design: DesignSpec = DesignSpec()
    executor: Literal["auto", "vmap", "processes", "dask"] = "auto"
    scheduler: str | None = None
    store: str | None = None
    batch_size: int | None = Field(None, ge=1)
    workers: int | None = Field(None, ge=1)
    lanes: int | None = Field(None, ge=1)  # variants per compiled vmap call (Study.run lanes=)

    @model_validator(mode="after")
    def _one_model(self):
        if (self.model is None) == (self.robot is None):
            raise ValueError("give exactly one of 'model' (a model file) and 'robot' (a built-in robot)")
        return self


class Expr:
    """An output given as a Python expression of the Result ``r``."""

    def __init__(self, text: str, name: str):
        import jax.numpy as jnp
        import numpy as np

        self.text, self.name = text, name
        try:
            self.code = compile(text, f"<output {name}>", "eval")
        except SyntaxError as exc:
            raise ModelError(f"study file: output '{name}' is not a Python expression: {exc.msg} in {text!r}.") from None
        self.ns = {"np": np, "jnp": jnp, "abs": abs, "max": max, "min": min, "float": float}

    def __call__(self, r):
        return eval(self.code, self.ns, {"r": r})  # noqa: S307 - a study file is the user's code

    def __repr__(self):
        return f"Expr({self.text!r})"


def _dim(name, v):
    from .space import LogRange

    if isinstance(v, dict):
        if len(v) != 1 or next(iter(v)) not in ("range", "log", "choices", "fixed"):
            raise ModelError(f"study file: space.{name} must be one of {{range: [lo, hi]}}, {{log: [lo, hi]}}, {{choices: [...]}}, {{fixed: value}} or a number; got {v!r}.")
        kind, val = next(iter(v.items()))
        if kind in ("range", "log"):
            if not isinstance(val, list) or len(val) != 2:
                raise ModelError(f"study file: space.{name}.{kind} must be [lo, hi]; got {val!r}.")
            try:
                lo, hi = float(val[0]), float(val[1])
            except (TypeError, ValueError):
                raise ModelError(f"study file: space.{name}.{kind} must be two numbers [lo, hi]; got {val!r}.") from None
            return (lo, hi) if kind == "range" else LogRange(lo, hi)
        if kind == "choices":
            if not isinstance(val, list) or not val:
                raise ModelError(f"study file: space.{name}.choices must be a non-empty list; got {val!r}.")
            return list(val)
        return val
    if isinstance(v, list):
        raise ModelError(f"study file: space.{name} is a bare list; write {{range: [lo, hi]}} or {{choices: [...]}}.")
    return v


def load_study_file(path):
    """(Study, run keywords) from a YAML study file."""
    import proleg as pl

    from .study import Study

    path = Path(path)
    if not path.is_file():
        raise ModelError(f"study file '{path}' does not exist{' (it is a folder)' if path.is_dir() else ''}.")
    try:
        raw = yaml.safe_load(path.read_text(encoding="utf-8"))
        spec = StudyFile.model_validate(raw)
    except yaml.YAMLError as exc:
        raise ModelError(f"study file '{path}': not valid YAML: {exc}") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ModelError(f"study file '{path}' cannot be read: {exc}.") from None
    except ValidationError as exc:
        errs = "; ".join(f"{'.'.join(map(str, e['loc'])) or '(top)'}: {e['msg']}" for e in exc.errors())
        raise ModelError(f"study file '{path}': {errs}.") from None
    base = path.parent
    if spec.model is not None:
        from ..io import load_model_file

        model, _ = load_model_file(base / spec.model)
    else:
        builder = getattr(pl.robots, spec.robot, None)
        if builder is None:
            raise ModelError(f"study file '{path}': unknown robot '{spec.robot}'; built-in: {[n for n in dir(pl.robots) if not n.startswith('_')]}.")
        try:
            model = builder(**spec.robot_args)
        except TypeError as exc:  # an unknown or missing keyword of the robot's function
            raise ModelError(f"study file '{path}': robot_args do not fit robot '{spec.robot}': {exc}.") from None
    system = pl.assemble(model)
    study = Study(system, {k: _dim(k, v) for k, v in spec.space.items()}, {k: Expr(v, k) for k, v in spec.outputs.items()},
                  simulate=spec.simulate, name=spec.name or path.stem)
    d = spec.design
    run_kw = dict(design=d.table and str(base / d.table) or d.kind, n=d.n, seed=d.seed, executor=spec.executor,
                  scheduler=spec.scheduler, store=str(base / spec.store) if spec.store else str(base / "results" / (spec.name or path.stem)),
                  batch_size=spec.batch_size, workers=spec.workers, lanes=spec.lanes)
    return study, run_kw
