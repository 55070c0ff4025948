"""Damping from a drop test by impulse and momentum balance (seed 000, Sec. 4.1, Eqs. 6–7).

From the HyQ-leg paper (seed 000):

* **Damping from a drop test** — impulse–momentum balance over the impact (Eqs. 6–7); see
  :func:`drop_damping` for how the printed equations are read.

Split out of :mod:`proleg.identify.classical`, which re-exports :class:`DropResult` and
:func:`drop_damping`. All inputs are SI: force [N], time [s], mass [kg], stroke [m].
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import DataError
from .classical import G0, _arr

__all__ = ["DropResult", "drop_damping"]


# --------------------------------------------------------------------------- drop test (Eqs. 6-7)
@dataclass(frozen=True)
class DropResult:
    """Damping from one drop test.

    Attributes
    ----------
    t_impact, t_end : float [s]
        Start (touchdown) and end (lift-off, or settling) of the impact window found in the force.
    duration : float [s]
        ΔT = t_end − t_impact.
    impulse : float [N·s]
        ∫ (F − F_baseline) dt over the momentum window.
    v_impact : float [m/s]
        Impact speed used (given, or from Eq. 7).
    v_impact_eq7 : float [m/s]
        Impact speed from Eq. 7, m v_i = −m g ΔT + ∫ F dt (NaN-free: None when not applicable).
    dl_max : float [m]
        Maximum compression Δl_max.
    c_eq6 : float [N·s/m]
        Eq. 6 as printed, c = m v_i² ΔT / (2 π² Δl_max²).
    c, k : float
        Least-squares fit F = k x + c ẋ over the impact window, x and ẋ from the momentum balance
        (or the measured stroke) [N·s/m], [N/m].
    lift_off : bool
        The force returned to its baseline (the body left the ground).
    """

    t_impact: float
    t_end: float
    duration: float
    impulse: float
    v_impact: float
    v_impact_eq7: float | None
    dl_max: float
    c_eq6: float
    c: float
    k: float
    lift_off: bool
    start: int
    stop: int

    def to_dict(self) -> dict:
        d = {k: getattr(self, k) for k in ("t_impact", "t_end", "duration", "impulse", "v_impact",
                                            "v_impact_eq7", "dl_max", "c_eq6", "c", "k", "lift_off")}
        d["units"] = {"t_impact": "s", "duration": "s", "impulse": "N s", "v_impact": "m/s",
                      "dl_max": "m", "c_eq6": "N s/m", "c": "N s/m", "k": "N/m"}
        return d


def drop_damping(t, force, mass: float, *, stroke=None, v_impact: float | None = None, g: float = G0,
                 threshold: float | None = None, source: str = "drop") -> DropResult:
    """Damping from a drop test by impulse and momentum balance (seed 000, Eqs. 6–7).

    A body of mass m falls on the force plate (or on its leg spring-damper) with speed v_i. The
    impact window starts where the force first exceeds the pre-impact baseline by ``threshold``
    (default: the larger of 5 % of the peak rise and 5 baseline standard deviations; the baseline
    is the median of the force before the impact, and the first 5 % of the record must precede it) and ends at
    lift-off (the force falls back to the baseline: within 3 noise standard deviations or 1 % of the
    peak rise) or, if the body stays down, where the
    force has settled to within 2 % of the peak rise (or 5 noise standard deviations) of its final
    value.

    **Eq. 7, m v_i = −m g ΔT + ∫₀^ΔT F_imp dt** is the impulse–momentum balance over a window
    that ends with the body at rest. It is applied from touchdown to the end of the record when
    the body stays on the ground (it is then at rest at the end); after a lift-off the impulse is
    m (v_i + v_rebound) and Eq. 7 does not give v_i — pass ``v_impact`` (e.g. √(2 g h)).

    **Eq. 6, m v_i² = c (2π²/ΔT) Δl_max², as printed**, reads as Eq. 5 (ΔE = c π ω X²) applied
    to the impact: the impact kinetic energy ½ m v_i² is dissipated in one equivalent half cycle
    of duration ΔT (ω = π/ΔT) at amplitude X = Δl_max: ½ m v_i² = c π (π/ΔT) Δl_max². It is an
    energy-equivalence estimate, exact only when all the impact energy is dissipated in that
    half cycle; for a lightly damped bounce it returns about √(m k)/(2π) whatever c is.
    It is reported as ``c_eq6``.

    The recommended ``c`` uses the same momentum balance in time: the compression rate
    ẋ(t) = v_i + ∫ (g − F/m) dt and compression x(t) = ∫ ẋ dt (or the measured ``stroke``) are
    fitted over the impact window by F − F_baseline = k x + c ẋ (least squares). For a linear
    spring-damper contact this recovers c and k up to the quadrature error.

    Parameters
    ----------
    t : (n,) [s]
    force : (n,) [N]
        Ground (impact) force on the body, positive upwards.
    mass : float [kg]
    stroke : (n,) [m], optional
        Measured compression of the element (any sign convention; its change from touchdown is used).
    v_impact : float [m/s], optional
        Impact speed (positive, downwards); default from Eq. 7.
    g : float [m/s²]
    threshold : float [N], optional
        Rise above baseline that marks the impact.
    """
    t = _arr(t, "time", source, allow_constant=True)
    f = _arr(force, "force", source, n=t.size)
    if not (np.isfinite(mass) and mass > 0):
        raise DataError(f"{source}: mass must be a positive number of kg, got {mass}.")
    if np.any(np.diff(t) <= 0):
        i = int(np.flatnonzero(np.diff(t) <= 0)[0]) + 1
        raise DataError(f"{source}: time does not increase at sample {i + 1} (1-based).")
    n = t.size
    nb = max(5, n // 20)
    base = float(np.median(f[:nb]))
    noise = float(np.std(f[:nb]))
    ipk = int(np.argmax(f))
    rise = f[ipk] - base
    if rise <= 10 * noise or ipk < nb:
        raise DataError(f"{source}: no impact found in column 'force': the peak rises {rise:.4g} N above "
                        f"the baseline {base:.4g} N (noise {noise:.3g} N), or lies in the first 5 % of the "
                        "record. The record must start before the impact.")
    thr = threshold if threshold is not None else max(0.05 * rise, 5.0 * noise)
    above = f - base > thr
    i0 = int(np.argmax(above))
    while i0 > 0 and f[i0 - 1] - base > 3.0 * noise and f[i0 - 1] > f[i0 - 2 if i0 >= 2 else 0]:
        i0 -= 1
    if i0 - 5 > nb:  # refine the baseline on everything before the impact (its error times ΔT biases Eq. 7)
        base = float(np.median(f[:i0 - 5]))
        noise = float(np.std(f[:i0 - 5]))
    # lift-off: back to the baseline (within noise, or 1 % of the rise), not merely below the threshold
    after = np.flatnonzero(f[ipk:] - base <= max(3.0 * noise, 0.01 * rise))
    lift_off = after.size > 0
    if lift_off:
        i1 = ipk + int(after[0])
        im = i1
    else:
        nf = max(5, n // 20)
        ffin = float(np.median(f[-nf:]))
        off = np.flatnonzero(np.abs(f[i0:] - ffin) > max(0.02 * rise, 5.0 * noise))
        i1 = i0 + int(off[-1]) + 1 if off.size else n - 1
        i1 = min(i1, n - 1)
        im = n - 1
    if i1 - i0 < 4:
        raise DataError(f"{source}: the impact spans only {i1 - i0 + 1} samples; sample faster.")
    tw, fw = t[i0:im + 1], f[i0:im + 1] - base
    impulse = float(np.trapezoid(fw, tw))
    v7 = None if lift_off else float((impulse - mass * g * (tw[-1] - tw[0])) / mass)
    if v_impact is None:
        if v7 is None:
            raise DataError(f"{source}: the force returns to its baseline at t = {t[i1]:.6g} s (lift-off), "
                            "so the impulse is m (v_i + v_rebound) and Eq. 7 cannot give the impact speed. "
                            "Pass v_impact (e.g. sqrt(2 g h) for a drop height h).")
        vi = v7
    else:
        vi = float(v_impact)
    if not vi > 0:
        raise DataError(f"{source}: impact speed {vi:.4g} m/s is not positive; check the force sign "
                        "(upwards positive) and the mass.")
    from scipy.integrate import cumulative_trapezoid

    tt, ff = t[i0:i1 + 1], f[i0:i1 + 1] - base
    if stroke is None:
        # the ground force above the pre-impact baseline acts on the body (baseline: a force plate's zero)
        xd = vi + cumulative_trapezoid(g - ff / mass, tt, initial=0.0)
        x = cumulative_trapezoid(xd, tt, initial=0.0)
    else:
        s = _arr(stroke, "stroke", source, n=n)[i0:i1 + 1]
        x = s - s[0]
        if abs(x.min()) > abs(x.max()):
            x = -x
        xd = np.gradient(x, tt)
    dl = float(np.max(np.abs(x)))
    dT = float(t[i1] - t[i0])
    c6 = mass * vi * vi * dT / (2.0 * np.pi**2 * dl * dl)
    coef, *_ = np.linalg.lstsq(np.column_stack([x, xd]), ff, rcond=None)
    out = DropResult(float(t[i0]), float(t[i1]), dT, impulse, vi, v7, dl, float(c6), float(coef[1]),
                     float(coef[0]), bool(lift_off), i0, i1)
    vals = [out.duration, out.impulse, out.v_impact, out.dl_max, out.c_eq6, out.c, out.k]
    if not np.all(np.isfinite(vals)):
        raise DataError(f"{source}: the drop analysis gave a non-finite value; check the record.")
    return out
