"""Calibration kept apart from validation (model updating practice; ASME V&V 10/20): a calibrated
parameter is declared with its name, value, bounds, unit, the data it was fitted on and where
that data comes from, and a comparison never scores a quantity that a calibration was fitted on.

- :class:`Calibrated`: the record.
- :func:`calibrate`: one scalar parameter fitted to one measured quantity inside its bounds,
  by a bracketed root search (Brent) in log space: a fixed, finite number of model evaluations.
- :func:`split_scores`: the rows of a comparison table split into "calibrated on" (not a score)
  and "predicted" (held-out; the only rows that judge the model).
- :func:`check_held_out`: raises if a quantity used as validation was fitted on.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import pandas as pd

from ..errors import DataError


@dataclass(frozen=True)
class Calibrated:
    """A calibrated parameter.

    name : str                  the model parameter (e.g. "pad_stiffness")
    value : float               the fitted value, in ``unit``
    bounds : (lo, hi)           the physically justified range it was fitted in
    unit : str
    fitted_on : tuple[str, ...] the measured quantities it was fitted to (never scored)
    source : str                where the data come from (seed file, table, row)
    target, achieved : float    the measured value and the model's value at ``value``
    at_bound : bool             the fit ended on a bound (the data ask for a value outside the range)
    """

    name: str
    value: float
    bounds: tuple
    unit: str
    fitted_on: tuple
    source: str
    target: float | None = None
    achieved: float | None = None
    at_bound: bool = False

    def row(self) -> dict:
        d = asdict(self)
        d["bounds"] = f"{self.bounds[0]:.4g} .. {self.bounds[1]:.4g}"
        d["fitted_on"] = ", ".join(self.fitted_on)
        return d


def calibrate(predict, *, name: str, bounds, unit: str, target: float, fitted_on, source: str,
              log: bool = True, rtol: float = 1e-8) -> Calibrated:
    """Fit the scalar parameter ``name`` so that ``predict(value) == target`` inside ``bounds``.

    ``predict`` maps the parameter to the model's value of the measured quantity; it must be
    monotonic over the bounds for the root to be unique (a bounce frequency in a pad stiffness,
    say). If the target lies outside the range the model can reach, the nearer bound is returned
    with ``at_bound=True``: the data ask for a value outside the physical range, which the
    report must say.
    """
    from scipy.optimize import brentq

    lo, hi = float(bounds[0]), float(bounds[1])
    if not (0 < lo < hi if log else lo < hi):
        raise DataError(f"calibrate {name}: bounds {bounds!r} must be increasing{' and positive (log search)' if log else ''}.")
    fitted_on = tuple([fitted_on] if isinstance(fitted_on, str) else fitted_on)
    to_x = (lambda u: math.exp(u)) if log else (lambda u: u)
    ulo, uhi = (math.log(lo), math.log(hi)) if log else (lo, hi)
    g = lambda u: float(predict(to_x(u))) - target  # noqa: E731
    glo, ghi = g(ulo), g(uhi)
    if glo * ghi > 0:
        x = lo if abs(glo) < abs(ghi) else hi
        return Calibrated(name, x, (lo, hi), unit, fitted_on, source, target, float(predict(x)), True)
    u = brentq(g, ulo, uhi, rtol=rtol, maxiter=200)
    x = to_x(u)
    return Calibrated(name, x, (lo, hi), unit, fitted_on, source, target, float(predict(x)), False)


def split_scores(table: pd.DataFrame, calibrations, quantity: str = "quantity") -> tuple[pd.DataFrame, pd.DataFrame]:
    """(calibrated_on, predicted): the rows of ``table`` whose ``quantity`` a calibration was fitted
    on, and the held-out rest (the only rows that score the model)."""
    if quantity not in table.columns:
        raise DataError(f"split_scores: the table has no column '{quantity}' naming each compared quantity.")
    fitted = {q for c in calibrations for q in c.fitted_on}
    m = table[quantity].isin(fitted)
    return table[m].reset_index(drop=True), table[~m].reset_index(drop=True)


def check_held_out(quantities, calibrations) -> None:
    """Raise DataError if any of ``quantities`` (used to validate) was fitted on by a calibration."""
    fitted = {q: c.name for c in calibrations for q in c.fitted_on}
    bad = [q for q in quantities if q in fitted]
    if bad:
        raise DataError(f"validation scores {bad}, which calibration fitted on ({', '.join(fitted[q] for q in bad)}); "
                        "score only held-out quantities (split_scores).")
