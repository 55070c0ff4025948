"""Validation of simulations against experiments: aligned error metrics and gait metrics.

Two ways to compare, following the source papers:

* **Time series** (seed 000, Figs. 5–6): the simulation is shifted in time to best match the
  measurement (peak of the cross-correlation, :func:`estimate_shift`), resampled onto the
  measurement's time stamps (``np.interp``, no extrapolation) and compared signal by signal:
  RMS error, maximum absolute error, RMS normalised by the range of the measurement and the
  correlation coefficient (:func:`compare`).
* **Gait metrics** (seed 003, Fig. 16): where phase drift makes a sample-by-sample comparison
  meaningless, each stride is reduced to a few numbers — stride frequency, duty factors of the
  back and front legs, max/min body pitch and max/min COM height (:func:`gait_metrics`) — and the
  simulation is compared with the experiment by mean and maximum percentage errors over the
  strides (:func:`compare_gait`).

All inputs are SI (s, m, rad); errors carry the unit of the signal.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import pandas as pd

from .errors import DataError
from .identify.data import check_signal

__all__ = ["Comparison", "compare", "compare_gait", "error_metrics", "estimate_shift", "gait_metrics",
           "plot_overlay"]


def _time(t, name: str) -> np.ndarray:
    t = check_signal(np.asarray(t), source=name, column="time", allow_constant=True)
    d = np.diff(t)
    if t.size < 2 or np.any(d <= 0):
        i = int(np.flatnonzero(d <= 0)[0]) + 2 if t.size >= 2 else 1
        raise DataError(f"{name}: time must increase strictly (fails at sample {i}, 1-based) and have "
                        "at least 2 samples.")
    return t


def estimate_shift(t_exp, y_exp, t_sim, y_sim, *, max_shift: float | None = None, dt: float | None = None) -> float:
    """Time shift τ [s] such that the simulation delayed by τ, y_sim(t − τ), best matches y_exp(t).

    Both signals are resampled onto uniform grids of spacing ``dt`` (default: the smaller median
    sample interval) and cross-correlated; at each lag the correlation coefficient is taken over
    the overlapping samples only (so a finite record does not bias the peak towards zero lag), and
    lags where the overlap is less than half the shorter record are skipped. The lag of the
    largest coefficient within ± ``max_shift`` (default: a quarter of the shorter record) is
    refined by a parabola through the peak and its neighbours, so τ is resolved to a fraction of
    ``dt``.

    Parameters
    ----------
    t_exp, y_exp : (n,) [s], [any]
    t_sim, y_sim : (m,) [s], [same unit]

    Returns
    -------
    float
        τ [s]; add it to the simulation times to align them (``t_sim + τ``).
    """
    from scipy.signal import correlate, correlation_lags

    te, ts = _time(t_exp, "experiment"), _time(t_sim, "simulation")
    ye = check_signal(y_exp, source="experiment", column="signal")
    ys = check_signal(y_sim, source="simulation", column="signal")
    if dt is None:
        dt = float(min(np.median(np.diff(te)), np.median(np.diff(ts))))
    ge = np.arange(te[0], te[-1] + 0.5 * dt, dt)
    gs = np.arange(ts[0], ts[-1] + 0.5 * dt, dt)
    a = np.interp(ge, te, ye)
    b = np.interp(gs, ts, ys)
    a, b = a - a.mean(), b - b.mean()
    # Pearson correlation over the overlap of each lag (sums over the overlap by correlating with ones),
    # so that the changing overlap does not pull the peak towards zero lag
    ia, ib = np.ones_like(a), np.ones_like(b)
    cnt = np.rint(correlate(ia, ib, mode="full"))
    sa, sb = correlate(a, ib, mode="full"), correlate(ia, b, mode="full")
    saa, sbb = correlate(a * a, ib, mode="full"), correlate(ia, b * b, mode="full")
    sab = correlate(a, b, mode="full")
    with np.errstate(invalid="ignore", divide="ignore"):
        cov = sab - sa * sb / cnt
        var = (saa - sa * sa / cnt) * (sbb - sb * sb / cnt)
        cc = np.where(var > 0, cov / np.sqrt(np.abs(var)), -np.inf)
    lags = correlation_lags(a.size, b.size, mode="full")
    tau = ge[0] - gs[0] + lags * dt
    if max_shift is None:
        max_shift = 0.25 * min(te[-1] - te[0], ts[-1] - ts[0])
    ok = (np.abs(tau) <= max_shift + 1e-12) & (cnt >= 0.5 * min(a.size, b.size))
    if not ok.any():
        raise DataError("estimate_shift: no lag within max_shift; the records do not overlap in time.")
    cc = np.where(ok, cc, -np.inf)
    i = int(np.argmax(cc))
    frac = 0.0
    if 0 < i < cc.size - 1 and np.isfinite(cc[i - 1]) and np.isfinite(cc[i + 1]):
        den = cc[i - 1] - 2.0 * cc[i] + cc[i + 1]
        if den < 0:
            frac = 0.5 * (cc[i - 1] - cc[i + 1]) / den
    return float(tau[i] + frac * dt)


def error_metrics(y_exp, y_sim) -> dict[str, float]:
    """Error metrics of a simulated signal against a measured one on common samples.

    Returns
    -------
    dict
        ``rms`` = √mean((sim − exp)²), ``max_abs`` = max |sim − exp| (both in the signal's unit),
        ``nrms`` = rms / (max(exp) − min(exp)) (dimensionless; inf for a constant measurement),
        ``r`` = Pearson correlation coefficient (NaN-free: 0 when either signal is constant),
        ``n`` = number of samples.
    """
    e = np.asarray(y_exp, dtype=float)
    s = np.asarray(y_sim, dtype=float)
    if e.size < 2:
        raise DataError(f"error_metrics: {e.size} common samples; the records barely overlap in time.")
    d = s - e
    rng = float(np.ptp(e))
    sd_e, sd_s = float(np.std(e)), float(np.std(s))
    r = float(np.mean((e - e.mean()) * (s - s.mean())) / (sd_e * sd_s)) if sd_e > 0 and sd_s > 0 else 0.0
    rms = float(np.sqrt(np.mean(d * d)))
    return {"rms": rms, "max_abs": float(np.max(np.abs(d))), "nrms": rms / rng if rng > 0 else float("inf"),
            "r": r, "n": int(e.size)}


@dataclass(frozen=True)
class Comparison:
    """Result of :func:`compare`.

    Attributes
    ----------
    metrics : DataFrame
        Index: signal (experiment column name); columns ``rms``, ``max_abs``, ``nrms``, ``r``, ``n``,
        ``sim`` (simulation column).
    shift : float [s]
        Time shift added to the simulation times.
    aligned : DataFrame
        ``time`` (experiment times inside the overlap) and, per pair, ``exp:<col>`` and ``sim:<col>``.
    """

    metrics: pd.DataFrame
    shift: float
    aligned: pd.DataFrame


def compare(sim: pd.DataFrame, exp: pd.DataFrame, mapping: Mapping[str, str], *, sim_time: str = "time",
            exp_time: str = "time", align: bool | str = True, shift: float | None = None,
            max_shift: float | None = None) -> Comparison:
    """Align a simulation with an experiment and compute error metrics per signal.

    Parameters
    ----------
    sim, exp : DataFrame
        Simulation and measurement, SI units, with time columns ``sim_time`` and ``exp_time`` [s].
    mapping : mapping simulation column -> experiment column
        The signals to compare.
    align : bool or str
        True: estimate the shift on the first pair; a simulation column name: estimate it on that
        pair; False: no shift.
    shift : float [s], optional
        Use this shift instead of estimating one.

    Returns
    -------
    Comparison
    """
    for frame, col, name in [(sim, sim_time, "simulation"), (exp, exp_time, "experiment")]:
        if col not in frame.columns:
            raise DataError(f"{name}: time column '{col}' not found; columns: {', '.join(map(str, frame.columns))}.")
    if not mapping:
        raise DataError("compare: empty mapping; give pairs sim_col=exp_col.")
    for s, e in mapping.items():
        if s not in sim.columns:
            raise DataError(f"simulation: column '{s}' not found; columns: {', '.join(map(str, sim.columns))}.")
        if e not in exp.columns:
            raise DataError(f"experiment: column '{e}' not found; columns: {', '.join(map(str, exp.columns))}.")
    ts = _time(sim[sim_time].to_numpy(), "simulation")
    te = _time(exp[exp_time].to_numpy(), "experiment")
    sig_s = {s: check_signal(sim[s], source="simulation", column=s, allow_constant=True) for s in mapping}
    sig_e = {e: check_signal(exp[e], source="experiment", column=e, allow_constant=True) for e in mapping.values()}
    if shift is None:
        if align is False:
            shift = 0.0
        else:
            key = next(iter(mapping)) if align is True else str(align)
            if key not in mapping:
                raise DataError(f"compare: align column '{key}' is not in the mapping.")
            shift = estimate_shift(te, sig_e[mapping[key]], ts, sig_s[key], max_shift=max_shift)
    tsh = ts + shift
    inside = (te >= tsh[0]) & (te <= tsh[-1])
    if inside.sum() < 2:
        raise DataError(f"compare: after a shift of {shift:.6g} s the records overlap in {int(inside.sum())} samples.")
    t = te[inside]
    aligned = {"time": t}
    rows = []
    for s, e in mapping.items():
        ye = sig_e[e][inside]
        ys = np.interp(t, tsh, sig_s[s])
        aligned[f"exp:{e}"] = ye
        aligned[f"sim:{s}"] = ys
        rows.append({"signal": e, "sim": s, **error_metrics(ye, ys)})
    return Comparison(pd.DataFrame(rows).set_index("signal"), float(shift), pd.DataFrame(aligned))


def plot_overlay(comparison: Comparison, path, *, units: Mapping[str, str] | None = None):
    """Save one panel per compared signal: measurement and aligned simulation over time (Agg)."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    units = dict(units or {})
    m = comparison.metrics
    fig, axes = plt.subplots(len(m), 1, figsize=(8, 2.4 * len(m) + 0.6), sharex=True, squeeze=False)
    a = comparison.aligned
    for ax, (sig, row) in zip(axes[:, 0], m.iterrows()):
        ax.plot(a["time"], a[f"exp:{sig}"], "k-", lw=1.0, label="experiment")
        ax.plot(a["time"], a[f"sim:{row['sim']}"], "r--", lw=1.0, label="simulation")
        u = units.get(sig, "")
        ax.set_ylabel(f"{sig}" + (f" [{u}]" if u else ""))
        ax.set_title(f"RMS {row['rms']:.3g}, NRMS {100 * row['nrms']:.2f} %, r = {row['r']:.3f}", fontsize=8)
        ax.grid(alpha=0.3)
    axes[0, 0].legend(fontsize=8)
    axes[-1, 0].set_xlabel(f"time [s] (simulation shifted by {comparison.shift:.4g} s)")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


# --------------------------------------------------------------------------- gait (seed 003, Fig. 16)
GAIT_METRICS = ("frequency", "duty_back", "duty_front", "pitch_max", "pitch_min", "height_max", "height_min")


def _contact(x, name: str, n: int) -> np.ndarray:
    a = np.asarray(x)
    if a.shape != (n,):
        raise DataError(f"gait_metrics: '{name}' has shape {a.shape}; expected ({n},) like the time.")
    if a.dtype != bool:
        vals = check_signal(a, source="gait_metrics", column=name, allow_constant=True)
        if not np.all((vals == 0) | (vals == 1)):
            i = int(np.flatnonzero((vals != 0) & (vals != 1))[0])
            raise DataError(f"gait_metrics: '{name}' must be a contact flag (bool or 0/1); sample {i + 1} "
                            f"(1-based) is {vals[i]}.")
        a = vals.astype(bool)
    return a


def gait_metrics(t, pitch, height, back_contact, front_contact) -> pd.DataFrame:
    """Per-stride gait metrics of a bounding run (seed 003, Fig. 16).

    A stride runs from one back-leg lift-off to the next (seed 003 defines steady strides by the
    back-leg lift-off event). Contact flags are sample-and-hold: a flag holds from its sample to
    the next, and an event happens at the first sample of the new state. Stance time is the
    time with the flag True inside the stride.

    Parameters
    ----------
    t : (n,) [s]
    pitch : (n,) [rad]
        Body pitch θ.
    height : (n,) [m]
        COM height y.
    back_contact, front_contact : (n,) bool
        Leg in contact with the ground.

    Returns
    -------
    DataFrame
        One row per complete stride: ``t_start`` [s], ``period`` [s], ``frequency`` [Hz],
        ``duty_back``, ``duty_front`` (stance time / stride period), ``pitch_max``, ``pitch_min``
        [rad], ``height_max``, ``height_min`` [m].

    Notes
    -----
    Exact (to round-off) when the contact events fall on samples; otherwise each event is late
    by less than one sample period, so period and stance times are within one sample period.
    """
    t = _time(t, "gait_metrics")
    n = t.size
    th = check_signal(pitch, source="gait_metrics", column="pitch", allow_constant=True)
    y = check_signal(height, source="gait_metrics", column="height", allow_constant=True)
    if th.size != n or y.size != n:
        raise DataError("gait_metrics: pitch and height must have as many samples as the time.")
    cb = _contact(back_contact, "back_contact", n)
    cf = _contact(front_contact, "front_contact", n)
    lo = np.flatnonzero(cb[:-1] & ~cb[1:]) + 1  # first flight sample after back stance
    if lo.size < 2:
        raise DataError(f"gait_metrics: {lo.size} back-leg lift-off(s) found; a stride needs two. "
                        "Record at least one full stride of bounding.")
    dt = np.diff(t)
    rows = []
    for a, b in zip(lo[:-1], lo[1:]):
        period = t[b] - t[a]
        seg = slice(a, b + 1)
        rows.append({
            "t_start": t[a], "period": period, "frequency": 1.0 / period,
            "duty_back": float(np.sum(cb[a:b] * dt[a:b]) / period),
            "duty_front": float(np.sum(cf[a:b] * dt[a:b]) / period),
            "pitch_max": float(th[seg].max()), "pitch_min": float(th[seg].min()),
            "height_max": float(y[seg].max()), "height_min": float(y[seg].min()),
        })
    return pd.DataFrame(rows)


def compare_gait(sim: pd.DataFrame, exp: pd.DataFrame, *, pairing: str = "mean",
                 metrics=GAIT_METRICS) -> pd.DataFrame:
    """Mean and maximum percentage errors of simulated against measured gait metrics (seed 003, Fig. 16).

    Parameters
    ----------
    sim, exp : DataFrame
        Outputs of :func:`gait_metrics`.
    pairing : {"mean", "index"}
        ``"mean"`` (default): each measured stride is compared with the mean simulated stride (phase
        drift between the two makes stride-by-stride pairing arbitrary; the simulation is usually a
        steady limit cycle). ``"index"``: stride k with stride k, over the shorter record.

    Returns
    -------
    DataFrame
        Index: metric. Columns ``sim_mean``, ``exp_mean``, ``mean_error_pct``, ``max_error_pct``
        (100 · |sim − exp| / |exp| averaged / maximised over strides), ``strides``.
    """
    if pairing not in ("mean", "index"):
        raise ValueError(f"pairing must be 'mean' or 'index', got {pairing!r}.")
    if len(sim) == 0 or len(exp) == 0:
        raise DataError("compare_gait: a record has no complete stride.")
    rows = []
    for m in metrics:
        for frame, name in [(sim, "simulation"), (exp, "experiment")]:
            if m not in frame.columns:
                raise DataError(f"compare_gait: {name} has no column '{m}'.")
        e = exp[m].to_numpy(dtype=float)
        s = sim[m].to_numpy(dtype=float)
        if pairing == "index":
            k = min(e.size, s.size)
            e, s = e[:k], s[:k]
        else:
            s = np.full_like(e, s.mean())
        if np.any(e == 0):
            raise DataError(f"compare_gait: measured '{m}' is 0 in stride {int(np.flatnonzero(e == 0)[0]) + 1}; "
                            "a percentage error is undefined (measure pitch/height from a non-zero reference).")
        pct = 100.0 * np.abs(s - e) / np.abs(e)
        rows.append({"metric": m, "sim_mean": float(sim[m].mean()), "exp_mean": float(exp[m].mean()),
                     "mean_error_pct": float(pct.mean()), "max_error_pct": float(pct.max()),
                     "strides": int(e.size)})
    return pd.DataFrame(rows).set_index("metric")
