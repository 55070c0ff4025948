"""Validation: time alignment, error metrics, gait metrics (seed 003 Fig. 16)."""

import numpy as np
import pandas as pd
import pytest

from proleg.errors import DataError
from proleg.validate import compare, compare_gait, error_metrics, estimate_shift, gait_metrics, plot_overlay


def test_shift_recovered_to_a_fraction_of_a_sample():
    # a smooth transient; the measurement is the simulation delayed by 37.3 ms (not a sample multiple)
    def sig(t):
        return np.exp(-((t - 1.0) / 0.15) ** 2) + 0.5 * np.sin(2 * np.pi * 1.3 * t) * np.exp(-t)

    ts = np.arange(0, 3, 0.002)
    te = np.arange(0.01, 3, 0.005)
    tau = 0.0373
    got = estimate_shift(te, sig(te - tau), ts, sig(ts))
    assert got == pytest.approx(tau, abs=2e-4)  # grid spacing 2 ms, parabolic refinement: 0.1 sample


def test_compare_metrics_closed_form(tmp_path):
    t = np.linspace(0, 2, 2001)
    exp = pd.DataFrame({"time": t, "force": 100 * np.sin(2 * np.pi * t)})
    sim = pd.DataFrame({"time": t, "f_sim": 100 * np.sin(2 * np.pi * t) + 3.0})
    cmp_ = compare(sim, exp, {"f_sim": "force"}, align=False)
    m = cmp_.metrics.loc["force"]
    assert m["rms"] == pytest.approx(3.0, rel=1e-12)
    assert m["max_abs"] == pytest.approx(3.0, rel=1e-12)
    assert m["nrms"] == pytest.approx(3.0 / 200.0, rel=1e-9)  # range of the measurement: 200 N
    assert m["r"] == pytest.approx(1.0, abs=1e-12)
    assert cmp_.shift == 0.0
    # a delayed simulation is realigned before the metrics
    sim2 = pd.DataFrame({"time": t, "f_sim": 100 * np.sin(2 * np.pi * (t + 0.05))})
    c2 = compare(sim2, exp, {"f_sim": "force"}, max_shift=0.3)
    assert c2.shift == pytest.approx(0.05, abs=1e-4)
    assert c2.metrics.loc["force", "nrms"] < 1e-3
    out = plot_overlay(c2, tmp_path / "overlay.png", units={"force": "N"})
    assert out.stat().st_size > 1000
    em = error_metrics([1.0, 2.0, 3.0], [1.0, 2.0, 3.0])
    assert em["rms"] == 0.0 and em["r"] == pytest.approx(1.0)


def test_compare_errors_name_the_column():
    t = np.linspace(0, 1, 11)
    exp = pd.DataFrame({"time": t, "a": t})
    sim = pd.DataFrame({"time": t, "b": t})
    with pytest.raises(DataError, match="'zz'"):
        compare(sim, exp, {"b": "zz"})
    bad = exp.copy()
    bad.loc[3, "a"] = np.nan
    with pytest.raises(DataError, match="'a'.*data row 4"):
        compare(sim, bad, {"b": "a"})


def gait_record(T=0.4, beta_b=0.35, beta_f=0.30, phase_f=0.5, strides=6, dt=1e-3):
    """Bounding pattern with stride period T and duty factors β_b, β_f; back lift-off at t = k T + β_b T.

    Event times are multiples of dt, so the metrics are exact up to round-off.
    """
    t = np.arange(0, strides * T + dt / 2, dt)
    ph = (t / T) % 1.0
    ph = np.round(ph / (dt / T)) * (dt / T) % 1.0  # phases on the sample grid
    back = ph < beta_b - 1e-9
    front = ((ph - phase_f) % 1.0) < beta_f - 1e-9
    pitch = 0.2 * np.sin(2 * np.pi * t / T)
    height = 0.32 + 0.02 * np.cos(2 * np.pi * t / T)
    return t, pitch, height, back, front


def test_gait_metrics_exact():
    T, bb, bf = 0.4, 0.35, 0.30
    g = gait_metrics(*gait_record(T, bb, bf))
    assert len(g) == 5  # six strides of stance/flight hold five lift-off-to-lift-off strides
    np.testing.assert_allclose(g["period"], T, rtol=1e-9)
    np.testing.assert_allclose(g["frequency"], 1 / T, rtol=1e-9)
    np.testing.assert_allclose(g["duty_back"], bb, rtol=1e-9)
    np.testing.assert_allclose(g["duty_front"], bf, rtol=1e-9)
    np.testing.assert_allclose(g["pitch_max"], 0.2, rtol=1e-9)  # sin reaches ±1 on samples (T/4 = 100 dt)
    np.testing.assert_allclose(g["pitch_min"], -0.2, rtol=1e-9)
    np.testing.assert_allclose(g["height_max"], 0.34, rtol=1e-9)
    np.testing.assert_allclose(g["height_min"], 0.30, rtol=1e-9)


def test_gait_metrics_off_grid_within_one_sample():
    # events off the sample grid: each is detected at the next sample, so times are within dt
    T, bb, bf, dt = 0.4173, 0.3512, 0.2987, 1e-3
    t = np.arange(0, 6 * T, dt)
    ph = (t / T) % 1.0
    g = gait_metrics(t, np.sin(t), np.cos(t) + 2, ph < bb, ((ph - 0.5) % 1.0) < bf)
    assert np.all(np.abs(g["period"] - T) <= dt)
    assert np.all(np.abs(g["duty_back"] - bb) <= 2 * dt / T)
    assert np.all(np.abs(g["duty_front"] - bf) <= 2 * dt / T)


def test_compare_gait_percent_errors():
    exp = gait_metrics(*gait_record(0.4, 0.35, 0.30))
    sim = gait_metrics(*gait_record(0.5, 0.42, 0.30))  # frequency 2.0 vs 2.5 Hz: -20 %; β_b +20 %
    e = compare_gait(sim, exp)
    assert e.loc["frequency", "mean_error_pct"] == pytest.approx(20.0, rel=1e-9)
    assert e.loc["duty_back", "max_error_pct"] == pytest.approx(20.0, rel=1e-9)
    assert e.loc["duty_front", "mean_error_pct"] == pytest.approx(0.0, abs=1e-9)
    e2 = compare_gait(sim, exp, pairing="index")
    assert e2.loc["frequency", "strides"] == 5
    with pytest.raises(DataError, match="lift-off"):
        t, p, h, b, f = gait_record()
        gait_metrics(t[:100], p[:100], h[:100], b[:100], f[:100])
