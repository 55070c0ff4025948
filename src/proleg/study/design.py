"""Designs of experiments over a :class:`~proleg.study.space.Space`.

- ``"grid"``: full factorial; ``n`` levels per continuous dimension (log-spaced for a
  :class:`LogRange`), every value of a :class:`Choice`.
- ``"lhs"``: Latin hypercube (``scipy.stats.qmc.LatinHypercube``, scrambled, seeded): each of
  the ``n`` equal strata of every dimension holds exactly one point.
- ``"sobol"``: scrambled Sobol' sequence (``scipy.stats.qmc.Sobol``, seeded); balanced for
  ``n`` a power of two (a warning otherwise).
- ``"table"``: the rows the user gives (a DataFrame, a {name: values} dict, a CSV or Parquet path).
A choice gets the stratum ``floor(u k)`` of a unit-cube sample, so LHS keeps the choices balanced.
"""

from __future__ import annotations

import itertools
import math
import warnings
from pathlib import Path

import numpy as np
import pandas as pd

from ..errors import DataError, ModelError
from .space import Choice, Fixed, Space

DESIGNS = ("grid", "lhs", "sobol", "table")

#: Most variants a generated design may have (``PROLEG_MAX_DESIGN_ROWS``): 10 million, months
#: of simulation at the measured ~1 variant/s of a HyQ leg, and ~80 MB per column. A larger
#: ``n`` (a typo, a grid of too many levels in too many dimensions) is refused before any array
#: is made, instead of exhausting the memory or hanging in itertools.product.
MAX_DESIGN_ROWS = 10_000_000


def _max_rows() -> int:
    from ..memguard import env_int

    return env_int("PROLEG_MAX_DESIGN_ROWS", MAX_DESIGN_ROWS)


def _size(n, what: str) -> int:
    """``n`` as a positive integer (an integral float is accepted), else a ModelError."""
    ok = isinstance(n, (int, np.integer)) and not isinstance(n, bool)
    if not ok and isinstance(n, (float, np.floating)) and np.isfinite(n) and float(n).is_integer():
        n, ok = int(n), True
    if not ok or int(n) < 1:
        raise ModelError(f"Study: {what} must be ≥ 1 and an integer (got n = {n!r}).")
    return int(n)


def _check_rows(rows: int, how: str) -> None:
    limit = _max_rows()
    if rows > limit:
        raise ModelError(f"Study: the design would have {rows:,} variants ({how}); at most {limit:,} are allowed "
                         "(PROLEG_MAX_DESIGN_ROWS). Use a smaller n, or fewer grid levels or dimensions.")


def unit_samples(kind: str, d: int, n: int, seed: int | None) -> np.ndarray:
    """(n, d) points in [0, 1)^d of a Latin hypercube or a scrambled Sobol' sequence."""
    from scipy.stats import qmc

    if kind == "lhs":
        return qmc.LatinHypercube(d=d, scramble=True, seed=seed).random(n)
    m = int(np.log2(n))
    sob = qmc.Sobol(d=d, scramble=True, seed=seed)
    if 2**m == n:
        return sob.random_base2(m)
    warnings.warn(f"Study: a Sobol' design is balanced for n a power of two; n = {n} is not (use {2 ** (m + 1)}).", stacklevel=3)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return sob.random(n)


def make_design(space: Space, design="lhs", n: int | None = None, seed: int | None = 0) -> pd.DataFrame:
    """The design's rows: one column per parameter of ``space`` (fixed ones repeated), in order.

    ``design`` is one of :data:`DESIGNS` or directly a table (DataFrame, dict or path).
    """
    if not isinstance(design, str):
        return _table(space, design)
    if design not in DESIGNS[:3]:
        if Path(design).suffix in (".csv", ".parquet"):
            return _table(space, design)
        raise ModelError(f"Study: unknown design '{design}'; valid: {list(DESIGNS[:3])}, or a table (DataFrame, dict, CSV/Parquet path).")
    if design == "grid":
        levels = 1
        if space.continuous:  # choices and fixed values need no n
            if n is None:
                raise ModelError(f"Study: a grid design needs n ≥ 1 levels per continuous dimension (got n = {n!r}).")
            levels = _size(n, "a grid design's levels per continuous dimension")
        counts = [1 if isinstance(d, Fixed) else len(d.values) if isinstance(d, Choice) else levels for d in space.dims.values()]
        _check_rows(math.prod(counts), f"a grid of {' x '.join(map(str, counts))}")
        axes = [d.grid(levels) if not isinstance(d, Fixed) else [d.value] for d in space.dims.values()]
        rows = list(itertools.product(*axes))
        return pd.DataFrame(rows, columns=list(space.dims))
    if n is None:
        raise ModelError(f"Study: design size n must be ≥ 1 (got n = {n!r}).")
    n = _size(n, "design size n")
    _check_rows(n, f"{design} n = {n:,}")
    sampled = space.sampled
    u = unit_samples(design, len(sampled), n, seed) if sampled else np.zeros((n, 0))
    return pd.DataFrame(space.from_unit(u))


def _table(space: Space, table) -> pd.DataFrame:
    if table is None:
        raise ModelError("Study: design 'table' needs the table: run(design=df) or run(design='table', n=df).")
    if isinstance(table, (str, Path)):
        p = Path(table)
        if not p.exists():
            raise DataError(f"Study: design table '{p}' does not exist.")
        df = pd.read_parquet(p) if p.suffix == ".parquet" else pd.read_csv(p)
    else:
        df = pd.DataFrame(table)
    if len(df) == 0:
        raise ModelError("Study: the design table has no rows (design size 0).")
    unknown = [c for c in df.columns if c not in space.dims]
    if unknown:
        raise DataError(f"Study: design table columns {unknown} are not in the space {list(space.dims)}.")
    missing = [k for k in space.sampled if k not in df.columns]
    if missing:
        raise DataError(f"Study: design table lacks columns {missing} (the space's varied parameters).")
    out = pd.DataFrame(index=range(len(df)))
    for k, d in space.dims.items():
        out[k] = df[k].to_numpy() if k in df.columns else [d.value] * len(df)
    return out
