"""Battery model identification (seed 003, Eq. 9).

From the Scout II paper (seed 003):

* **Battery** — V = V_nom − i R_s by least squares (seed 003, Eq. 9): :func:`fit_battery`.

The line is the RMS line of :func:`proleg.identify.classical.stiffness_rms` (seed 000, Eq. 4)
through voltage over current. Split out of :mod:`proleg.identify.classical`, which re-exports
:class:`BatteryFit`, :func:`fit_battery` and :func:`plot_battery`. All inputs are SI: current
[A], voltage [V].
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .classical import _arr, stiffness_rms

__all__ = ["BatteryFit", "fit_battery", "plot_battery"]


# --------------------------------------------------------------------------- battery (seed 003, Eq. 9)
@dataclass(frozen=True)
class BatteryFit:
    """Battery model V = V_nom − i R_s fitted by least squares (seed 003, Eq. 9).

    Attributes
    ----------
    v_nom : float [V]
    r_s : float [Ω]
    v_nom_se, r_s_se : float
        Standard errors from s² = RSS / (n − 2).
    rms : float [V]
        RMS residual.
    residuals : (n,) [V]
        V − (V_nom − i R_s).
    current, voltage : (n,) [A], [V]
    """

    v_nom: float
    r_s: float
    v_nom_se: float
    r_s_se: float
    rms: float
    residuals: np.ndarray = field(repr=False)
    current: np.ndarray = field(repr=False)
    voltage: np.ndarray = field(repr=False)

    def to_dict(self) -> dict:
        return {"v_nom": self.v_nom, "r_s": self.r_s, "v_nom_se": self.v_nom_se, "r_s_se": self.r_s_se,
                "rms": self.rms, "n": int(self.current.size), "units": {"v_nom": "V", "r_s": "Ohm"}}


def fit_battery(current, voltage, *, source: str = "battery") -> BatteryFit:
    """Least-squares fit of V = V_nom − i R_s (seed 003, Eq. 9; Scout II: 37.17 V, 0.13 Ω).

    Parameters
    ----------
    current : (n,) [A]
        Total load current i (must vary).
    voltage : (n,) [V]
        Terminal voltage.
    """
    i = _arr(current, "current", source)
    v = _arr(voltage, "voltage", source, n=i.size, allow_constant=True)
    line = stiffness_rms(i, v, source=source)
    res = v - (line.intercept + line.slope * i)
    return BatteryFit(line.intercept, -line.slope, line.intercept_se, line.slope_se, line.rms, res, i, v)


def plot_battery(fit: BatteryFit, path):
    """Save the battery data with the fitted line and the residuals against current (Agg backend)."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    fig, (a1, a2) = plt.subplots(2, 1, figsize=(6, 6), sharex=True)
    a1.plot(fit.current, fit.voltage, ".", ms=3, label="measured")
    ii = np.array([fit.current.min(), fit.current.max()])
    a1.plot(ii, fit.v_nom - ii * fit.r_s, "k-", label=f"V = {fit.v_nom:.4g} V − i · {fit.r_s:.4g} Ω")
    a1.set_ylabel("voltage [V]")
    a1.legend(fontsize=8)
    a2.plot(fit.current, fit.residuals, ".", ms=3)
    a2.axhline(0.0, color="k", lw=0.8)
    a2.set_xlabel("current [A]")
    a2.set_ylabel("residual [V]")
    for a in (a1, a2):
        a.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path
