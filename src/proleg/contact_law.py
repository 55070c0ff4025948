"""Pure contact force laws: IMPACT normal force, Adams-style friction, Hertz closed forms.

These are the scalar/vector laws only (no geometry, no contact detection): the assembly layer
computes a penetration g ≥ 0, its rate ġ (> 0 while approaching) and the tangential slip
velocity, and calls these. Everything is pure ``jax.numpy`` (``jit``/``vmap``/``grad`` safe,
float64) and smooth where the Adams law is smooth.

Sources: seed 002 (IMPACT-function contact of the FLEGX tip with the ground), MSC Adams
CONTACT friction model (stiction/dynamic transition velocities), Hertz theory for the
sphere–plane closed forms (Johnson, *Contact Mechanics*, 1985, §4.2 and §11.4).
"""

from __future__ import annotations

from typing import NamedTuple

import jax.numpy as jnp
from jax.scipy.special import gammaln

from .fn import _safe_pow, step

__all__ = [
    "normal_force",
    "friction_coefficient",
    "friction_vector",
    "hertz_sphere_plane_stiffness",
    "hertz_duration_constant",
    "ImpactResponse",
    "impact_response",
]


def normal_force(penetration, penetration_rate, stiffness, exponent, damping, dmax):
    """IMPACT contact law in penetration form (seed 002; Adams IMPACT with g = x1 − x).

    ::

        F_n = max(0, k g^e + STEP(g, 0, 0, dmax, c) · ġ)    for g > 0
        F_n = 0                                              for g ≤ 0

    The damping coefficient is ramped in from 0 at first contact to ``c`` at the penetration
    ``dmax``, so F_n is continuous at touchdown. Clipped at 0: the ground never pulls
    (no sticking on rebound). Derivatives are finite at g = 0 for any exponent ≥ 1
    (non-integer powers are evaluated on a safe inner value outside contact).

    Parameters
    ----------
    penetration : array_like [m]          g, > 0 in contact
    penetration_rate : array_like [m/s]   ġ, > 0 while approaching (penetration growing)
    stiffness : array_like [N/m^e]        k
    exponent : array_like [-]             e (1.5 for a Hertz sphere, 1 linear)
    damping : array_like [N s/m]          c, maximum damping coefficient
    dmax : array_like [m], > 0            penetration at which the full damping is reached

    Returns
    -------
    Array [N], ≥ 0, pushing the bodies apart along the contact normal.
    """
    g = penetration
    c = step(g, 0.0, 0.0, dmax, damping)
    f = stiffness * _safe_pow(g, exponent) + c * penetration_rate
    return jnp.where((g > 0.0) & (f > 0.0), f, 0.0)


def _mu_of_speed(s, mu_static, mu_dynamic, v_stiction, v_friction):
    """Signed coefficient μ(s) for a scalar slip velocity s (odd in s)."""
    a = jnp.abs(s)
    sgn = jnp.sign(s)
    low = step(s, -v_stiction, -mu_static, v_stiction, mu_static)  # odd, smooth through 0
    mid = sgn * step(a, v_stiction, mu_static, v_friction, mu_dynamic)
    return jnp.where(a < v_stiction, low, mid)


def friction_coefficient(v_slip, mu_static, mu_dynamic, v_stiction, v_friction):
    """Adams contact friction coefficient, signed (odd in the slip velocity).

    ::

        μ(v) = STEP(v, −v_s, −μ_s, v_s, μ_s)                 for |v| < v_s
        μ(v) = sign(v) · STEP(|v|, v_s, μ_s, v_d, μ_d)       for v_s ≤ |v| ≤ v_d
        μ(v) = sign(v) · μ_d                                  for |v| > v_d

    So |μ| rises smoothly from 0 at v = 0 to μ_s at the stiction transition velocity v_s
    (slope 1.5 μ_s / v_s at 0, which acts as a stiff viscous "stiction" spring), falls from
    μ_s to μ_d between v_s and the friction transition velocity v_d, and stays μ_d beyond.
    C1 in v. The friction force on the sliding body is ``−μ(v) · F_n`` (it opposes v).

    Parameters
    ----------
    v_slip : array_like [m/s]        tangential slip velocity (scalar form)
    mu_static, mu_dynamic : array_like [-]   μ_s ≥ μ_d ≥ 0 (need not be ordered)
    v_stiction : array_like [m/s]    v_s > 0, stiction transition velocity
    v_friction : array_like [m/s]    v_d > v_s, friction (dynamic) transition velocity

    Returns
    -------
    Array [-], same sign as v_slip.

    Choosing values: Adams defaults are v_s = 0.1 m/s, v_d = 10 m/s; for a robot foot a
    v_s of 1e-3–1e-2 m/s and v_d ≈ 2 v_s are more realistic. Small v_s is closer to true
    stiction but makes the law stiff (slope 1.5 μ_s F_n / v_s).
    """
    return _mu_of_speed(v_slip, mu_static, mu_dynamic, v_stiction, v_friction)


def friction_vector(v_tangential, mu_static, mu_dynamic, v_stiction, v_friction):
    """Vector friction coefficient for a tangential slip velocity, ``μ(|v|) · v/|v|``.

    The friction force on the sliding body is ``−F_n · friction_vector(v_t, ...)``. The law is
    isotropic in the tangent plane and uses :func:`friction_coefficient` for the magnitude.
    Safe at v = 0: since μ(s)/s → 1.5 μ_s / v_s as s → 0, the result is computed as
    ``(μ(|v|)/|v|) · v`` with that limit at zero, so value and derivatives are finite there.

    Parameters
    ----------
    v_tangential : (..., 3) or (..., 2) array_like [m/s]   slip velocity in the tangent plane
    mu_static, mu_dynamic, v_stiction, v_friction : as :func:`friction_coefficient`

    Returns
    -------
    (..., 3) or (..., 2) Array [-], parallel to v_tangential, norm μ(|v|).
    """
    v = jnp.asarray(v_tangential)
    s2 = jnp.sum(v * v, axis=-1, keepdims=True)
    nz = s2 > 0.0
    s = jnp.sqrt(jnp.where(nz, s2, 1.0))
    mu = _mu_of_speed(s, mu_static, mu_dynamic, v_stiction, v_friction)
    ratio = jnp.where(nz, mu / s, 1.5 * mu_static / v_stiction)
    return ratio * v


def hertz_sphere_plane_stiffness(radius, youngs_1, poisson_1, youngs_2, poisson_2):
    """Hertz stiffness of a sphere on a plane (exponent 1.5): F = k δ^1.5.

    ``k = (4/3) E* sqrt(R)`` with ``1/E* = (1 − ν1²)/E1 + (1 − ν2²)/E2`` (Johnson 1985, §4.2).

    Parameters
    ----------
    radius : [m]                 sphere radius (for two spheres use R = R1 R2/(R1 + R2))
    youngs_1, youngs_2 : [Pa]    Young's moduli
    poisson_1, poisson_2 : [-]   Poisson ratios

    Returns
    -------
    k [N/m^1.5]
    """
    e_star = 1.0 / ((1.0 - poisson_1**2) / youngs_1 + (1.0 - poisson_2**2) / youngs_2)
    return 4.0 / 3.0 * e_star * jnp.sqrt(radius)


def hertz_duration_constant(exponent=1.5):
    """Dimensionless constant C(e) of the undamped impact duration T = C · δ_max / v0.

    From T = 2 ∫₀^δmax dδ / sqrt(v0² − 2 k δ^(e+1) / ((e+1) m)) with u = δ/δ_max and
    n = e + 1: ``C = 2 ∫₀¹ (1 − uⁿ)^(−1/2) du = (2/n) B(1/n, 1/2)``.
    For e = 1.5: C = 2.9432 (the classic Hertz value T ≈ 2.94 δ_max / v0); in terms of the
    data, T = 3.2181 (m² / (k² v0))^(1/5) (= 2.9432 · (5/4)^(2/5)).
    """
    n = exponent + 1.0
    log_beta = gammaln(1.0 / n) + gammaln(0.5) - gammaln(1.0 / n + 0.5)
    return 2.0 / n * jnp.exp(log_beta)


class ImpactResponse(NamedTuple):
    """Closed-form undamped impact of a mass on a power-law spring (see :func:`impact_response`)."""

    max_penetration: jnp.ndarray  # [m]
    peak_force: jnp.ndarray  # [N]
    duration: jnp.ndarray  # [s]


def impact_response(mass, speed, stiffness, exponent=1.5):
    """Peak penetration, peak force and contact duration of an undamped impact.

    A mass ``m`` hits a rigid surface with normal speed ``v0`` through the law F = k δ^e
    (e = 1.5: Hertz sphere on a plane). Energy: ½ m v0² = k δ_max^(e+1)/(e+1), so::

        δ_max = ((e+1) m v0² / (2k))^(1/(e+1)),    F_max = k δ_max^e,
        T     = C(e) δ_max / v0                     (C from :func:`hertz_duration_constant`)

    For e = 1.5: T = 3.2181 (m²/(k² v0))^(1/5) and F_max = (5/4)^(3/5) (k² m³ v0⁶)^(1/5)
    = 1.1433 (k² m³ v0⁶)^(1/5). The rebound speed equals v0 (no damping).

    Parameters
    ----------
    mass : [kg]      m > 0
    speed : [m/s]    v0 > 0, normal approach speed
    stiffness : [N/m^e]   k > 0
    exponent : [-]   e > 0, default 1.5

    Returns
    -------
    :class:`ImpactResponse` (max_penetration [m], peak_force [N], duration [s]).
    """
    n = exponent + 1.0
    dmax = (n * mass * speed**2 / (2.0 * stiffness)) ** (1.0 / n)
    fmax = stiffness * dmax**exponent
    duration = hertz_duration_constant(exponent) * dmax / speed
    return ImpactResponse(dmax, fmax, duration)
