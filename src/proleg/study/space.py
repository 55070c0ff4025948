"""The parameter space of a study: ranges, log ranges, choices and fixed values by name.

``{"spring.stiffness": (10.0, 1000.0)}`` is a continuous range, ``LogRange(1e6, 1e10)`` a
range sampled uniformly in log10, ``[0.1, 0.5, 1.0]`` a set of choices, a number (or array) a
fixed value. Names are those of :meth:`proleg.System.with_params` when the study runs one
System; with a builder function they are the builder's keyword arguments.
"""

from __future__ import annotations

import difflib
import math
from dataclasses import dataclass

import numpy as np

from ..errors import ModelError


@dataclass(frozen=True)
class Range:
    """Continuous range [lo, hi] (the parameter's unit), sampled uniformly."""

    lo: float
    hi: float

    def from_unit(self, u):
        return self.lo + (self.hi - self.lo) * np.asarray(u, float)

    def grid(self, n: int):
        return np.linspace(self.lo, self.hi, n)

    def spec(self):
        return ["range", self.lo, self.hi]


@dataclass(frozen=True)
class LogRange(Range):
    """Continuous range [lo, hi] with lo > 0, sampled uniformly in log10 (stiffnesses, gains)."""

    def from_unit(self, u):
        a, b = math.log10(self.lo), math.log10(self.hi)
        return 10.0 ** (a + (b - a) * np.asarray(u, float))

    def grid(self, n: int):
        return np.logspace(math.log10(self.lo), math.log10(self.hi), n)

    def spec(self):
        return ["log", self.lo, self.hi]


@dataclass(frozen=True)
class Choice:
    """A finite set of values; a sample u in [0, 1) picks ``values[floor(u k)]``."""

    values: tuple

    def from_unit(self, u):
        k = len(self.values)
        idx = np.minimum((np.asarray(u, float) * k).astype(int), k - 1)
        return np.asarray(self.values, dtype=object if _is_text(self.values) else float)[idx]

    def grid(self, n: int):
        return np.asarray(self.values, dtype=object if _is_text(self.values) else float)

    def spec(self):
        return ["choice", *[v if isinstance(v, str) else float(v) for v in self.values]]


@dataclass(frozen=True)
class Fixed:
    """A value held fixed for every variant."""

    value: object

    def spec(self):
        v = self.value
        return ["fixed", v if isinstance(v, str) else np.asarray(v, float).tolist()]


def _is_text(values) -> bool:
    return any(isinstance(v, str) for v in values)


class Space:
    """Named dimensions of a study (:class:`Range`, :class:`LogRange`, :class:`Choice`,
    :class:`Fixed`), in the order given. ``sampled`` are the names a design varies."""

    def __init__(self, dims: dict):
        if isinstance(dims, Space):
            dims = dims.dims
        if not isinstance(dims, dict) or not dims:
            raise ModelError("Study: the space is empty. Pass e.g. {'spring.stiffness': (10.0, 1000.0)}.")
        self.dims = {str(k): _dim(str(k), v) for k, v in dims.items()}

    @property
    def sampled(self) -> list[str]:
        return [k for k, d in self.dims.items() if not isinstance(d, Fixed)]

    @property
    def continuous(self) -> list[str]:
        return [k for k, d in self.dims.items() if isinstance(d, Range)]

    def spec(self) -> dict:
        return {k: d.spec() for k, d in self.dims.items()}

    def check_names(self, valid: list[str], what: str = "the system", shown: list[str] | None = None) -> None:
        """Refuse a name that is not in ``valid``, listing the close matches among ``shown`` (the
        public names; default ``valid``)."""
        shown = valid if shown is None else shown
        for name in self.dims:
            if name not in valid:
                close = difflib.get_close_matches(name, shown, n=5, cutoff=0.5)
                hint = f" Close matches: {close}." if close else f" Valid names: {shown[:30]}{' ...' if len(shown) > 30 else ''}."
                raise ModelError(f"Study: parameter '{name}' is not a parameter of {what}.{hint}")

    def from_unit(self, u: np.ndarray) -> dict:
        """{name: values (n,)} from unit-cube samples u (n, len(sampled)); fixed values repeated."""
        u = np.atleast_2d(np.asarray(u, float))
        n = u.shape[0]
        out = {}
        j = 0
        for k, d in self.dims.items():
            if isinstance(d, Fixed):
                out[k] = [d.value] * n
            else:
                out[k] = d.from_unit(u[:, j])
                j += 1
        return out

    def __repr__(self):
        return f"Space({self.spec()})"


def _dim(name: str, v):
    if isinstance(v, (Range, Choice, Fixed)):
        d = v
    elif isinstance(v, tuple):
        if len(v) != 2:
            raise ModelError(f"Study: range of '{name}' must be (lo, hi); got {v!r}.")
        d = Range(float(v[0]), float(v[1]))
    elif isinstance(v, list):
        if not v:
            raise ModelError(f"Study: choices of '{name}' are empty; give at least one value.")
        return Choice(tuple(v))
    else:
        return Fixed(v)
    if isinstance(d, Range):
        if not (np.isfinite(d.lo) and np.isfinite(d.hi)):
            raise ModelError(f"Study: range of '{name}' must be finite; got ({d.lo}, {d.hi}).")
        if not d.hi > d.lo:
            raise ModelError(f"Study: range of '{name}' is empty: ({d.lo}, {d.hi}); give (lo, hi) with hi > lo.")
        if isinstance(d, LogRange) and d.lo <= 0:
            raise ModelError(f"Study: log range of '{name}' needs lo > 0; got ({d.lo}, {d.hi}).")
    if isinstance(d, Choice) and not d.values:
        raise ModelError(f"Study: choices of '{name}' are empty; give at least one value.")
    return d
