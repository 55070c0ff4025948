"""Modes from measured FRFs: pyEMA's LSCF poles over a range of model orders, an automatic
stabilisation-diagram picking (own code: pyEMA's chart is interactive or needs the frequencies
given, and has no MAC criterion), and pyEMA's LSFD mode shapes. :func:`proleg.identify.modal`
builds the FRFs from hammer records (pyFRF) and calls :func:`modal_from_frf`; a UFF file's FRFs
go to :func:`modal_from_frf` directly. The method is described in :mod:`proleg.identify.hammer`.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from ..errors import DataError
from .correlation import auto_mac, mac


def _need(module, package):
    """Import an optional EMA library, or say how to install it."""
    import importlib

    try:
        return importlib.import_module(module)
    except ImportError as e:
        raise ImportError(f"proleg.identify's hammer-test analysis needs {package} ({e}); install the EMA extra: "
                          "pip install 'proleg[ema]'.") from e



@dataclass
class StabilisationDiagram:
    """Poles of every model order: ``order`` (n,), ``frequency`` [Hz] (n,), ``damping`` [-] (n,),
    ``status`` (n,) 0 new, 1 stable in frequency, 2 and in damping, 3 and in MAC (fully stable);
    ``cluster`` (n,) the picked mode a pole belongs to (-1 none); ``freq`` [Hz] and ``frf_sum``
    (sum of |H_j| over the channels) for the background curve."""

    order: np.ndarray
    frequency: np.ndarray
    damping: np.ndarray
    status: np.ndarray
    cluster: np.ndarray
    freq: np.ndarray
    frf_sum: np.ndarray
    criteria: tuple = (0.01, 0.05, 0.98)

    def table(self) -> pd.DataFrame:
        return pd.DataFrame({"order": self.order, "frequency [Hz]": self.frequency, "damping [-]": self.damping,
                             "status": self.status, "mode": self.cluster + 1})


@dataclass
class ModalIdentification:
    """Result of :func:`modal`: frequencies [Hz], damping ratios [-], mode shapes (n_channels,
    n_modes) (real, max-abs normalised), the FRF ``frf`` (n_freq, n_channels) [(m/s^2)/N] at
    ``freq`` [Hz], ``coherence`` (n_freq, n_channels), ``n_averages`` and the half-power
    estimates; ``complex_shapes`` the LSFD residues (n_channels, n_modes), ``stabilisation`` the
    diagram the modes were picked from, ``message`` what the picking found (why no mode, say)."""

    frequencies: np.ndarray
    damping: np.ndarray
    shapes: np.ndarray
    freq: np.ndarray
    frf: np.ndarray
    coherence: np.ndarray
    n_averages: int
    half_power_damping: np.ndarray
    complex_shapes: np.ndarray = field(default_factory=lambda: np.zeros((0, 0), complex))
    stabilisation: StabilisationDiagram | None = None
    message: str = ""
    estimator: str = "H1"

    def table(self) -> pd.DataFrame:
        return pd.DataFrame({"mode": np.arange(1, self.frequencies.size + 1), "frequency [Hz]": self.frequencies,
                             "damping [-]": self.damping, "half-power damping [-]": self.half_power_damping})

    def auto_mac(self) -> np.ndarray:
        """Auto-MAC of the identified (complex) shapes."""
        return auto_mac(self.complex_shapes)

    def plot_stabilisation(self, ax=None, f_range=None):
        """Stabilisation diagram: the poles of each model order (o new, + stable in frequency,
        x and in damping, filled: fully stable, coloured when picked) over the FRF sum."""
        import matplotlib.pyplot as plt

        s = self.stabilisation
        if s is None:
            raise DataError("plot_stabilisation: this result has no stabilisation diagram (made without LSCF).")
        fig = None
        if ax is None:
            fig, ax = plt.subplots(figsize=(9, 4.5))
        lo, hi = f_range if f_range is not None else (s.freq[0], s.freq[-1])
        m = (s.freq >= lo) & (s.freq <= hi)
        ax2 = ax.twinx()
        ax2.semilogy(s.freq[m], s.frf_sum[m], color="0.6", lw=0.8)
        ax2.set_ylabel("sum |H| [(m/s²)/N]")
        marks = {0: ("o", "none", "0.7", "new"), 1: ("+", None, "C1", "stable f"), 2: ("x", None, "C2", "stable f, ζ"),
                 3: ("o", None, "C0", "stable f, ζ, MAC")}
        for k, (mk, fc, c, lab) in marks.items():
            sel = (s.status == k) & (s.frequency >= lo) & (s.frequency <= hi)
            if fc == "none":
                ax.scatter(s.frequency[sel], s.order[sel], s=8, marker=mk, facecolors="none", edgecolors=c, lw=0.5,
                           label=lab)
            else:
                ax.scatter(s.frequency[sel], s.order[sel], s=10, marker=mk, color=c, lw=0.7, label=lab)
        picked = s.cluster >= 0
        ax.scatter(s.frequency[picked], s.order[picked], s=14, color="C3", label="picked mode")
        for f in self.frequencies:
            ax.axvline(f, color="C3", lw=0.5, ls="--")
        ax.set_xlim(lo, hi)
        ax.set_xlabel("frequency [Hz]")
        ax.set_ylabel("model order")
        ax.set_zorder(ax2.get_zorder() + 1)
        ax.patch.set_visible(False)
        ax.legend(fontsize=7, loc="upper left", framealpha=0.8)
        ax.set_title(f"stabilisation diagram (LSCF): {self.frequencies.size} modes; criteria df < "
                     f"{100 * s.criteria[0]:g} %, dζ < {100 * s.criteria[1]:g} %, MAC > {s.criteria[2]:g}", fontsize=9)
        if fig is not None:
            fig.tight_layout()
        return fig if fig is not None else ax.figure


def _half_power(f, ind, k):
    half = ind[k] / 2
    i = k
    while i > 0 and ind[i] > half:
        i -= 1
    j = k
    while j < ind.size - 1 and ind[j] > half:
        j += 1
    if i == 0 or j == ind.size - 1 or ind[i + 1] == ind[i] or ind[j] == ind[j - 1]:
        return float("nan")
    fl = f[i] + (half - ind[i]) * (f[i + 1] - f[i]) / (ind[i + 1] - ind[i])
    fr = f[j - 1] + (half - ind[j - 1]) * (f[j] - f[j - 1]) / (ind[j] - ind[j - 1])
    return max((fr - fl) / (2 * f[k]), 1e-5)


def _f_zeta(p):
    w = np.abs(p)
    return w / (2 * np.pi), -p.real / np.where(w > 0, w, 1.0)


def _pole(f, z):
    w = 2 * np.pi * f
    return -z * w + 1j * w * np.sqrt(np.clip(1 - z * z, 0, None))


def _lsfd(poles, freq, H):
    """pyEMA's LSFD on the accelerances H (nf, n_ch): complex residues (n_ch, n_poles)."""
    from sdypy.EMA.EMA import LSFD

    with warnings.catch_warnings(), np.errstate(all="ignore"):
        warnings.simplefilter("ignore")
        A, Hr, _, _ = LSFD(np.asarray(poles, complex), H.T, freq, True, True, 0, freq.size, "accelerance")
    return A, Hr.T


def _split_cluster(idx, order, freq_p):
    """Split a frequency cluster that holds k > 1 poles in most of its orders into k clusters
    (close modes): centres from the rank-wise medians of the orders with exactly k poles."""
    orders, counts = np.unique(order[idx], return_counts=True)
    k = int(np.round(np.median(counts)))
    if k < 2:
        return [idx]
    full = [o for o, c in zip(orders, counts, strict=True) if c == k]
    ranks = np.array([np.sort(freq_p[idx][order[idx] == o]) for o in full])
    centres = np.median(ranks, axis=0)
    lab = np.argmin(np.abs(freq_p[idx][:, None] - centres[None, :]), axis=1)
    return [idx[lab == j] for j in range(k) if np.any(lab == j)]


def modal_from_frf(freq, frf, *, f_range=None, n_modes: int | None = None, f_guess=None, band: float = 0.2,
                   max_order: int | None = None, stability=(0.01, 0.05, 0.98), min_stable: float = 0.15,
                   zeta_max: float = 0.3, coherence=None, n_averages: int = 1, decay_rate: float = 0.0,
                   estimator: str = "H1", band_ratio: float = 10.0, source: str = "FRFs") -> ModalIdentification:
    """Modes from measured accelerances: LSCF poles and stabilisation (pyEMA), automatic picking,
    LSFD shapes (pyEMA). ``freq`` (nf,) [Hz] from 0 with a constant step, ``frf`` (nf, n_ch)
    [(m/s^2)/N]; the other parameters as in :func:`modal`.

    A range wider than ``band_ratio`` (f_hi / f_lo) is analysed in log-spaced sub-bands that
    overlap by 20 % (own code): LSCF maps 0..f_hi onto the unit circle, so a 2 Hz mode in a
    1..200 Hz fit spans a few lines of 6400 and its poles do not stabilise; each sub-band keeps
    the modes inside its core."""
    freq = np.asarray(freq, float).ravel()
    if freq.size < 16:
        raise DataError(f"{source}: the frequency axis has {freq.size} lines; an FRF needs many more.")
    lo, hi = f_range if f_range is not None else (max(freq[1], 0.5), 0.8 * freq[-1])
    lo, hi = max(float(lo), freq[1]), min(float(hi), freq[-1])
    f_range = (lo, hi)
    if max_order is not None and (int(max_order) != max_order or max_order < 2):
        raise DataError(f"{source}: max_order = {max_order!r} must be an integer >= 2.")
    kw = dict(n_modes=None, f_guess=f_guess, band=band, max_order=max_order, stability=stability,
              min_stable=min_stable, zeta_max=zeta_max, coherence=coherence, n_averages=n_averages,
              decay_rate=decay_rate, estimator=estimator, source=source)
    nb = max(1, math.ceil(math.log(max(hi / max(lo, 1e-9), 1.0)) / math.log(band_ratio))) if lo > 0 else 1
    if nb == 1:
        return _pick_n(_modal_band(freq, frf, f_range=f_range, **kw), n_modes, f_guess)
    edges = list(np.geomspace(lo, hi, nb + 1))
    df = freq[1] - freq[0]
    while len(edges) > 2 and (min(edges[1] * 1.2, hi) - edges[0]) / df < 64:  # too few lines: merge upwards
        del edges[1]
    edges = np.array(edges)
    nb = edges.size - 1
    if nb == 1:
        return _pick_n(_modal_band(freq, frf, f_range=f_range, **kw), n_modes, f_guess)
    parts = [_modal_band(freq, frf, f_range=(max(a / 1.2, lo), min(b * 1.2, hi)), **kw)
             for a, b in zip(edges[:-1], edges[1:], strict=True)]
    keep = [(p.frequencies >= a) & (p.frequencies < b if k < nb - 1 else p.frequencies <= b)
            for k, (p, a, b) in enumerate(zip(parts, edges[:-1], edges[1:], strict=True))]
    cat = lambda name: np.concatenate([getattr(p, name)[..., m] for p, m in zip(parts, keep, strict=True)], axis=-1)  # noqa: E731
    f_all = cat("frequencies")
    o = np.argsort(f_all)
    d = [p.stabilisation for p in parts]
    rank = np.empty(o.size, int)
    rank[o] = np.arange(o.size)
    clus, start = [], 0
    for di, m in zip(d, keep, strict=True):
        loc = np.full(m.size, -1)
        loc[m] = rank[start + np.arange(int(m.sum()))]
        start += int(m.sum())
        clus.append(np.where(di.cluster >= 0, loc[np.maximum(di.cluster, 0)] if m.size else -1, -1))
    diagram = StabilisationDiagram(np.concatenate([x.order for x in d]), np.concatenate([x.frequency for x in d]),
                                   np.concatenate([x.damping for x in d]), np.concatenate([x.status for x in d]),
                                   np.concatenate(clus), parts[-1].freq, parts[-1].stabilisation.frf_sum,
                                   tuple(stability))
    msg = "; ".join(f"{a:.3g}..{b:.3g} Hz: {int(m.sum())} of {p.message}" for p, a, b, m in
                    zip(parts, edges[:-1], edges[1:], keep, strict=True))
    if f_all.size == 0:
        msg = "no mode in any sub-band: " + msg
    r = ModalIdentification(f_all[o], cat("damping")[o], cat("shapes")[:, o], parts[0].freq, parts[0].frf,
                            parts[0].coherence, n_averages, cat("half_power_damping")[o], cat("complex_shapes")[:, o],
                            diagram, msg, estimator)
    return _pick_n(r, n_modes, f_guess)


def _pick_n(r, n_modes, f_guess=None):
    """Keep the ``n_modes`` modes whose clusters are stable over the most orders; among equally
    stable ones, those nearest a guess (``f_guess`` [Hz]) first."""
    if n_modes is None or r.frequencies.size <= n_modes:
        return r
    s = r.stabilisation
    score = np.array([np.unique(s.order[s.cluster == k]).size for k in range(r.frequencies.size)])
    g = np.atleast_1d(np.asarray(f_guess, float)) if f_guess is not None else np.zeros(0)
    dist = (np.min(np.abs(np.log(r.frequencies[:, None] / g[None, :])), axis=1) if g.size
            else np.zeros(r.frequencies.size))
    keep = np.sort(np.lexsort((dist, -score))[:n_modes])
    remap = np.full(r.frequencies.size + 1, -1)
    remap[keep] = np.arange(keep.size)
    s.cluster = np.where(s.cluster >= 0, remap[s.cluster], -1)
    return ModalIdentification(r.frequencies[keep], r.damping[keep], r.shapes[:, keep], r.freq, r.frf, r.coherence,
                               r.n_averages, r.half_power_damping[keep], r.complex_shapes[:, keep], s,
                               r.message + f"; the {n_modes} most stable kept", r.estimator)


def _modal_band(freq, frf, *, f_range, n_modes, f_guess, band, max_order, stability, min_stable, zeta_max,
                coherence, n_averages, decay_rate, estimator, source) -> ModalIdentification:
    Model = _need("sdypy.EMA", "pyema").Model

    freq = np.asarray(freq, float).ravel()
    H = np.asarray(frf, complex)
    H = H[:, None] if H.ndim == 1 else H
    if H.shape[0] != freq.size:
        raise DataError(f"{source}: the FRFs have {H.shape[0]} lines but the frequency axis {freq.size}.")
    if freq.size < 16 or np.ptp(np.diff(freq)) > 1e-6 * np.diff(freq).mean() or freq[0] < 0:
        raise DataError(f"{source}: the frequency axis must have >= 16 equally spaced lines from >= 0 Hz.")
    if not np.all(np.isfinite(H)):
        raise DataError(f"{source}: the FRFs have NaN or inf values.")
    df = freq[1] - freq[0]
    if freq[0] > 0:  # LSCF maps 0 .. f_max onto the unit circle: pad the missing low lines with zeros
        pad = np.arange(int(round(freq[0] / df))) * df
        freq, H = np.r_[pad, freq], np.r_[np.zeros((pad.size, H.shape[1])), H]
    lo, hi = f_range if f_range is not None else (max(freq[1], 0.5), 0.8 * freq[-1])
    lo, hi = max(float(lo), freq[1]), min(float(hi), freq[-1])
    if not hi > lo:
        raise DataError(f"{source}: f_range = {f_range!r} Hz lies outside the measured band "
                        f"{freq[1]:g}..{freq[-1]:g} Hz.")
    tol_f, tol_z, tol_mac = stability
    n_lines = int(np.sum((freq >= lo) & (freq <= hi)))
    if n_lines < 16:
        raise DataError(f"{source}: only {n_lines} frequency lines in {lo:g}..{hi:g} Hz (step {df:g} Hz); widen "
                        "f_range or record longer blocks (the line step is 1 / block length).")
    if max_order is None:  # enough for ~ one mode per 20 lines, capped: the cost grows as order^3
        max_order = int(np.clip(n_lines // 40, 15, 60))
    max_order = int(min(max_order, max(n_lines // 4, 2)))
    cut = int(np.searchsorted(freq, hi, side="right"))
    with warnings.catch_warnings(), np.errstate(all="ignore"):
        warnings.simplefilter("ignore")
        lscf = Model(frf=H[:cut + 1].T, freq=freq[:cut + 1], lower=lo, upper=freq[min(cut, freq.size - 1)],
                     pol_order_high=max_order, frf_form="accelerance")
        lscf.get_poles("lscf", show_progress=False)
    band_m = (freq >= lo) & (freq <= hi)
    fb, Hb = freq[band_m], H[band_m]
    step = max(1, math.ceil(fb.size / 1500))  # residues for the MAC criterion: every step-th line is enough
    fd, Hd = fb[::step], Hb[::step]
    # physical poles of each order, their LSFD residues, stability against the order below
    O, P, S, V = [], [], [], []
    prev = None
    for k, poles in enumerate(lscf.all_poles):
        p = np.asarray(poles)
        p = p[np.isfinite(p)]
        fp, zp = _f_zeta(p)
        keep = (p.imag > 0) & (fp > lo) & (fp < hi) & (zp > 0) & (zp < zeta_max)
        p = p[keep]
        fp, zp = fp[keep], zp[keep]
        if p.size:
            A, _ = _lsfd(p, fd, Hd)
        else:
            A = np.zeros((H.shape[1], 0), complex)
        st = np.zeros(p.size, int)
        if prev is not None and prev[0].size and p.size:
            pf, pz, pA = prev
            for i in range(p.size):
                rel = np.abs(pf / fp[i] - 1)
                j = int(np.argmin(rel))
                if rel[j] < tol_f:
                    st[i] = 1
                    if abs(zp[i] / pz[j] - 1) < tol_z:
                        st[i] = 2
                        if mac(A[:, i], pA[:, j])[0, 0] > tol_mac:
                            st[i] = 3
        O.append(np.full(p.size, 2 * (k + 1)))
        P.append(p)
        S.append(st)
        V.append(A)
        prev = (fp, zp, A)
    order, poles_all, status = np.concatenate(O), np.concatenate(P), np.concatenate(S)
    fpa, zpa = _f_zeta(poles_all)
    n_orders = len(lscf.all_poles)
    # cluster the fully stable poles
    idx = np.flatnonzero(status == 3)
    idx = idx[np.argsort(fpa[idx])]
    clusters = []
    if idx.size:
        breaks = np.flatnonzero(fpa[idx][1:] / fpa[idx][:-1] - 1 > tol_f) + 1
        for c in np.split(idx, breaks):
            clusters += _split_cluster(c, order, fpa)
    guesses = np.atleast_1d(np.asarray(f_guess, float)) if f_guess is not None else np.zeros(0)
    need = max(3, math.ceil(min_stable * n_orders))
    need_guess = max(3, math.ceil(0.5 * min_stable * n_orders))
    cand = []
    for c in clusters:
        n_st = np.unique(order[c]).size
        fc = float(np.median(fpa[c]))
        near = guesses.size > 0 and np.min(np.abs(guesses / fc - 1)) <= band
        if n_st >= (need_guess if near else need):
            top = c[order[c] >= np.median(order[c])]
            dist = float(np.min(np.abs(np.log(guesses / fc)))) if guesses.size else 0.0
            cand.append((n_st, -dist, float(np.median(fpa[top])), float(np.median(zpa[top])), c))
    # tie-breaker: a guessed mode that no fully stable cluster stands for may be taken from the
    # poles stable in frequency and damping (no MAC criterion) within +-band of the guess
    for g in guesses:
        if not (lo < g < hi) or any(abs(c[2] / g - 1) <= 0.03 for c in cand):
            continue
        taken = np.zeros(order.size, bool)
        for c in cand:
            taken[c[4]] = True
            taken |= np.abs(fpa / c[2] - 1) <= tol_f
        idx2 = np.flatnonzero((status >= 2) & (np.abs(fpa / g - 1) <= band) & ~taken)
        idx2 = idx2[np.argsort(fpa[idx2])]
        if not idx2.size:
            continue
        br = np.flatnonzero(fpa[idx2][1:] / fpa[idx2][:-1] - 1 > tol_f) + 1
        best = max(np.split(idx2, br), key=lambda c: np.unique(order[c]).size)
        n_st = np.unique(order[best]).size
        if n_st >= need_guess:
            top = best[order[best] >= np.median(order[best])]
            cand.append((n_st, -float(abs(math.log(np.median(fpa[best]) / g))), float(np.median(fpa[top])),
                         float(np.median(zpa[top])), best))
    if n_modes is not None and len(cand) > n_modes:
        cand = sorted(cand, key=lambda x: (x[0], x[1]), reverse=True)[:n_modes]
    cand.sort(key=lambda x: x[2])
    cluster_id = np.full(order.size, -1)
    for m_, c in enumerate(cand):
        cluster_id[c[4]] = m_
    frf_sum = np.sum(np.abs(H), axis=1)
    diagram = StabilisationDiagram(order, fpa, zpa, status, cluster_id, freq, frf_sum, tuple(stability))
    coh = np.ones_like(H, dtype=float) if coherence is None else np.asarray(coherence, float)
    if not cand:
        msg = (f"no mode: no cluster of poles stable in frequency ({100 * tol_f:g} %), damping ({100 * tol_z:g} %) "
               f"and MAC (> {tol_mac:g}) over >= {need} of the {n_orders} LSCF model orders in {lo:g}..{hi:g} Hz "
               f"({idx.size} fully stable poles in all); the record shows no structural mode (noise only?).")
        e = np.zeros(0)
        return ModalIdentification(e, e, np.zeros((H.shape[1], 0)), freq, H, coh, n_averages, e,
                                   np.zeros((H.shape[1], 0), complex), diagram, msg, estimator)
    fw = np.array([c[2] for c in cand])
    zw = np.array([c[3] for c in cand])
    pw = _pole(fw, zw)  # poles of the windowed FRFs: their residues
    A, _ = _lsfd(pw, fb, Hb)
    fr, zr = _f_zeta(pw + decay_rate)  # the exponential window's decay removed
    shapes = []
    for k in range(A.shape[1]):
        v = A[:, k] * np.exp(-1j * np.angle(A[np.argmax(np.abs(A[:, k])), k]))
        shapes.append(v.real / max(np.abs(v.real).max(), 1e-300))
    ind = np.sum(np.abs(H) ** 2 / np.maximum(np.max(np.abs(H[band_m]) ** 2, axis=0), 1e-300), axis=1)
    hp = np.array([_half_power(freq, ind, int(np.argmin(np.abs(freq - f)))) for f in fr])
    msg = (f"{fr.size} modes: clusters of poles stable over >= {need} of {n_orders} LSCF model orders "
           f"(max order {2 * n_orders}) in {lo:g}..{hi:g} Hz")
    return ModalIdentification(fr, zr, np.array(shapes).T, freq, H, coh, n_averages, hp, A, diagram, msg, estimator)
