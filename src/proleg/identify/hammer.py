"""Experimental modal analysis from an impact-hammer test (seed 001 Problem 3, Table 2), on the
field's libraries.

Pipeline of :func:`modal` (and :func:`modal_from_frf` for FRFs measured elsewhere, e.g. a UFF file):

1. **Hits** (own code: pyFRF takes blocks, it does not find them): the records are split at the
   hammer hits (force above ``hit_threshold`` x peak), one block per hit, all of equal length from
   ``pre_trigger`` before the hit.
2. **FRFs by pyFRF** (:class:`pyFRF.FRF`): H1 (default), H2 or Hv, averaged over the hits, with
   the coherence. Windows: a force window (the force is kept from the block start to
   ``force_window`` s after the hit, zero after: the hammer's signal is there, the rest of the
   block is only noise), and an exponential window on the responses that falls to
   ``exp_window_end`` at the block end (leakage of slowly decaying modes, noise at the block
   end). The exponential window adds the decay rate sigma_w = -ln(exp_window_end) / T_block to
   every pole; it is subtracted from the identified poles (own code: pyEMA does not know the
   window).
3. **Poles by pyEMA's LSCF** (polyMAX; :meth:`sdypy.EMA.Model.get_poles`), for model orders
   2, 4, ... 2 ``max_order``, on the accelerances inside ``f_range``.
4. **Stabilisation diagram and automatic picking** (own code: pyEMA's stabilisation chart is
   interactive or needs the frequencies given; it has no MAC criterion). A pole of order n is
   stable when a pole of order n-2 lies within ``stability[0]`` in frequency, ``stability[1]`` in
   damping and has a MAC above ``stability[2]`` with it; the MAC uses the residues that pyEMA's
   LSFD gives at each order. Fully stable poles are clustered in frequency (single linkage, a
   cluster holding two poles of one order is split in two: close modes); a cluster is a mode when
   its poles are stable over at least ``min_stable`` of the orders. ``f_guess`` (a pre-test FE
   analysis) is the tie-breaker: clusters within +-``band`` of a guess need half the stability;
   a guess that no picked mode lies within 3 % of may take a cluster of poles stable in
   frequency and damping only (not MAC) within +-``band``, if stable over that many orders (a
   weak mode next to strong ones); with ``n_modes`` the modes nearest a guess rank first among
   equally stable ones. A range wider than a decade is analysed in log-spaced sub-bands
   (:func:`proleg.identify.ema.modal_from_frf`).
5. **Mode shapes by pyEMA's LSFD** (:func:`sdypy.EMA.EMA.LSFD`) with the picked poles, lower and
   upper residuals; the complex residues are rotated to real and max-abs normalised.

Everything is a fixed number of linear solves (no iteration to convergence): a pathological
record ends in bounded time, a noise-only record with no stable pole gives no mode and says so
in ``message``.

Synthetic data: :func:`synthetic_hammer_test` (modal superposition with known damping, exact
zero-order-hold discretisation per mode, plus noise). MAC and the Table 2-style comparison:
:mod:`proleg.identify.correlation`.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np

from ..errors import DataError
from .correlation import auto_mac as auto_mac
from .correlation import comparison_table as comparison_table
from .correlation import mac as mac
from .ema import ModalIdentification as ModalIdentification
from .ema import StabilisationDiagram as StabilisationDiagram
from .ema import _need
from .ema import modal_from_frf as modal_from_frf

ESTIMATORS = ("H1", "H2", "Hv")


def _check(time, force, acc, source="arrays"):
    t = np.asarray(time, float).ravel()
    F = np.asarray(force, float).ravel()
    A = np.asarray(acc, float)
    A = A[:, None] if A.ndim == 1 else A
    if t.size < 16:
        raise DataError(f"{source}: column 'time' has {t.size} samples; a hammer record needs many more.")
    if F.size != t.size:
        raise DataError(f"{source}: column 'force' has {F.size} samples but 'time' has {t.size}; "
                        "the channels must have the same length.")
    if A.ndim != 2 or A.shape[0] != t.size:
        raise DataError(f"{source}: the acceleration channels have {A.shape[0]} samples but 'time' has {t.size}; "
                        "the channels must have the same length.")
    for name, v in (("time", t), ("force", F), ("accelerations", A)):
        if not np.all(np.isfinite(v)):
            raise DataError(f"{source}: column '{name}' has NaN or inf values; remove or fill them.")
    dt = np.diff(t)
    if np.any(dt <= 0) or np.ptp(dt) > 1e-3 * np.median(dt):
        i = int(np.argmax(np.abs(dt - np.median(dt))))
        raise DataError(f"{source}: column 'time' is not regularly sampled (step {dt[i]:.6g} s at row {i + 2} vs "
                        f"median {np.median(dt):.6g} s); resample to a constant rate before the FRF estimate.")
    if not np.any(F != 0):
        raise DataError(f"{source}: column 'force' is zero everywhere; a hammer record needs at least one hit.")
    return t, F, A, float(np.median(dt))


def split_hits(time, force, accelerations, *, hit_threshold: float = 0.1, pre_trigger: float = 0.01,
               source: str = "arrays"):
    """Blocks of equal length, one per hammer hit, from ``pre_trigger`` [s] before each hit.

    Returns exc (n_hits, n), resp (n_hits, n_ch, n), dt [s] and the index (in a block) where the
    longest hit's force falls back below the threshold."""
    t, F, A, dt = _check(time, force, accelerations, source)
    above = np.abs(F) > hit_threshold * np.abs(F).max()
    starts = np.flatnonzero(above & ~np.r_[False, above[:-1]])
    min_gap = max(int(0.05 / dt), 4)
    hits = [s for i, s in enumerate(starts) if i == 0 or s - starts[i - 1] > min_gap]
    pre = int(round(pre_trigger / dt))
    begins = [max(h - pre, 0) for h in hits]
    ends = begins[1:] + [t.size]
    n = min(e - b for b, e in zip(begins, ends, strict=True))
    if n < 16:
        raise DataError(f"{source}: the hammer hits are too close together for an FRF block ({n} samples between "
                        "two hits); hit once per block, after the response has died out.")
    exc = np.stack([F[b:b + n] for b in begins])
    resp = np.stack([A[b:b + n].T for b in begins])
    pulse_end = 0
    for e in exc:
        ab = np.abs(e) > hit_threshold * np.abs(F).max()
        idx = np.flatnonzero(ab)
        if idx.size:  # end of the first contiguous run above the threshold
            run_end = idx[0] + int(np.argmax(np.diff(np.r_[idx, idx[-1] + 2]) > 1))
            pulse_end = max(pulse_end, int(run_end) + 1)
    return exc, resp, dt, pulse_end


@dataclass
class FRFEstimate:
    """FRFs from :func:`frf_estimate`: ``freq`` (nf,) [Hz], ``frf`` (nf, n_ch) accelerance
    [(m/s^2)/N], ``coherence`` (nf, n_ch), ``n_averages``, ``decay_rate`` [1/s] added by the
    exponential window (subtract it from the poles), ``estimator``."""

    freq: np.ndarray
    frf: np.ndarray
    coherence: np.ndarray
    n_averages: int
    decay_rate: float
    estimator: str


def frf_estimate(time, force, accelerations, *, estimator: str = "H1", force_window: float | None = None,
                 exp_window_end: float = 0.1, hit_threshold: float = 0.1, pre_trigger: float = 0.01,
                 source: str = "arrays") -> FRFEstimate:
    """Accelerances and coherence averaged over the hammer hits, by pyFRF.

    Parameters
    ----------
    estimator : "H1" (noise on the response), "H2" (noise on the force) or "Hv"
    force_window : [s] after the end of the hit where the force window closes (default: 5 times
        the hit's duration, at least 5 samples); None uses the default, 0 switches it off
    exp_window_end : [-] value of the exponential response window at the block end (1: none).
        Choosing values: 0.1 adds -ln(0.1)/T_block to every pole's decay rate (0.07 1/s for a 32 s
        block, 0.2 % damping at 2 Hz), removed again from the poles; lower values suppress more
        noise and leakage but blur close modes.
    """
    pyFRF = _need("pyFRF", "pyfrf")
    if estimator not in ESTIMATORS:
        raise DataError(f"{source}: FRF estimator {estimator!r} is not one of {ESTIMATORS}; H1 suits response noise "
                        "(the usual hammer test), H2 force noise.")
    if not (0 < exp_window_end <= 1):
        raise DataError(f"{source}: exp_window_end = {exp_window_end!r} must be in (0, 1]; 1 means no window.")
    exc, resp, dt, pulse_end = split_hits(time, force, accelerations, hit_threshold=hit_threshold,
                                          pre_trigger=pre_trigger, source=source)
    nh, n = exc.shape
    pulse_start = int(round(pre_trigger / dt))
    if force_window is None:
        close = pulse_end + max(5 * (pulse_end - pulse_start), 5)
    elif force_window <= 0:
        close = n
    else:
        close = pulse_end + int(round(force_window / dt))
    close = min(close, n)
    fs = 1.0 / dt
    wins = (f"force:{close / n + 0.5 / n:.12g}" if close < n else "none",
            f"exponential:{exp_window_end:.12g}" if exp_window_end < 1 else "none")
    with warnings.catch_warnings(), np.errstate(all="ignore"):
        warnings.simplefilter("ignore")
        fr = pyFRF.FRF(max(int(round(fs)), 1), exc[:, None, :], resp, exc_type="f", resp_type="a", window=wins,
                       frf_estimator=estimator)
        H = fr.get_FRF(frf_form="accelerance")[:, 0, :].T
        coh = np.real(fr.get_coherence()).T
    H = np.nan_to_num(H)
    H[0] = 0.0  # DC: undefined for accelerance data
    coh = np.clip(np.nan_to_num(coh), 0.0, 1.0)
    freq = np.fft.rfftfreq(n, dt)
    decay = -math.log(exp_window_end) / ((n - 1) * dt) if exp_window_end < 1 else 0.0
    return FRFEstimate(freq, H, coh, nh, decay, estimator)


def h1_estimate(time, force, accelerations, *, hit_threshold: float = 0.1, pre_trigger: float = 0.01,
                source: str = "arrays"):
    """H1 FRF [(m/s^2)/N] and coherence averaged over the hammer hits, without windows (pyFRF).

    Returns freq (nf,) [Hz], H (nf, n_ch), coherence (nf, n_ch), number of hits."""
    r = frf_estimate(time, force, accelerations, force_window=0, exp_window_end=1.0, hit_threshold=hit_threshold,
                     pre_trigger=pre_trigger, source=source)
    return r.freq, r.frf, r.coherence, r.n_averages


def modal(time, force, accelerations, *, n_modes: int | None = None, f_range=None, prominence: float | None = None,
          group_ratio: float | None = None, band: float = 0.2, hit_threshold: float = 0.1,
          f_guess=None, source: str = "arrays", estimator: str = "H1", force_window: float | None = None,
          exp_window_end: float = 0.1, max_order: int | None = None, stability=(0.01, 0.05, 0.98),
          min_stable: float = 0.15) -> ModalIdentification:
    """Natural frequencies [Hz], damping ratios and mode shapes from hammer-test records: FRFs by
    pyFRF, poles by pyEMA's LSCF with a stabilisation diagram, shapes by LSFD (module docstring).

    Parameters
    ----------
    time : (n,) [s]                 regularly sampled
    force : (n,) [N]                hammer force, one or several hits (averaged)
    accelerations : (n,) or (n, n_ch) [m/s^2]
    n_modes : int, optional         keep at most the ``n_modes`` most stable modes
    f_range : (f_lo, f_hi) [Hz]     band searched for modes (default 0.5 Hz .. 0.8 Nyquist)
    band : [-]                      a cluster within +-band (relative) of an ``f_guess`` needs half
                                    the stability of one that no analysis predicted
    f_guess : (m,) [Hz], optional   expected frequencies (pre-test FE analysis): the tie-breaker
    estimator, force_window, exp_window_end : see :func:`frf_estimate`
    max_order : int, optional       LSCF orders 2 .. 2 max_order (default from the number of lines
                                    in the band, 15..60)
    stability : (df, dzeta, MAC)    stabilisation criteria: relative frequency and damping change
                                    between orders, least MAC (PolyMAX's usual 1 %, 5 %, 0.98)
    min_stable : [-]                a mode's poles must be fully stable in this share of the orders
    prominence, group_ratio :       parameters of the former peak-picking method; ignored (LSCF
                                    fits the whole band); passing them warns
    """
    if prominence is not None or group_ratio is not None:
        warnings.warn("modal: 'prominence' and 'group_ratio' belonged to the former peak-picking method and have no "
                      "effect; the modes are picked from the LSCF stabilisation diagram (see 'stability', "
                      "'min_stable').", UserWarning, stacklevel=2)
    est = frf_estimate(time, force, accelerations, estimator=estimator, force_window=force_window,
                       exp_window_end=exp_window_end, hit_threshold=hit_threshold, source=source)
    return modal_from_frf(est.freq, est.frf, f_range=f_range, n_modes=n_modes, f_guess=f_guess, band=band,
                          max_order=max_order, stability=stability, min_stable=min_stable,
                          coherence=est.coherence, n_averages=est.n_averages, decay_rate=est.decay_rate,
                          estimator=estimator, source=source)


def synthetic_hammer_test(frequencies, damping, shapes_out, shape_in, *, fs: float = 1024.0, block: float = 16.0,
                          n_hits: int = 5, pulse: float = 0.002, peak_force: float = 200.0,
                          noise_force: float = 1e-4, noise_acc: float = 1e-4, seed: int = 0):
    """Hammer-test records from a modal model (mass-normalised modes).

    Parameters
    ----------
    frequencies : (m,) [Hz]; damping : (m,) [-]
    shapes_out : (n_ch, m)  mode-shape values at the accelerometers (mass-normalised)
    shape_in : (m,)         mode-shape values at the hammer point
    fs [Hz], block [s] per hit, n_hits, pulse [s] half-sine duration, peak_force [N] (each hit
    scaled by a random factor in [0.7, 1.3]); noise_force, noise_acc: Gaussian noise std as a
    fraction of the peak force / of the largest acceleration.

    Returns time (n,) [s], force (n,) [N], accelerations (n, n_ch) [m/s^2]. The response of each
    mode q'' + 2 zeta w q' + w^2 q = phi_in F is discretised exactly for a zero-order-hold force.
    """
    from scipy.signal import cont2discrete, lfilter

    rng = np.random.default_rng(seed)
    nb = int(round(block * fs))
    n = nb * n_hits
    t = np.arange(n) / fs
    F = np.zeros(n)
    npulse = max(int(round(pulse * fs)), 2)
    for k in range(n_hits):
        s = k * nb + int(0.02 * fs)
        F[s:s + npulse] += peak_force * rng.uniform(0.7, 1.3) * np.sin(np.pi * (np.arange(npulse) + 0.5) / npulse)
    Y = np.zeros((n, np.asarray(shapes_out).shape[0]))
    for fr, z, po, pi in zip(frequencies, damping, np.asarray(shapes_out).T, shape_in, strict=True):
        w = 2 * np.pi * fr
        A = np.array([[0.0, 1.0], [-(w**2), -2 * z * w]])
        B = np.array([[0.0], [1.0]])
        C = np.array([[-(w**2), -2 * z * w]])
        D = np.array([[1.0]])
        Ad, Bd, Cd, Dd, _ = cont2discrete((A, B, C, D), 1 / fs, "zoh")
        # state-space recursion via lfilter on the equivalent transfer function
        from scipy.signal import ss2tf

        num, den = ss2tf(Ad, Bd, Cd, Dd)
        qdd = lfilter(num[0], den, F * pi)
        Y += qdd[:, None] * np.asarray(po)[None, :]
    Fn = F + noise_force * peak_force * rng.standard_normal(n)
    Yn = Y + noise_acc * np.abs(Y).max() * rng.standard_normal(Y.shape)
    return t, Fn, Yn
