"""Classical identification of spring-damper and friction coefficients (seed 000, Sec. 4.1).

Two closed-form methods from the HyQ-leg paper (seed 000) live here:

* **Stiffness** — slope of the RMS line of the force–stroke curve (Eq. 4, F = k δ): the
  least-squares line F = k δ + F₀, with the standard errors of slope and intercept.
* **Damping from hysteresis loops** — the energy dissipated per cycle is the loop area
  ΔE = ∮ F dx = c π ω X² (Eq. 5), so c = ΔE / (π ω X²) per cycle, with ω = 2π / period and
  X = half the peak-to-peak stroke of that cycle (the excitation need not be a sinusoid). For a
  friction-dominated loop the same area gives the Coulomb level of a pure dry-friction loop,
  ΔE = 4 F_c X. A least-squares fit F = k x + c ẋ + F_c sign(ẋ) + F₀ gives a second, joint
  estimate.

Two more live in their own modules and are re-exported from here (same names as before):

* **Damping from a drop test** — impulse–momentum balance over the impact (seed 000,
  Eqs. 6–7): :mod:`proleg.identify.drop` (:func:`drop_damping`, :class:`DropResult`).
* **Battery** — V = V_nom − i R_s by least squares (seed 003, Eq. 9):
  :mod:`proleg.identify.battery` (:func:`fit_battery`, :func:`plot_battery`,
  :class:`BatteryFit`).

The shared pieces (``G0``, the input check ``_arr``, :func:`stiffness_rms`) stay here; the two
modules import them from here, so this module imports them back only at its end.

All inputs are SI: stroke [m], force [N], time [s], mass [kg], current [A], voltage [V].
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from ..errors import DataError
from .data import check_signal, split_runs
from .stats import Interval, mean_interval, repetitions_table

__all__ = [
    "BatteryFit", "Cycle", "DropResult", "HysteresisResult", "LineFit",
    "coulomb_fit", "detect_cycles", "drop_damping", "fit_battery", "identify_hysteresis",
    "loop_energy", "loops_table", "plot_battery", "plot_hysteresis", "stiffness_rms",
]

G0 = 9.80665  # standard gravity [m/s²]


def _arr(x, name: str, source: str, *, allow_constant=False, n=None) -> np.ndarray:
    """Validated 1-D float array (rows in messages are 1-based sample numbers)."""
    a = check_signal(np.asarray(x), source=source, column=name, allow_constant=allow_constant)
    if n is not None and a.size != n:
        raise DataError(f"{source}: '{name}' has {a.size} samples but the other signals have {n}.")
    return a


# --------------------------------------------------------------------------- stiffness (Eq. 4)
@dataclass(frozen=True)
class LineFit:
    """Least-squares line y = slope · x + intercept.

    Attributes
    ----------
    slope, intercept : float
        [unit y / unit x], [unit y]; for force–stroke data the stiffness k [N/m] and F₀ [N].
    slope_se, intercept_se : float
        Standard errors from the residual variance s² = RSS / (n − 2).
    rms : float
        RMS residual [unit y].
    n : int
        Number of points.
    """

    slope: float
    intercept: float
    slope_se: float
    intercept_se: float
    rms: float
    n: int


def stiffness_rms(stroke, force, *, source: str = "stiffness_rms") -> LineFit:
    """Stiffness as the slope of the RMS (least-squares) line through force–stroke data (seed 000, Eq. 4).

    Parameters
    ----------
    stroke : (n,) [m]
        Stroke (displacement) δ.
    force : (n,) [N]
        Force F.

    Returns
    -------
    LineFit
        ``slope`` = k [N/m], ``intercept`` = F₀ [N] (preload), with standard errors.

    Notes
    -----
    Over whole cycles of a linear spring-damper, F = k x + c ẋ, sampled uniformly, Σ (x − x̄) ẋ
    vanishes and the least-squares slope is exactly k: the damping tilts nothing, it only opens
    the loop. Over partial cycles it does not.
    """
    x = _arr(stroke, "stroke", source)
    f = _arr(force, "force", source, allow_constant=True, n=x.size)
    n = x.size
    if n < 3:
        raise DataError(f"{source}: {n} points; the RMS line needs at least 3.")
    xm, fm = x.mean(), f.mean()
    dx = x - xm
    sxx = float(dx @ dx)
    slope = float(dx @ (f - fm)) / sxx
    intercept = fm - slope * xm
    res = f - (slope * x + intercept)
    s2 = float(res @ res) / (n - 2)
    return LineFit(slope, float(intercept), float(np.sqrt(s2 / sxx)),
                   float(np.sqrt(s2 * (1.0 / n + xm * xm / sxx))), float(np.sqrt(np.mean(res * res))), n)


# --------------------------------------------------------------------------- cycles and loops
@dataclass(frozen=True)
class Cycle:
    """One full cycle of a periodic stroke: turning point ``start`` -> ``turn`` -> ``stop``.

    Sample indices into the record; ``start`` and ``stop`` are turning points of the same kind
    (both minima or both maxima). ``t_start``, ``t_stop`` [s] are the turning times (the middle of
    a plateau of equal samples), used for the period.
    """

    start: int
    turn: int
    stop: int
    t_start: float
    t_stop: float


def _plateau_time(t, x, i) -> float:
    """Time of the extremum at sample i: the middle of the run of equal samples around it.

    A quantised stroke (an encoder) holds its extreme value over several samples; the turning
    point is in the middle of that plateau, not at its first sample.
    """
    v = x[i]
    a = i
    while a > 0 and x[a - 1] == v:
        a -= 1
    b = i
    while b < x.size - 1 and x[b + 1] == v:
        b += 1
    return float(0.5 * (t[a] + t[b]))


def _turning_points(x: np.ndarray, gate: float) -> list[int]:
    """Alternating extrema of x whose reversals exceed ``gate`` (peak-valley filter).

    The running extreme is recorded as a turning point once the signal has come back from it by
    more than ``gate``; noise smaller than the gate never makes a turning point. The first and the
    last entries are the record's edge extremes (candidates, checked by the caller).
    """
    tps: list[int] = []
    i_hi = i_lo = 0
    d = 0
    ie = 0
    for i in range(1, x.size):
        xi = x[i]
        if d == 0:
            if xi > x[i_hi]:
                i_hi = i
            if xi < x[i_lo]:
                i_lo = i
            if x[i_hi] - x[i_lo] > gate:
                if i_hi > i_lo:
                    tps.append(i_lo)
                    d, ie = 1, i_hi
                else:
                    tps.append(i_hi)
                    d, ie = -1, i_lo
        elif d > 0:
            if xi > x[ie]:
                ie = i
            elif x[ie] - xi > gate:
                tps.append(ie)
                d, ie = -1, i
        else:
            if xi < x[ie]:
                ie = i
            elif xi - x[ie] > gate:
                tps.append(ie)
                d, ie = 1, i
    if d != 0:
        tps.append(ie)
    return tps


def detect_cycles(t, stroke, *, hysteresis: float = 0.2, min_fraction: float = 0.9,
                  source: str = "detect_cycles") -> list[Cycle]:
    """Find the full cycles of a periodic stroke record (sinusoid, triangle, irregular).

    Turning points are found by a peak-valley filter with a gate of ``hysteresis`` times the
    stroke range (1st to 99th percentile): a maximum counts once the stroke has come down from it
    by more than the gate, and likewise for a minimum, so noise smaller than the gate makes no
    extra cycles. One cycle runs from a turning point to the next one of the same kind. The
    first and last turning points are the record's edge extremes; each is kept only if its stroke
    to the neighbouring turning point is at least ``min_fraction`` of the median stroke, so a
    record that starts mid-stroke does not give a short cycle, while one that starts at rest at an
    end of the stroke does.

    Parameters
    ----------
    t : (n,) [s]
        Strictly increasing time stamps.
    stroke : (n,) [m]
    hysteresis : float
        Gate as a fraction of the stroke range; default 0.2.
    min_fraction : float
        See above; default 0.9.

    Returns
    -------
    list of Cycle
        Consecutive, non-overlapping cycles (the phase — min-to-min or max-to-max — that gives
        more cycles). The turning times are sample times (middle of a plateau of equal samples):
        the period of a cycle is exact when its turning points fall on samples, and otherwise
        within one sample interval. On a noisy stroke the sample extreme wanders over the flat top
        of the wave, so single periods scatter (by ±5 % for noise of 5 % of the amplitude on a
        sinusoid); the mean period over cycles does not, since consecutive periods share their
        turning points.
    """
    t = _arr(t, "time", source, allow_constant=True)
    x = _arr(stroke, "stroke", source, n=t.size)
    lo, hi = np.percentile(x, [1.0, 99.0])
    if not hi > lo:
        raise DataError(f"{source}: the stroke does not move (1st-99th percentile range is 0).")
    tps = _turning_points(x, hysteresis * (hi - lo))
    if len(tps) < 3:
        return []
    strokes = np.abs(np.diff(x[tps]))
    ref = float(np.median(strokes[1:-1])) if strokes.size > 2 else float(strokes.max())
    if strokes[-1] < min_fraction * ref:
        tps = tps[:-1]
    if strokes[0] < min_fraction * ref:
        tps = tps[1:]
    ncyc = [(len(tps) - 1 - p) // 2 for p in (0, 1)]
    p = 0 if ncyc[0] >= ncyc[1] else 1
    return [Cycle(tps[j], tps[j + 1], tps[j + 2], _plateau_time(t, x, tps[j]), _plateau_time(t, x, tps[j + 2]))
            for j in range(p, len(tps) - 2, 2)]


def loop_energy(stroke, force) -> float:
    """Area of the closed force–stroke loop, ΔE = ∮ F dx [J] (trapezoid = shoelace formula).

    Positive when the loop is traversed so that the element dissipates energy (force in the
    direction of motion larger than against it). The polygon is closed from the last point back
    to the first. For N samples per cycle of an ellipse the polygon underestimates the area by a
    relative (2π/N)²/6 (6.6e-6 at N = 1000).
    """
    x = np.asarray(stroke, dtype=float)
    f = np.asarray(force, dtype=float)
    e = 0.5 * np.sum((f[1:] + f[:-1]) * np.diff(x))
    return float(e + 0.5 * (f[0] + f[-1]) * (x[0] - x[-1]))


def _loop_row(t, x, f, cyc: Cycle) -> dict:
    i0, i2 = cyc.start, cyc.stop
    xs, fs = x[i0:i2 + 1], f[i0:i2 + 1]
    energy = loop_energy(xs, fs)
    period = cyc.t_stop - cyc.t_start
    omega = 2.0 * np.pi / period
    amp = 0.5 * (xs.max() - xs.min())
    line = stiffness_rms(x[i0:i2], f[i0:i2])
    return {"t_start": t[i0], "t_stop": t[i2], "period": period, "omega": omega, "amplitude": amp,
            "energy": energy, "k": line.slope, "intercept": line.intercept,
            "c": energy / (np.pi * omega * amp * amp), "friction": energy / (4.0 * amp)}


def loops_table(t, stroke, force, *, hysteresis: float = 0.2, min_fraction: float = 0.9,
                source: str = "loops_table") -> pd.DataFrame:
    """Per-cycle identification of one run: one row per detected loop.

    Columns: ``start``, ``stop`` (sample indices), ``t_start``, ``t_stop`` [s], ``period`` [s],
    ``omega`` [rad/s], ``amplitude`` X [m], ``energy`` ΔE [J], ``k`` (RMS slope of the loop,
    Eq. 4) [N/m], ``intercept`` [N], ``c`` = ΔE / (π ω X²) (Eq. 5) [N·s/m], ``friction`` =
    ΔE / (4 X) [N] (Coulomb level of a pure dry-friction loop of the same area).
    """
    t = _arr(t, "time", source, allow_constant=True)
    x = _arr(stroke, "stroke", source, n=t.size)
    f = _arr(force, "force", source, n=t.size, allow_constant=True)
    cycles = detect_cycles(t, x, hysteresis=hysteresis, min_fraction=min_fraction, source=source)
    rows = []
    for cyc in cycles:
        r = {"start": cyc.start, "stop": cyc.stop}
        r.update(_loop_row(t, x, f, cyc))
        rows.append(r)
    cols = ["start", "stop", "t_start", "t_stop", "period", "omega", "amplitude", "energy", "k",
            "intercept", "c", "friction"]
    return pd.DataFrame(rows, columns=cols)


def _velocity(t, x, window: int) -> np.ndarray:
    """Stroke rate [m/s] by a local quadratic (Savitzky–Golay) derivative over ``window`` samples."""
    from scipy.signal import savgol_filter

    window = max(5, window | 1)
    if window > x.size:
        return np.gradient(x, t)
    dt = float(np.median(np.diff(t)))
    # savgol assumes uniform spacing: differentiate against the sample index, then divide by dt/di
    dxdi = savgol_filter(x, window, 2, deriv=1)
    dtdi = np.gradient(t)
    return dxdi / np.where(dtdi > 0, dtdi, dt)


def coulomb_fit(t, stroke, force, *, viscous: bool = False, window: int | None = None, vmin: float = 0.05,
                source: str = "coulomb_fit") -> dict[str, float]:
    """Least-squares fit F = k x + F_c sign(ẋ) + F₀ (+ c ẋ with ``viscous=True``) over a record.

    ẋ is a Savitzky–Golay derivative (quadratic, ``window`` samples, default about 2 % of the
    record, at least 5). Samples slower than ``vmin`` × the 95th-percentile speed are left out,
    because sign(ẋ) is undefined at the turning points.

    Returns
    -------
    dict
        ``k`` [N/m], ``c`` [N·s/m] (0 unless ``viscous``), ``friction`` F_c [N], ``offset`` F₀ [N],
        ``rms`` residual [N].

    Notes
    -----
    The viscous term is off by default. When the speed is nearly the same on every stroke (a
    triangle-wave drive, as in the O-ring friction files) the columns ẋ and sign(ẋ) are almost
    parallel and c and F_c trade off freely: on the 1 bar file the four-parameter fit splits a
    5.4 N friction level into about 1 N of Coulomb friction and 400 N·s/m of viscous damping,
    with loop-to-loop scatter of 100 %. Fit the viscous term only when the record holds several
    speeds.
    """
    t = _arr(t, "time", source, allow_constant=True)
    x = _arr(stroke, "stroke", source, n=t.size)
    f = _arr(force, "force", source, n=t.size, allow_constant=True)
    if window is None:
        window = max(5, int(0.02 * x.size))
    v = _velocity(t, x, window)
    speed = np.abs(v)
    keep = speed > vmin * np.percentile(speed, 95)
    if keep.sum() < 8:
        raise DataError(f"{source}: too few moving samples ({int(keep.sum())}) for the friction fit.")
    cols = [x, np.sign(v), np.ones_like(x)] + ([v] if viscous else [])
    a = np.column_stack(cols)[keep]
    coef, *_ = np.linalg.lstsq(a, f[keep], rcond=None)
    res = f[keep] - a @ coef
    return {"k": float(coef[0]), "c": float(coef[3]) if viscous else 0.0, "friction": float(coef[1]),
            "offset": float(coef[2]), "rms": float(np.sqrt(np.mean(res * res)))}


@dataclass
class HysteresisResult:
    """Identification from hysteresis loops, with statistics over repetitions.

    Attributes
    ----------
    loops : DataFrame
        One row per loop (see :func:`loops_table`) plus ``run`` and ``repetition``.
    repetitions : DataFrame
        One row per repetition: ``k`` [N/m] (RMS slope, Eq. 4), ``c`` [N·s/m] (Eq. 5, mean over
        its loops), ``friction`` [N] (ΔE/4X, mean over its loops), ``k_fit``, ``friction_fit``
        (least-squares fit F = k x + F_c sign(ẋ) + F₀, :func:`coulomb_fit`), ``loops``.
    table : DataFrame
        :func:`~proleg.identify.stats.repetitions_table` of the repetition columns.
    repetition : str
        ``"run"`` when the record holds several runs (each run is one repetition), ``"loop"``
        when it holds one run (each loop is one repetition).
    line : LineFit
        RMS line through all loop samples (for the figure).
    """

    loops: pd.DataFrame
    repetitions: pd.DataFrame
    table: pd.DataFrame
    repetition: str
    nruns: int
    line: LineFit
    confidence: float
    source: str = ""
    _x: np.ndarray = field(default=None, repr=False)
    _f: np.ndarray = field(default=None, repr=False)

    def interval(self, name: str) -> Interval:
        return mean_interval(self.repetitions[name].to_numpy(), self.confidence, name=name)

    @property
    def k(self) -> float:
        return float(self.table.loc["k", "mean"])

    @property
    def c(self) -> float:
        return float(self.table.loc["c", "mean"])

    @property
    def friction(self) -> float:
        return float(self.table.loc["friction", "mean"])

    def to_dict(self) -> dict:
        """JSON-ready summary.

        Keys: ``k`` [N/m], ``c`` [N·s/m], ``friction`` [N] (loop area), ``friction_fit`` [N] (least
        squares), each with ``<name>_ci`` (2-list, interval of the mean); ``cycles`` (loops used),
        ``runs`` (repetitions the intervals are formed over), ``runs_in_file`` (runs found by the
        run column or the clock), ``repetition`` ("loop" or "run"), ``confidence``, ``table``.
        """
        tb = self.table

        def ci(q):
            return [float(tb.loc[q, "ci_low"]), float(tb.loc[q, "ci_high"])]

        out = {"k": self.k, "k_ci": ci("k"), "c": self.c, "c_ci": ci("c"),
               "friction": self.friction, "friction_ci": ci("friction"),
               "friction_fit": float(tb.loc["friction_fit", "mean"]), "friction_fit_ci": ci("friction_fit"),
               "cycles": int(len(self.loops)), "runs": int(len(self.repetitions)),
               "runs_in_file": int(self.nruns), "repetition": self.repetition,
               "confidence": self.confidence,
               "units": {"k": "N/m", "c": "N s/m", "friction": "N"}}
        out["table"] = {q: {c: (v.item() if hasattr(v, "item") else v) for c, v in row.items()}
                        for q, row in tb.iterrows()}
        return out


def identify_hysteresis(t, stroke, force, *, run=None, confidence: float = 0.95, hysteresis: float = 0.2,
                        min_fraction: float = 0.9, gap_factor: float = 50.0, source: str = "data",
                        stroke_name: str = "stroke") -> HysteresisResult:
    """Stiffness, equivalent viscous damping and Coulomb friction from periodic force–stroke records.

    Parameters
    ----------
    t : (n,) [s]
        Time stamps (strictly increasing inside each run).
    stroke : (n,) [m]
    force : (n,) [N]
        Force applied to the element in the direction of the stroke.
    run : (n,) int, optional
        Run number per sample (e.g. ``Record.run``); default: split by time restarts/gaps
        (:func:`~proleg.identify.data.split_runs`).
    confidence : float
        Level of the Student-t intervals over repetitions; default 0.95.

    Returns
    -------
    HysteresisResult

    Raises
    ------
    DataError
        Fewer than two repetitions (loops or runs) to form an interval; a loop with negative
        energy (reversed force sign); a non-finite estimate.
    """
    t = _arr(t, "time", source, allow_constant=True)
    x = _arr(stroke, stroke_name, source, n=t.size)
    f = _arr(force, "force", source, n=t.size, allow_constant=True)
    labels = (split_runs(t, source=source, gap_factor=gap_factor) if run is None
              else np.asarray(run, dtype=int))
    runs = np.unique(labels)
    loops, reps = [], []
    mask = np.zeros(t.size, bool)
    for r in runs:
        idx = np.flatnonzero(labels == r)
        tr, xr, fr = t[idx], x[idx], f[idx]
        if np.ptp(xr) == 0:
            raise DataError(f"{source}: column '{stroke_name}' is constant in run {r + 1}.")
        lt = loops_table(tr, xr, fr, hysteresis=hysteresis, min_fraction=min_fraction, source=source)
        if lt.empty:
            continue
        lt.insert(0, "run", int(r))
        loops.append(lt)
        a, b = int(lt["start"].iloc[0]), int(lt["stop"].iloc[-1])
        mask[idx[a:b + 1]] = True
        if len(runs) > 1:
            line = stiffness_rms(xr[a:b], fr[a:b])
            fit = coulomb_fit(tr[a:b + 1], xr[a:b + 1], fr[a:b + 1], source=source)
            reps.append({"run": int(r), "k": line.slope, "c": lt["c"].mean(), "friction": lt["friction"].mean(),
                         "k_fit": fit["k"], "friction_fit": fit["friction"],
                         "loops": len(lt)})
        else:
            for _, row in lt.iterrows():
                s0, s1 = int(row["start"]), int(row["stop"])
                fit = coulomb_fit(tr[s0:s1 + 1], xr[s0:s1 + 1], fr[s0:s1 + 1], source=source)
                reps.append({"run": int(r), "k": row["k"], "c": row["c"], "friction": row["friction"],
                             "k_fit": fit["k"], "friction_fit": fit["friction"],
                             "loops": 1})
    nloops = sum(len(lt) for lt in loops)
    if len(reps) < 2:
        raise DataError(f"{source}: column '{stroke_name}' gives {nloops} complete cycle(s) in "
                        f"{len(runs)} run(s); at least 2 repetitions (2 cycles, or 2 runs) are needed "
                        "to form an interval. Record more cycles.")
    loop_df = pd.concat(loops, ignore_index=True)
    if (loop_df["energy"] <= 0).all():
        raise DataError(f"{source}: every loop has negative area (energy generated, not dissipated): "
                        "the force sign is reversed relative to the stroke. Give the force that acts on "
                        "the element in the direction of positive stroke (negate the column).")
    rep_df = pd.DataFrame(reps)
    rep_df.insert(0, "repetition", np.arange(1, len(rep_df) + 1))
    qty = ["k", "c", "friction", "k_fit", "friction_fit"]
    bad = ~np.isfinite(rep_df[qty].to_numpy())
    if bad.any():
        i, j = np.argwhere(bad)[0]
        raise DataError(f"{source}: repetition {i + 1} gives a non-finite {qty[j]}; check the record.")
    table = repetitions_table(rep_df[qty], confidence,
                              units={"k": "N/m", "c": "N s/m", "friction": "N", "k_fit": "N/m",
                                     "friction_fit": "N"})
    line = stiffness_rms(x[mask], f[mask], source=source)
    return HysteresisResult(loop_df, rep_df, table, "run" if len(runs) > 1 else "loop", len(runs),
                            line, confidence, source, x[mask], f[mask])


def plot_hysteresis(result: HysteresisResult, path, *, title: str | None = None):
    """Save a figure of the loops (force over stroke, stroke in mm) and the RMS line (Eq. 4).

    Returns the path written. Uses the Agg backend (no display needed).
    """
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 5))
    x, f = result._x, result._f
    ax.plot(x * 1e3, f, lw=0.6, color="tab:blue", label=f"loops ({len(result.loops)})")
    xs = np.array([x.min(), x.max()])
    ax.plot(xs * 1e3, result.line.slope * xs + result.line.intercept, "k-.", lw=1.5,
            label=f"RMS line, slope {result.line.slope:.4g} N/m")
    ax.set_xlabel("stroke [mm]")
    ax.set_ylabel("force [N]")
    ax.set_title(title or (f"k = {result.k:.4g} N/m, c = {result.c:.4g} N s/m, "
                           f"F_c = {result.friction:.4g} N"), fontsize=9)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


# --------------------------------------------------------------------------- moved names
# The drop test and the battery model live in drop.py and battery.py, which import G0, _arr and
# stiffness_rms from here; their names stay reachable from this module lazily (PEP 562), so no
# import order matters.
_MOVED = {"DropResult": "drop", "drop_damping": "drop", "BatteryFit": "battery", "fit_battery": "battery", "plot_battery": "battery"}


def __getattr__(name: str):
    if name in _MOVED:
        import importlib

        return getattr(importlib.import_module(f".{_MOVED[name]}", __package__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
