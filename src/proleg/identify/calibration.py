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
from collections.abc import Callable
from dataclasses import asdict, dataclass

import numpy as np
import pandas as pd

from ..errors import ConvergenceError, DataError, ModelError


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


# Several quantities or a root on the bounds (Scout II's leg friction): fit_to, held_out_score.


def fit_to(name: str, predict: Callable[[float], dict], measured: dict, bounds, *, unit: str = "-", source: str = "",
              xtol: float | None = None, max_evals: int = 30, history: list | None = None) -> Calibrated:
    """Fit one scalar parameter so that ``predict(value)`` matches ``measured``.

    Parameters
    ----------
    name : str, the parameter
    predict : value → {quantity: predicted}, must contain every key of ``measured``
    measured : {quantity: measured value} — the calibration data (one quantity: a root is found
        by bisection on the sign change of predict − measured, which must exist on the bounds;
        several: their summed squared relative error is minimised by golden-section search)
    bounds : (lo, hi), the physically justified range (the result stays inside)
    xtol : absolute tolerance on the value (default 1e-3 of the range)
    max_evals : the most calls of ``predict`` (each may be a simulation)
    history : a list to which (value, predictions) of every call is appended

    Returns
    -------
    :class:`Calibrated` with ``fitted_on`` = the keys of ``measured``.
    """
    lo, hi = (float(b) for b in bounds)
    if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
        raise ModelError(f"calibrate '{name}': bounds must be finite with lo < hi, got {bounds!r}.")
    if not measured:
        raise DataError(f"calibrate '{name}': no measured quantities to fit on; give {{quantity: value}}.")
    keys = tuple(measured)
    xtol = 1e-3 * (hi - lo) if xtol is None else float(xtol)
    calls = []

    def f(x):
        if len(calls) >= max_evals:
            raise ConvergenceError(f"calibrate '{name}': no fit within {max_evals} evaluations (last value {x:g} {unit}).")
        p = predict(x)
        missing = set(keys) - set(p)
        if missing:
            raise DataError(f"calibrate '{name}': predict() did not return {sorted(missing)}; it must return every measured quantity.")
        calls.append((x, p))
        if history is not None:
            history.append((x, dict(p)))
        return np.array([(float(p[k]) - float(measured[k])) / max(abs(float(measured[k])), 1e-300) for k in keys])

    if len(keys) == 1:
        flo, fhi = f(lo)[0], f(hi)[0]
        if not (np.isfinite(flo) and np.isfinite(fhi)) or flo * fhi > 0:
            raise ConvergenceError(
                f"calibrate '{name}': the prediction of {keys[0]} does not bracket the measured {measured[keys[0]]:g} on "
                f"[{lo:g}, {hi:g}] {unit} (relative residuals {flo:+.3g} and {fhi:+.3g}); the parameter cannot explain the "
                "data within its justified range: report that rather than widen the range."
            )
        a, b, fa, fb = lo, hi, flo, fhi
        while b - a > xtol:
            m = 0.5 * (a + b)
            fm = f(m)[0]
            if not np.isfinite(fm):
                raise ConvergenceError(f"calibrate '{name}': the prediction at {m:g} {unit} is not finite.")
            if fm * fa > 0:
                a, fa = m, fm
            else:
                b, fb = m, fm
        x = a if abs(fa) <= abs(fb) else b
    else:
        g = (math.sqrt(5) - 1) / 2
        a, b = lo, hi
        c, d = b - g * (b - a), a + g * (b - a)
        fc, fd = np.sum(f(c) ** 2), np.sum(f(d) ** 2)
        while b - a > xtol:
            if fc < fd:
                b, d, fd = d, c, fc
                c = b - g * (b - a)
                fc = np.sum(f(c) ** 2)
            else:
                a, c, fc = c, d, fd
                d = a + g * (b - a)
                fd = np.sum(f(d) ** 2)
        x = c if fc < fd else d
    return Calibrated(name=name, value=float(x), bounds=(lo, hi), unit=unit, fitted_on=keys, source=source)


def held_out_score(calibrated, predicted: dict, measured: dict) -> list[dict]:
    """Prediction errors on held-out data only.

    Parameters
    ----------
    calibrated : a :class:`Calibrated` or a list of them (what the model was fitted on)
    predicted : {quantity: model value}
    measured : {quantity: measured value} — must not contain a quantity any ``calibrated``
        was fitted on (raises DataError: score it in the "calibrated on" table instead)

    Returns
    -------
    rows {quantity, predicted, measured, error, relative error [%]} for each measured quantity.
    """
    cals = [calibrated] if isinstance(calibrated, Calibrated) else list(calibrated)
    used = {k: c.name for c in cals for k in c.fitted_on}
    overlap = sorted(set(measured) & set(used))
    if overlap:
        raise DataError(
            f"held_out_score: {overlap} were used to calibrate {sorted({used[k] for k in overlap})}; a held-out score may "
            "only use data the model was not fitted on. Show them in the 'calibrated on' table instead."
        )
    missing = sorted(set(measured) - set(predicted))
    if missing:
        raise DataError(f"held_out_score: no prediction for {missing}.")
    rows = []
    for k, y in measured.items():
        p, y = float(predicted[k]), float(y)
        rows.append({"quantity": k, "predicted": p, "measured": y, "error": p - y,
                     "relative error [%]": 100 * (p - y) / abs(y) if y else float("nan")})
    return rows
