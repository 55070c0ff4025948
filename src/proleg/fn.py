"""Adams-style function library for force, torque and motion laws.

Every function here is pure ``jax.numpy``: no Python branching on values, so each one works
under ``jit``, ``vmap``, ``jax.grad`` and ``jax.jacfwd`` in float64, and is as smooth as the
Adams function it mirrors (STEP is C1, STEP5 and the spline are C2, HAVSIN is C1, SINUSOID
C-infinity). Piecewise laws are written with ``jnp.clip``/``jnp.where`` and, where a branch
would produce ``inf``/``NaN`` outside its domain (a non-integer power of a negative number),
with a safe inner value, so that derivatives are finite everywhere.

Names and argument orders follow MSC Adams (STEP, STEP5, HAVSIN, IMPACT, BISTOP), so a law
copied from an Adams model reads the same here::

    theta = step(t, 0.0, 0.0, 0.5, 30 * deg)            # seed 002, Eq. 18
    f_n   = impact(y, ydot, 0.0, 1e5, 1.5, 50.0, 1e-4)  # seed 002, contact of the leg tip

Sources: seed 002 (Eq. 18, STEP motion law; IMPACT function for the tip contact),
MSC Adams/Solver function reference (STEP, STEP5, HAVSIN, IMPACT, BISTOP, CUBSPL).
"""

from __future__ import annotations

from typing import Literal

import jax
import jax.numpy as jnp
import numpy as np

__all__ = [
    "step",
    "step5",
    "havsin",
    "sinusoid",
    "impact",
    "bistop",
    "spline",
    "Spline",
    "smooth_sign",
    "coulomb",
]


def _unit(x, x0, x1):
    """Normalised, clipped coordinate Δ = clip((x − x0)/(x1 − x0), 0, 1)."""
    return jnp.clip((x - x0) / (x1 - x0), 0.0, 1.0)


def step(x, x0, h0, x1, h1):
    """Adams STEP: cubic blend from h0 at x0 to h1 at x1 (seed 002, Eq. 18).

    ``h0`` for x ≤ x0; ``h0 + a Δ²(3 − 2Δ)`` for x0 < x < x1, with a = h1 − h0 and
    Δ = (x − x0)/(x1 − x0); ``h1`` for x ≥ x1. The printed Eq. 18 of seed 002 has a minus
    sign in front of ``a`` — an extraction error (MODEL_DATA §3): the law must reach h1.

    C1: value and first derivative are continuous (dSTEP/dx = 0 at both ends); the second
    derivative jumps by ±6a/(x1 − x0)² at the ends. Use :func:`step5` where a continuous
    acceleration matters (a motion law imposed on a joint).

    Parameters
    ----------
    x : array_like        the independent variable (time [s], displacement, ...)
    x0, x1 : array_like   start and end of the transition, x0 < x1 (same unit as x)
    h0, h1 : array_like   values before and after the transition (any unit)

    Returns
    -------
    Array, broadcast of the inputs.
    """
    d = _unit(x, x0, x1)
    s = d * d * (3.0 - 2.0 * d)
    return h0 * (1.0 - s) + h1 * s


def step5(x, x0, h0, x1, h1):
    """Adams STEP5: quintic blend ``h0 + a Δ³(10 − 15Δ + 6Δ²)``, a = h1 − h0.

    Same arguments and end values as :func:`step`; C2 (first and second derivatives vanish at
    both ends), so a motion law built with it has continuous acceleration.
    """
    d = _unit(x, x0, x1)
    s = d * d * d * (10.0 + d * (-15.0 + 6.0 * d))
    return h0 * (1.0 - s) + h1 * s


def havsin(x, x0, h0, x1, h1):
    """Adams HAVSIN: haversine blend ``h0 + a (1 − cos(π Δ))/2``, a = h1 − h0.

    Same arguments and end values as :func:`step`. C1 (zero slope at the ends); the second
    derivative jumps by ±a π²/(2 (x1 − x0)²) at the ends.
    """
    d = _unit(x, x0, x1)
    s = 0.5 * (1.0 - jnp.cos(jnp.pi * d))
    return h0 * (1.0 - s) + h1 * s


def sinusoid(t, amplitude, frequency_hz, phase=0.0, offset=0.0):
    """``offset + amplitude · sin(2π · frequency_hz · t + phase)``.

    Parameters
    ----------
    t : array_like [s]
    amplitude : array_like   (unit of the result)
    frequency_hz : array_like [Hz]   (cycles per second, not rad/s)
    phase : array_like [rad], default 0
    offset : array_like, default 0
    """
    return offset + amplitude * jnp.sin(2.0 * jnp.pi * frequency_hz * t + phase)


def _safe_pow(g, e):
    """``g**e`` for g > 0 and 0 for g ≤ 0, with finite derivatives at and below g = 0."""
    pos = g > 0.0
    g_safe = jnp.where(pos, g, 1.0)
    return jnp.where(pos, g_safe**e, 0.0)


def impact(x, xdot, x1, k, e, cmax, d, clip_negative=True):
    """Adams IMPACT: one-sided nonlinear spring-damper that acts when x < x1.

    With the penetration g = x1 − x::

        F = 0                                                     for x ≥ x1
        F = k g^e − STEP(x, x1 − d, cmax, x1, 0) · ẋ              for x < x1

    The damping coefficient is ramped in by a cubic STEP from 0 at contact (g = 0) to cmax
    at the penetration d, so the force is continuous at first contact. The force is positive
    (it pushes x back above x1) and acts on the body whose coordinate is x. Seed 002 uses it
    for the contact of the flexible link tip with the ground.

    Sign choice (``clip_negative``): on rebound (ẋ > 0) the damping term can outweigh the
    spring and make F negative, i.e. the surface would pull on the body ("sticking"). With
    ``clip_negative=True`` (default, what most users expect of a contact and what the
    Adams/Solver reference prescribes with its ``max(0, ...)``) F is clipped at 0; pass
    ``False`` for the raw, possibly negative law.

    Derivatives are finite everywhere, including x = x1 with a non-integer exponent (the
    power is evaluated on a safe inner value outside contact). For e < 1 the derivative
    ∂F/∂x is unbounded as g → 0⁺, as the law itself is.

    Parameters
    ----------
    x : array_like [m or rad]       distance variable (e.g. height of the contact point)
    xdot : array_like [m/s, rad/s]  its time derivative
    x1 : array_like                 x at first contact (free distance)
    k : array_like [N/m^e]          stiffness
    e : array_like [-]              force exponent, > 0 (1 = linear, 1.5 = Hertz sphere)
    cmax : array_like [N s/m]       maximum damping coefficient
    d : array_like [m]              penetration at which the full damping cmax is reached, > 0
    clip_negative : bool, default True   clip the force at 0 (no sticking)

    Returns
    -------
    Array [N or N m], ≥ 0 when ``clip_negative``.
    """
    g = x1 - x
    spring = k * _safe_pow(g, e)
    c = step(x, x1 - d, cmax, x1, 0.0)
    f = jnp.where(g > 0.0, spring - c * xdot, 0.0)
    if clip_negative:
        f = jnp.where(f > 0.0, f, 0.0)
    return f


def bistop(x, xdot, x1, x2, k, e, cmax, d, clip_negative=True):
    """Adams BISTOP: a gap element, free for x1 ≤ x ≤ x2, IMPACT-like outside.

    ::

        x < x1:        F =  k (x1 − x)^e − STEP(x, x1 − d, cmax, x1, 0) · ẋ    (≥ 0)
        x1 ≤ x ≤ x2:   F = 0
        x > x2:        F = −k (x − x2)^e − STEP(x, x2, 0, x2 + d, cmax) · ẋ    (≤ 0)

    The force pushes x back into the free interval. With ``clip_negative`` (default True,
    as Adams) each branch is clipped to its pushing sign, so the stops never pull.

    Parameters as :func:`impact`; ``x1 < x2`` are the two stops [m or rad].
    """
    g_lo = x1 - x
    g_hi = x - x2
    f_lo = k * _safe_pow(g_lo, e) - step(x, x1 - d, cmax, x1, 0.0) * xdot
    f_hi = -k * _safe_pow(g_hi, e) - step(x, x2, 0.0, x2 + d, cmax) * xdot
    if clip_negative:
        f_lo = jnp.where(f_lo > 0.0, f_lo, 0.0)
        f_hi = jnp.where(f_hi < 0.0, f_hi, 0.0)
    return jnp.where(g_lo > 0.0, f_lo, jnp.where(g_hi > 0.0, f_hi, 0.0))


def smooth_sign(v, eps, kind: Literal["algebraic", "tanh", "step"] = "algebraic"):
    """Smooth approximation of sign(v) over a regularisation width ``eps``.

    ``kind`` (static):

    - ``"algebraic"`` (default): v / sqrt(v² + eps²); C-infinity, slope 1/eps at 0, reaches
      ±0.707 at ±eps and approaches ±1 only asymptotically.
    - ``"tanh"``: tanh(v/eps); C-infinity, slope 1/eps at 0, ±0.76 at ±eps.
    - ``"step"``: STEP(v, −eps, −1, eps, 1), the Adams idiom; C1, exactly ±1 for |v| ≥ eps,
      slope 1.5/eps at 0.

    Choosing eps: a few percent of the typical sliding speed. Smaller eps is closer to Coulomb
    friction but makes the law stiffer (slope ~1/eps) and the integrator slower.

    Parameters
    ----------
    v : array_like [any velocity unit]
    eps : array_like, > 0, same unit as v
    """
    if kind == "algebraic":
        return v / jnp.sqrt(v * v + eps * eps)
    if kind == "tanh":
        return jnp.tanh(v / eps)
    if kind == "step":
        return step(v, -eps, -1.0, eps, 1.0)
    raise ValueError(f"smooth_sign: kind must be 'algebraic', 'tanh' or 'step', got {kind!r}.")


def coulomb(v, force, eps, damping=0.0, kind: Literal["algebraic", "tanh", "step"] = "step"):
    """Regularised Coulomb (+ viscous) friction opposing the sliding velocity.

    ``F = −force · smooth_sign(v, eps, kind) − damping · v``: the friction force (or torque)
    acting on the body that slides with velocity v relative to its counterpart; the reaction
    acts on the counterpart. E.g. the Scout II hip joint (seed 003, Table 5): stiction
    5.5e-3 N m.

    Parameters
    ----------
    v : array_like [m/s or rad/s]        sliding velocity
    force : array_like [N or N m], ≥ 0   Coulomb friction level
    eps : array_like, > 0                regularisation width, same unit as v
    damping : array_like [N s/m or N m s/rad], default 0   viscous coefficient
    kind : see :func:`smooth_sign`; default ``"step"`` (exactly the Coulomb level for |v| ≥ eps)
    """
    return -force * smooth_sign(v, eps, kind) - damping * v


# --------------------------------------------------------------------------------------------
# Cubic spline through tabulated data (Adams CUBSPL / AKISPL use)
# --------------------------------------------------------------------------------------------


@jax.tree_util.register_pytree_node_class
class Spline:
    """Interpolating cubic spline (C2), evaluated in jnp; build it with :func:`spline`.

    The coefficients are computed once (numpy/scipy) and stored as arrays; evaluating at a
    traced argument is traceable (``jnp.searchsorted`` picks the interval). The spline is a
    pytree, so it can be passed into ``jit``-compiled functions as an argument.

    Call ``s(x)`` for the value, ``s(x, nu=1)`` / ``s(x, nu=2)`` for the first / second
    derivative (velocity / acceleration of a tabulated motion). ``s.derivative(nu)`` returns a
    callable for the ``nu``-th derivative.

    Attributes
    ----------
    knots : (n,) array         breakpoints, strictly increasing
    coeffs : (4, n−1, ...) array   per-interval polynomial coefficients, highest power first,
                               in the local variable x − knots[i] (scipy ``PPoly`` layout)
    extrapolate : {"cubic", "linear", "hold"}   behaviour outside [knots[0], knots[-1]]
    """

    def __init__(self, knots, coeffs, extrapolate="cubic"):
        self.knots = knots
        self.coeffs = coeffs
        self.extrapolate = extrapolate

    def tree_flatten(self):
        return (self.knots, self.coeffs), (self.extrapolate,)

    @classmethod
    def tree_unflatten(cls, aux, children):
        return cls(*children, *aux)

    def _eval_poly(self, x, nu):
        t = self.knots
        c = self.coeffs
        n = t.shape[0]
        i = jnp.clip(jnp.searchsorted(t, x, side="right") - 1, 0, n - 2)
        dx = x - t[i]
        c3, c2, c1, c0 = c[0, i], c[1, i], c[2, i], c[3, i]
        dx = jnp.reshape(dx, dx.shape + (1,) * (c3.ndim - dx.ndim))
        if nu == 0:
            return ((c3 * dx + c2) * dx + c1) * dx + c0
        if nu == 1:
            return (3.0 * c3 * dx + 2.0 * c2) * dx + c1
        if nu == 2:
            return 6.0 * c3 * dx + 2.0 * c2
        if nu == 3:
            return 6.0 * c3 + 0.0 * dx
        raise ValueError(f"Spline: derivative order nu must be 0, 1, 2 or 3, got {nu!r}.")

    def __call__(self, x, nu: int = 0):
        x = jnp.asarray(x)
        if self.extrapolate == "cubic":
            return self._eval_poly(x, nu)
        t0, t1 = self.knots[0], self.knots[-1]
        xc = jnp.clip(x, t0, t1)
        inside = (x >= t0) & (x <= t1)
        y_in = self._eval_poly(x, nu)
        shape = y_in.shape
        inside = jnp.reshape(inside, inside.shape + (1,) * (y_in.ndim - inside.ndim))
        if self.extrapolate == "hold":
            y_out = self._eval_poly(xc, 0) if nu == 0 else jnp.zeros(shape)
        elif self.extrapolate == "linear":
            if nu == 0:
                y_end = self._eval_poly(xc, 0)
                slope = self._eval_poly(xc, 1)
                dxo = jnp.reshape(x - xc, (x - xc).shape + (1,) * (y_in.ndim - x.ndim))
                y_out = y_end + slope * dxo
            elif nu == 1:
                y_out = self._eval_poly(xc, 1)
            else:
                y_out = jnp.zeros(shape)
        else:
            raise ValueError(
                f"Spline: extrapolate must be 'cubic', 'linear' or 'hold', got {self.extrapolate!r}."
            )
        return jnp.where(inside, y_in, y_out)

    def derivative(self, nu: int = 1):
        """Callable x ↦ d^nu s / dx^nu (nu = 1 velocity, 2 acceleration)."""
        return lambda x: self(x, nu=nu)


def spline(t_data, y_data, bc_type="not-a-knot", extrapolate="cubic") -> Spline:
    """Interpolating C2 cubic spline through (t_data, y_data), traceable in its argument.

    Coefficients come from ``scipy.interpolate.CubicSpline`` (computed once, in float64 numpy);
    evaluation is pure jnp. Use it for tabulated motions (joint angle vs time from a gait
    recording) and tabulated force laws (measured force vs stroke), as Adams CUBSPL.

    Parameters
    ----------
    t_data : (n,) array_like, strictly increasing, n ≥ 2 (n ≥ 4 for "not-a-knot" to differ
        from a single cubic)
    y_data : (n,) or (n, m) array_like   values at the knots (any unit); columns are
        independent splines sharing the knots
    bc_type : "not-a-knot" (default) | "natural" | "clamped" | as scipy ``CubicSpline``
        Natural: zero second derivative at both ends (a motion that starts and ends without
        acceleration); not-a-knot: no end condition imposed, usually the most accurate.
    extrapolate : "cubic" (default, continue the end polynomials, as scipy) | "linear"
        (constant slope beyond the ends: constant velocity) | "hold" (constant end value)

    Returns
    -------
    :class:`Spline`  — call ``s(x)``, ``s(x, nu=1)``, ``s(x, nu=2)``.
    """
    from scipy.interpolate import CubicSpline

    t = np.asarray(t_data, dtype=np.float64)
    y = np.asarray(y_data, dtype=np.float64)
    if t.ndim != 1 or t.shape[0] < 2:
        raise ValueError(f"spline: t_data must be a 1-D array with at least 2 points, got shape {t.shape}.")
    if y.shape[:1] != t.shape:
        raise ValueError(
            f"spline: y_data has shape {y.shape}; its first axis must match t_data ({t.shape[0]} points)."
        )
    if not np.all(np.diff(t) > 0):
        raise ValueError("spline: t_data must be strictly increasing. Sort the table and remove duplicates.")
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(y))):
        raise ValueError("spline: t_data and y_data must be finite (found NaN or inf).")
    if extrapolate not in ("cubic", "linear", "hold"):
        raise ValueError(f"spline: extrapolate must be 'cubic', 'linear' or 'hold', got {extrapolate!r}.")
    cs = CubicSpline(t, y, axis=0, bc_type=bc_type)
    return Spline(jnp.asarray(cs.x), jnp.asarray(cs.c), extrapolate)
