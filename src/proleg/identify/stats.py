"""Statistics over repeated identification experiments (seed 000, Table 2 and Sec. 4.1).

Seed 000 repeats every test five times, reports the mean, the relative standard deviation σ
(Table 2) and a 95 % confidence interval on the mean from Student's t with n − 1 = 4 degrees of
freedom, and checks that "each measured value is included in its relative interval". This
module does the same for any number n ≥ 2 of repetitions:

* mean  x̄ = Σ xᵢ / n,  sample standard deviation  s = √(Σ (xᵢ − x̄)² / (n − 1)),
* relative sigma  σ_rel = s / |x̄|  (Table 2 prints it in %),
* confidence interval of the mean  x̄ ± t_{(1+p)/2, n−1} s / √n  (``scipy.stats.t``),
* prediction interval for one more repetition  x̄ ± t_{(1+p)/2, n−1} s √(1 + 1/n).

The seed's check is ambiguous: with n = 5 the interval of the *mean* is narrower than the
spread of the single values, so most repetitions fall outside it by construction. Both readings
are reported: ``inside_ci`` (the value lies in the interval of the mean, the literal reading) and
``inside_pi`` (the value lies in the prediction interval, the statistically meaningful one).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy import stats as _st

from ..errors import DataError

__all__ = ["Interval", "mean_interval", "repetition_check", "repetitions_table"]


@dataclass(frozen=True)
class Interval:
    """Mean of repeated estimates with its Student-t interval.

    Attributes
    ----------
    mean, std : float
        Sample mean and sample standard deviation (ddof = 1), in the unit of the values.
    n : int
        Number of repetitions.
    low, high : float
        Confidence interval of the mean at level ``confidence``.
    confidence : float
        E.g. 0.95.
    t : float
        Student-t quantile t_{(1+confidence)/2, n−1}.
    """

    mean: float
    std: float
    n: int
    low: float
    high: float
    confidence: float
    t: float

    @property
    def half_width(self) -> float:
        return 0.5 * (self.high - self.low)

    @property
    def rel_sigma(self) -> float:
        """s / |mean| (dimensionless; Table 2's σ)."""
        return self.std / abs(self.mean) if self.mean != 0 else float("inf")

    @property
    def prediction(self) -> tuple[float, float]:
        """Prediction interval for one further repetition, x̄ ± t s √(1 + 1/n)."""
        h = self.t * self.std * np.sqrt(1.0 + 1.0 / self.n)
        return (self.mean - h, self.mean + h)

    def contains(self, value: float) -> bool:
        return self.low <= value <= self.high


def _values(values, name: str) -> np.ndarray:
    arr = np.asarray(values, dtype=float).ravel()
    if not np.all(np.isfinite(arr)):
        i = int(np.flatnonzero(~np.isfinite(arr))[0])
        raise DataError(f"{name}: repetition {i + 1} is {arr[i]}; every repetition must give a finite estimate.")
    if arr.size < 2:
        raise DataError(f"{name}: {arr.size} repetition(s); at least 2 are needed to form an interval "
                        "(seed 000 uses 5). Record more cycles or runs.")
    return arr


def mean_interval(values, confidence: float = 0.95, *, name: str = "values") -> Interval:
    """Mean and Student-t confidence interval of repeated estimates.

    Parameters
    ----------
    values : (n,) array-like, n ≥ 2
        One estimate per repetition (any unit; the interval has the same unit).
    confidence : float in (0, 1)
        Coverage of the interval, default 0.95.
    name : str
        Used in error messages.

    Returns
    -------
    Interval
        ``low, high = mean ∓ t_{(1+confidence)/2, n−1} · s / √n``.
    """
    if not 0.0 < confidence < 1.0:
        raise ValueError(f"confidence must lie in (0, 1), got {confidence}.")
    arr = _values(values, name)
    n = arr.size
    mean = float(arr.mean())
    std = float(arr.std(ddof=1))
    tq = float(_st.t.ppf(0.5 * (1.0 + confidence), n - 1))
    h = tq * std / np.sqrt(n)
    return Interval(mean, std, n, mean - h, mean + h, confidence, tq)


def repetition_check(values, confidence: float = 0.95, *, name: str = "values") -> pd.DataFrame:
    """One row per repetition: its value and whether it lies in the interval of the mean / prediction interval."""
    arr = _values(values, name)
    iv = mean_interval(arr, confidence, name=name)
    plo, phi = iv.prediction
    return pd.DataFrame({
        "repetition": np.arange(1, arr.size + 1),
        "value": arr,
        "inside_ci": (arr >= iv.low) & (arr <= iv.high),
        "inside_pi": (arr >= plo) & (arr <= phi),
    })


def repetitions_table(values: Mapping[str, Sequence[float]] | pd.DataFrame, confidence: float = 0.95,
                      units: Mapping[str, str] | None = None) -> pd.DataFrame:
    """Table-2-style summary of repeated estimates, one row per quantity.

    Parameters
    ----------
    values : mapping name -> (n,) values, or a DataFrame with one column per quantity
        E.g. ``{"k": [8.2e4, 8.4e4, ...], "c": [...]}``; each quantity needs n ≥ 2 repetitions.
    confidence : float
        Interval level, default 0.95.
    units : mapping name -> unit string, optional
        Copied into a ``unit`` column.

    Returns
    -------
    pandas.DataFrame
        Index: quantity. Columns: ``n``, ``mean``, ``std`` (ddof = 1), ``rel_sigma`` (s/|mean|,
        dimensionless), ``ci_low``, ``ci_high`` (interval of the mean), ``pi_low``, ``pi_high``
        (prediction interval), ``n_inside_ci``, ``n_inside_pi`` (repetitions inside each),
        ``all_inside`` (every repetition inside the prediction interval), ``unit``.
    """
    if isinstance(values, pd.DataFrame):
        items = {str(c): values[c].to_numpy() for c in values.columns}
    else:
        items = {str(k): v for k, v in values.items()}
    if not items:
        raise DataError("repetitions_table: no quantities given.")
    units = dict(units or {})
    rows = []
    for name, vals in items.items():
        arr = _values(vals, name)
        iv = mean_interval(arr, confidence, name=name)
        plo, phi = iv.prediction
        in_ci = int(np.sum((arr >= iv.low) & (arr <= iv.high)))
        in_pi = int(np.sum((arr >= plo) & (arr <= phi)))
        rows.append({
            "quantity": name, "n": iv.n, "mean": iv.mean, "std": iv.std, "rel_sigma": iv.rel_sigma,
            "ci_low": iv.low, "ci_high": iv.high, "pi_low": plo, "pi_high": phi,
            "n_inside_ci": in_ci, "n_inside_pi": in_pi, "all_inside": in_pi == iv.n,
            "unit": units.get(name, ""),
        })
    return pd.DataFrame(rows).set_index("quantity")
