"""Sensitivities of a study's outputs to its parameters.

- local: ∂output/∂parameter at one point, by ``jax.jacfwd`` through the simulation (forward
  mode: the integrator's adaptive loop is a ``while_loop``), with the normalised elasticity
  (∂y/∂p · p / y);
- global: Sobol' first-order (S1) and total (ST) indices from a Saltelli design
  (SALib: ``SALib.sample.sobol`` and ``SALib.analyze.sobol``; Saltelli 2010, Jansen
  estimators), the samples run through the study's executor and store. Sampling is in the unit
  box of the continuous parameters (log10 for a LogRange); choices are held at their first
  value and fixed values fixed.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from ..errors import ModelError
from .space import Choice, Fixed


def saltelli_unit(d: int, n: int, seed: int | None = 0) -> np.ndarray:
    """Saltelli's design in [0, 1]^d without second-order terms: n (d + 2) rows."""
    from SALib.sample import sobol as sobol_sample

    if n < 2 or n & (n - 1):
        raise ModelError(f"sobol: n must be a power of two ≥ 2 (Sobol' sequence balance); got {n}.")
    problem = {"num_vars": d, "names": [f"x{i}" for i in range(d)], "bounds": [[0.0, 1.0]] * d}
    return sobol_sample.sample(problem, n, calc_second_order=False, scramble=True, seed=seed)


def sobol_indices(names: list[str], y: np.ndarray, *, seed: int | None = 0) -> pd.DataFrame:
    """S1, S1_conf, ST, ST_conf per parameter from outputs ``y`` of a :func:`saltelli_unit` design."""
    from SALib.analyze import sobol as sobol_analyze

    y = np.asarray(y, float)
    if not np.all(np.isfinite(y)):
        raise ModelError(f"sobol: {int(np.sum(~np.isfinite(y)))} of {len(y)} outputs are NaN (failed variants); Sobol' indices need every sample.")
    problem = {"num_vars": len(names), "names": list(names), "bounds": [[0.0, 1.0]] * len(names)}
    si = sobol_analyze.analyze(problem, y, calc_second_order=False, seed=seed)
    return pd.DataFrame({"parameter": names, "S1": si["S1"], "S1_conf": si["S1_conf"], "ST": si["ST"], "ST_conf": si["ST_conf"]})


def sobol(study, n: int = 256, *, seed: int | None = 0, outputs=None, store=None, **run_kw) -> pd.DataFrame:
    """Sobol' indices of each output over the study's continuous parameters: runs the
    n (d + 2) Saltelli samples through ``study.evaluate`` (executor, store, resume) and returns
    a long table (output, parameter, S1, S1_conf, ST, ST_conf). With a store the table is also
    written to ``STORE/sobol.parquet`` (the report's bar chart)."""
    names = [k for k, d in study.space.dims.items() if not isinstance(d, (Fixed, Choice))]
    if not names:
        raise ModelError("sobol: the space has no continuous parameter.")
    u = saltelli_unit(len(names), n, seed)
    table = {}
    j = 0
    for k, d in study.space.dims.items():
        if k in names:
            table[k] = d.from_unit(u[:, names.index(k)])
        elif isinstance(d, Choice):
            table[k] = [d.values[0]] * len(u)
        else:
            table[k] = [d.value] * len(u)
    rows = study.evaluate(pd.DataFrame(table), store=store, label=f"sobol n={n} seed={seed}", **run_kw)
    # Duplicate samples collapse to one row in evaluate; map back by key.
    from .store import variant_key

    keys = [variant_key({k: table[k][i] for k in study.space.dims}) for i in range(len(u))]
    by_key = rows.set_index("key")
    out = []
    for o in outputs or list(study.outputs):
        y = by_key.loc[keys, o].to_numpy(float)
        df = sobol_indices(names, y, seed=seed)
        df.insert(0, "output", o)
        out.append(df)
    res = pd.concat(out, ignore_index=True)
    if store is not None:
        from pathlib import Path

        res.to_parquet(Path(store) / "sobol.parquet", index=False)
    return res


def local_sensitivity(study, at: dict | None = None, *, outputs=None) -> pd.DataFrame:
    """∂output/∂parameter at ``at`` (default: mid-range, the geometric middle of a LogRange;
    choices at their first value) for every continuous parameter, by ``jax.jacfwd`` through
    the simulation. Long table: output, parameter, value (of the parameter), output_value,
    derivative, elasticity (∂y/∂p · p / y)."""
    import jax
    import jax.numpy as jnp

    from ..analyses.simulate import simulate, simulate_kwargs
    from ..assembly.system import System
    from .space import LogRange

    if study.kind != "system":
        raise ModelError(f"local_sensitivity: needs a System study (a {study.kind} study is not differentiable through its {study.kind}).")
    names = study.space.continuous
    if not names:
        raise ModelError("local_sensitivity: the space has no continuous parameter.")
    point = {}
    for k, d in study.space.dims.items():
        if at is not None and k in at:
            point[k] = at[k]
        elif isinstance(d, LogRange):
            point[k] = float(np.sqrt(d.lo * d.hi))
        elif k in names:
            point[k] = 0.5 * (d.lo + d.hi)
        elif isinstance(d, Choice):
            point[k] = d.values[0]
        else:
            point[k] = d.value
    outs = list(outputs or study.outputs)
    apply = study.apply or System.with_params

    def f(p):
        vals = {**{k: jnp.asarray(v, jnp.float64) for k, v in point.items()}, **{k: p[i] for i, k in enumerate(names)}}
        r = simulate(apply(study.target, vals), progress=False, throw=False, **simulate_kwargs(study.simulate))
        return jnp.stack([jnp.asarray(study.outputs[o](r), jnp.float64).reshape(()) for o in outs])

    p0 = jnp.asarray([float(point[k]) for k in names])
    y, J = jax.jit(lambda p: (f(p), jax.jacfwd(f)(p)))(p0)
    y, J = np.asarray(y), np.asarray(J)
    rows = []
    for i, o in enumerate(outs):
        for j, k in enumerate(names):
            rows.append({"output": o, "parameter": k, "value": float(p0[j]), "output_value": float(y[i]), "derivative": float(J[i, j]),
                         "elasticity": float(J[i, j] * p0[j] / y[i]) if y[i] != 0 else np.nan})
    return pd.DataFrame(rows)
