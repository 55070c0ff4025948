"""Motion laws whose shape is made of design variables: a spline through knots, a chain of STEP5
segments and a Fourier series (issue 30, "design the motion, not only the hardware").

A law's knot values (or durations, or coefficients) are the model's design variables
(:meth:`proleg.Model.add_variable`), named ``"<law>_<part><k>"`` (``push_y0``, ``push_d1``,
``gait_b2``). They become System parameters, so a study sweeps, vmaps, differentiates and
optimises them like a stiffness, **without recompiling**: the compiled simulation reads the
values from the System, never from the law object.

Add a law to a model with :meth:`proleg.Model.add_law`; then use it wherever a function of time
``f(t, state)`` is accepted:

- a :class:`~proleg.model.control.Motion` (``displacement=law``: an imposed joint coordinate);
- a PID set point (``PID(..., setpoint=law)``);
- a feed-forward force or torque (``JointActuator(..., effort=law)``, ``Torque(..., value=...)``);
- a force law of another argument: ``law.at(x, state)`` evaluates it at any x (a stroke, an
  angle), ``law.at(x, state, nu=1)`` its derivative.

``state`` is anything with ``state.variable(name)`` (what force functions, controllers and
motions receive), or a mapping {variable name: value} (to evaluate a law outside a simulation).

Each law is as smooth as the Adams function it is built from (:mod:`proleg.fn`): the clamped
spline and the STEP5 chain are C2 (continuous acceleration, as a motion law imposed on a joint
needs), the Fourier series is C-infinity. Outside the knots the spline and the chain hold their
end values (zero velocity and acceleration).

Example::

    law = pl.SplineLaw("push", times=[0.0, 0.1, 0.2, 0.3], values=[0.0, 0.2, 0.6, 1.0])
    model.add_law(law)                       # variables push_y0 ... push_y3
    model.add_motion(pl.Motion("drive", "knee", displacement=law))
    space = law.space(lo=-1.0, hi=1.5)       # {"push_y0": (-1.0, 1.5), ...} for a Study
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from ..errors import ModelError
from ._validate import finite_array, finite_scalar

__all__ = ["AbstractLaw", "SplineLaw", "Step5Chain", "FourierLaw"]


def read_variable(state, name: str):
    """The value of design variable ``name`` from a state view or a {name: value} mapping."""
    if isinstance(state, Mapping):
        try:
            return state[name]
        except KeyError:
            raise ModelError(f"Law variable '{name}' is not in the mapping given; known: {sorted(state)}.") from None
    reader = getattr(state, "variable", None)
    if reader is None:
        raise ModelError(
            f"A motion law was evaluated with {type(state).__name__}, which has no design variables; pass the "
            "state that proleg gives a function f(t, state), or a mapping {variable name: value}."
        )
    return reader(name)


class AbstractLaw:
    """A scalar law y(x) [any unit] whose shape parameters are design variables.

    Subclasses define ``_names`` (the variable names, in order), ``_values`` (their initial
    values) and ``evaluate(x, p, nu)`` (the law and its derivatives in jnp from the vector p of
    the variables' values). Calling the law, ``law(t, state)``, evaluates it at time t.
    """

    unit = ""

    def __init__(self, name: str):
        if not isinstance(name, str) or not name.isidentifier():
            raise ModelError(f"{type(self).__name__}: the name must be an identifier (letters, digits, _), got {name!r}.")
        self.name = name
        self._names: list[str] = []
        self._values: np.ndarray = np.zeros(0)

    # -- variables ---------------------------------------------------------------------------
    @property
    def variables(self) -> dict:
        """{variable name: initial value}, in the law's order."""
        return dict(zip(self._names, (float(v) for v in self._values)))

    def add_to(self, model) -> AbstractLaw:
        """Register the law's variables on ``model`` (what :meth:`proleg.Model.add_law` does)."""
        for n, v in self.variables.items():
            model.add_variable(n, v, self.unit, f"{type(self).__name__} '{self.name}'")
        return self

    def values(self, state):
        """The vector p of the variables' current values (traced in a simulation)."""
        import jax.numpy as jnp

        return jnp.stack([jnp.asarray(read_variable(state, n), jnp.float64).reshape(()) for n in self._names])

    def space(self, lo=None, hi=None, *, names=None) -> dict:
        """{variable: (lo, hi)} for a :class:`proleg.study.Study` space: ``lo``/``hi`` a number
        (every variable) or a {variable: bound} mapping; ``names`` restricts to some variables.
        Without bounds a law-specific default is used where one exists (:meth:`_default_bounds`)."""
        out = {}
        for n in names or self._names:
            if n not in self._names:
                raise ModelError(f"{type(self).__name__} '{self.name}': no variable '{n}'; its variables: {self._names}.")
            dlo, dhi = self._default_bounds(n)
            a = lo.get(n, dlo) if isinstance(lo, Mapping) else (dlo if lo is None else lo)
            b = hi.get(n, dhi) if isinstance(hi, Mapping) else (dhi if hi is None else hi)
            if a is None or b is None:
                raise ModelError(f"{type(self).__name__} '{self.name}': give lo= and hi= bounds for '{n}'.")
            out[n] = (float(a), float(b))
        return out

    def _default_bounds(self, name):
        return None, None

    # -- evaluation --------------------------------------------------------------------------
    def evaluate(self, x, p, nu: int = 0):  # pragma: no cover - abstract
        raise NotImplementedError

    def at(self, x, state, nu: int = 0):
        """d^nu y / dx^nu at x, with the variables read from ``state``."""
        if nu not in (0, 1, 2):
            raise ModelError(f"{type(self).__name__} '{self.name}': derivative order nu must be 0, 1 or 2, got {nu!r}.")
        return self.evaluate(x, self.values(state), nu)

    def __call__(self, t, state):
        return self.at(t, state, 0)

    def derivative(self, nu: int = 1):
        """A function ``f(t, state)`` of the nu-th derivative (a velocity or acceleration law)."""
        return lambda t, state: self.at(t, state, nu)

    @property
    def breakpoints(self) -> tuple:
        """Times where a derivative of order ≥ 3 jumps (given to a Motion's ``breakpoints``)."""
        return ()

    def __repr__(self):
        return f"{type(self).__name__}({self.name!r}, variables={self._names})"


class SplineLaw(AbstractLaw):
    """Cubic spline through N knots (t_k, y_k): the knot values y_k are design variables
    ``"<name>_y<k>"``; the knot times are fixed [s, or the unit of the argument].

    The spline's coefficients are linear in the knot values: the map is computed once in numpy
    (scipy ``CubicSpline`` of each unit vector), so evaluating the law is a small matrix product
    and a cubic, traceable and differentiable in the values.

    Parameters
    ----------
    name : str
    times : (N,) strictly increasing, N ≥ 2
    values : (N,) initial knot values [any unit]
    bc : "clamped" (default: zero slope at both ends — a motion that starts and ends at rest,
        C2 inside and C1 at the ends with the hold outside), "natural" (zero second derivative at
        the ends) or "not-a-knot"
    unit : text, for the variables' description
    """

    def __init__(self, name, times, values, bc="clamped", unit=""):
        super().__init__(name)
        t = finite_array(f"SplineLaw '{name}' times", times).ravel()
        y = finite_array(f"SplineLaw '{name}' values", values).ravel()
        if t.size < 2 or y.size != t.size:
            raise ModelError(f"SplineLaw '{name}': give N ≥ 2 knot times and as many values; got {t.size} times, {y.size} values.")
        if not np.all(np.diff(t) > 0):
            raise ModelError(f"SplineLaw '{name}': knot times must be strictly increasing, got {t.tolist()}.")
        if bc not in ("clamped", "natural", "not-a-knot"):
            raise ModelError(f"SplineLaw '{name}': bc must be 'clamped', 'natural' or 'not-a-knot', got {bc!r}.")
        if bc == "not-a-knot" and t.size < 4:
            raise ModelError(f"SplineLaw '{name}': a not-a-knot spline needs N ≥ 4 knots (got {t.size}); use bc='clamped'.")
        from scipy.interpolate import CubicSpline

        self.times, self.bc, self.unit = t, bc, unit
        # basis[c, i, k]: coefficient c (highest power first) of interval i for a unit value at knot k
        self.basis = np.stack([CubicSpline(t, e, bc_type=bc).c for e in np.eye(t.size)], axis=-1)
        self._names = [f"{name}_y{k}" for k in range(t.size)]
        self._values = y

    def evaluate(self, x, p, nu: int = 0):
        import jax.numpy as jnp

        t = jnp.asarray(self.times)
        x = jnp.asarray(x, jnp.float64)
        inside = (x >= t[0]) & (x <= t[-1])
        # where, not clip: jnp.clip's derivative is 1/2 at a tie, which would halve the law's
        # velocity (and quarter its acceleration) exactly at the first knot, the start of a run
        xc = jnp.where(x < t[0], t[0], jnp.where(x > t[-1], t[-1], x))
        i = jnp.clip(jnp.searchsorted(t, xc, side="right") - 1, 0, t.shape[0] - 2)
        c = jnp.asarray(self.basis) @ p  # (4, N-1)
        c3, c2, c1, c0 = c[0, i], c[1, i], c[2, i], c[3, i]
        dx = xc - t[i]
        if nu == 0:
            return ((c3 * dx + c2) * dx + c1) * dx + c0
        y = (3.0 * c3 * dx + 2.0 * c2) * dx + c1 if nu == 1 else 6.0 * c3 * dx + 2.0 * c2
        return jnp.where(inside, y, 0.0)  # held end value outside the knots

    @property
    def breakpoints(self):
        return tuple(float(v) for v in self.times)


class Step5Chain(AbstractLaw):
    """A chain of Adams STEP5 segments through N knots: y(t) = y_0 + Σ_k STEP5(t, t_k, 0, t_{k+1},
    y_{k+1} − y_k) (each segment a quintic blend with zero velocity and acceleration at both
    ends, :func:`proleg.fn.step5`).

    Design variables: the knot values ``"<name>_y<k>"`` (k = 0..N−1) and, with
    ``vary_durations=True``, the segment durations ``"<name>_d<k>"`` (k = 0..N−2) [s], t_{k+1} =
    t_k + d_k from the fixed start ``t0``: durations keep the knots in order for any positive
    values, where free knot times could cross. A duration is read through max(d, 1e-9 s).

    Parameters
    ----------
    name : str
    times : (N,) strictly increasing knot times [s] (with ``vary_durations`` the initial ones)
    values : (N,) initial knot values [any unit]
    vary_durations : bool, default False
    """

    def __init__(self, name, times, values, vary_durations=False, unit=""):
        super().__init__(name)
        t = finite_array(f"Step5Chain '{name}' times", times).ravel()
        y = finite_array(f"Step5Chain '{name}' values", values).ravel()
        if t.size < 2 or y.size != t.size:
            raise ModelError(f"Step5Chain '{name}': give N ≥ 2 knot times and as many values; got {t.size} times, {y.size} values.")
        if not np.all(np.diff(t) > 0):
            raise ModelError(f"Step5Chain '{name}': knot times must be strictly increasing, got {t.tolist()}.")
        self.t0, self.times, self.unit, self.vary_durations = float(t[0]), t, unit, bool(vary_durations)
        self.n = t.size
        self._names = [f"{name}_y{k}" for k in range(t.size)]
        self._values = y
        if self.vary_durations:
            self._names += [f"{name}_d{k}" for k in range(t.size - 1)]
            self._values = np.concatenate([y, np.diff(t)])

    def _default_bounds(self, name):
        if name.startswith(f"{self.name}_d"):
            d = float(self._values[self._names.index(name)])
            return 0.25 * d, 4.0 * d
        return None, None

    def knot_times(self, p):
        """The knot times [s] from the variables' vector p."""
        import jax.numpy as jnp

        if not self.vary_durations:
            return jnp.asarray(self.times)
        d = jnp.maximum(p[self.n :], 1e-9)
        return self.t0 + jnp.concatenate([jnp.zeros(1), jnp.cumsum(d)])

    def evaluate(self, x, p, nu: int = 0):
        import jax.numpy as jnp

        t = self.knot_times(p)
        y = p[: self.n]
        x = jnp.asarray(x, jnp.float64)
        out = y[0] if nu == 0 else jnp.zeros_like(x)
        for k in range(self.n - 1):
            h = t[k + 1] - t[k]
            d = (x - t[k]) / h
            d = jnp.where(d < 0.0, 0.0, jnp.where(d > 1.0, 1.0, d))
            a = y[k + 1] - y[k]
            if nu == 0:
                s = d**3 * (10.0 + d * (-15.0 + 6.0 * d))
            elif nu == 1:
                s = 30.0 * d * d * (1.0 - d) ** 2 / h
            else:
                s = 60.0 * d * (1.0 - d) * (1.0 - 2.0 * d) / (h * h)
            out = out + a * s
        return out + 0.0 * x

    @property
    def breakpoints(self):
        return tuple(float(v) for v in self.times)


class FourierLaw(AbstractLaw):
    """Truncated Fourier series y(t) = a_0 + Σ_{k=1..K} a_k cos(k ω t) + b_k sin(k ω t),
    ω = 2π / period: a periodic gait or set-point law. Design variables ``"<name>_a0"``,
    ``"<name>_a<k>"``, ``"<name>_b<k>"``.

    Parameters
    ----------
    name : str
    period : float [s], > 0 (fixed: a frequency that changes would change every phase)
    a0 : float, initial mean value; a, b : (K,) initial cosine and sine amplitudes
    """

    def __init__(self, name, period, a0=0.0, a=(0.0,), b=(0.0,), unit=""):
        super().__init__(name)
        self.period = finite_scalar(f"FourierLaw '{name}' period", period, positive=True, unit="s")
        a = finite_array(f"FourierLaw '{name}' a", a).ravel()
        b = finite_array(f"FourierLaw '{name}' b", b).ravel()
        if a.size != b.size or a.size < 1:
            raise ModelError(f"FourierLaw '{name}': a and b need the same number K ≥ 1 of harmonics; got {a.size} and {b.size}.")
        self.harmonics, self.unit = a.size, unit
        K = a.size
        self._names = [f"{name}_a0"] + [f"{name}_a{k}" for k in range(1, K + 1)] + [f"{name}_b{k}" for k in range(1, K + 1)]
        self._values = np.concatenate([[finite_scalar(f"FourierLaw '{name}' a0", a0)], a, b])

    def evaluate(self, x, p, nu: int = 0):
        import jax.numpy as jnp

        K = self.harmonics
        w = 2.0 * np.pi / self.period * np.arange(1, K + 1)
        x = jnp.asarray(x, jnp.float64)
        ph = w * x[..., None]
        a, b = p[1 : K + 1], p[K + 1 :]
        if nu == 0:
            return p[0] + jnp.sum(a * jnp.cos(ph) + b * jnp.sin(ph), -1)
        if nu == 1:
            return jnp.sum(w * (-a * jnp.sin(ph) + b * jnp.cos(ph)), -1)
        return jnp.sum(-w * w * (a * jnp.cos(ph) + b * jnp.sin(ph)), -1)
