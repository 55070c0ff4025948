"""Calibration kept apart from validation (issue 31; ASME V&V 10/20 practice).

A calibrated parameter is a :class:`Calibrated` record: its name, value, unit, the bounds it was
searched in, the data it was fitted on and where the bounds come from. :func:`calibrate` fits
one scalar parameter to one or more measured quantities; :func:`held_out_score` compares
predictions with measurements and refuses any quantity the parameter was fitted on, so a
report's "predicted" table can never score a number against the data that made it.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..errors import ConvergenceError, DataError, ModelError

__all__ = ["Calibrated", "calibrate", "held_out_score"]


@dataclass(frozen=True)
class Calibrated:
    """A parameter fitted to data.

    name : str; value : float; unit : str;
    bounds : (lo, hi) — the physically justified range searched;
    fitted_on : tuple of str — the measured quantities it was fitted to (their names);
    source : str — where the bounds (and the data) come from.
    """

    name: str
    value: float
    unit: str
    bounds: tuple
    fitted_on: tuple
    source: str

    def row(self) -> dict:
        """One row for a report's "calibrated on" table."""
        return {"parameter": self.name, "value": self.value, "unit": self.unit, "lower bound": self.bounds[0],
                "upper bound": self.bounds[1], "fitted on": ", ".join(self.fitted_on), "source of bounds": self.source}


def calibrate(name: str, predict: Callable[[float], dict], measured: dict, bounds, *, unit: str = "-", source: str = "",
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
    return Calibrated(name, float(x), unit, (lo, hi), keys, source)


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
