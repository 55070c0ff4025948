"""Classical identification (seed 000 Eqs. 4-7, seed 003 Eq. 9) against closed forms."""

import numpy as np
import pandas as pd
import pytest

from proleg.errors import DataError
from proleg.identify import (
    coulomb_fit,
    detect_cycles,
    drop_damping,
    fit_battery,
    identify_hysteresis,
    load_record,
    loop_energy,
    loops_table,
    mean_interval,
    plot_battery,
    plot_hysteresis,
    stiffness_rms,
)

G = 9.80665


def sine_record(k, c, X, f, n_per, cycles, f0=0.0):
    """x = X sin(ωt), F = k x + c ẋ + F0, ``n_per`` samples per period, t in [0, cycles·T]."""
    w = 2 * np.pi * f
    t = np.arange(cycles * n_per + 1) / (n_per * f)
    x = X * np.sin(w * t)
    return t, x, k * x + c * X * w * np.cos(w * t) + f0


# ------------------------------------------------------------------ Eq. 4 and Eq. 5, exact data
def test_eq5_and_rms_slope_exact_sinusoid():
    k, c, X, f = 8.3e4, 4.5e5, 2e-3, 0.2
    t, x, F = sine_record(k, c, X, f, n_per=4096, cycles=5, f0=300.0)
    lt = loops_table(t, x, F)
    assert len(lt) == 4  # turning points from T/4 to 4.75 T: four full max-to-max cycles
    # the polygon (shoelace) area of N samples of an ellipse is πXY·(N/2π)·sin(2π/N): 3.9e-7 low at N = 4096
    np.testing.assert_allclose(lt["c"], c, rtol=1e-6)
    np.testing.assert_allclose(lt["omega"], 2 * np.pi * f, rtol=1e-12)
    np.testing.assert_allclose(lt["amplitude"], X, rtol=1e-12)
    # over whole periods Σ(x - x̄)ẋ = 0 exactly: the RMS slope is k to round-off
    np.testing.assert_allclose(lt["k"], k, rtol=1e-9)
    np.testing.assert_allclose(lt["intercept"], 300.0, rtol=1e-9)
    line = stiffness_rms(x[:-1], F[:-1])  # five whole periods, end point excluded (it repeats the first)
    assert abs(line.slope / k - 1) < 1e-9
    # its standard error counts the (orthogonal) damping force as scatter: rms residual = c ω X / √2
    assert line.rms == pytest.approx(c * 2 * np.pi * f * 2e-3 / np.sqrt(2), rel=1e-9)


def test_loop_area_is_the_inscribed_polygon():
    # closed form of the shoelace area on an ellipse sampled uniformly in phase: (N/2) X Y sin(2π/N)
    k, c, X, f, N = 1e3, 50.0, 0.01, 1.0, 64
    t, x, F = sine_record(k, c, X, f, n_per=N, cycles=3)
    lt = loops_table(t, x, F)
    exact = (N / (2 * np.pi)) * np.sin(2 * np.pi / N)
    np.testing.assert_allclose(lt["c"] / c, exact, rtol=1e-12)
    assert loop_energy(x[:N + 1], F[:N + 1]) == pytest.approx(np.pi * c * 2 * np.pi * f * X**2 * exact, rel=1e-12)


def test_irregular_excitation_per_cycle_omega_and_amplitude():
    # each cycle its own period and amplitude: x = X_j (1 - cos(2π(t - t_j)/T_j)), minima at 0
    k, c, dt = 2e4, 3e3, 1e-3
    periods, amps = [2.0, 1.6, 2.4, 1.2, 2.0], [1e-3, 0.8e-3, 1.2e-3, 0.9e-3, 1.1e-3]
    ts, xs, vs, t0 = [], [], [], 0.0
    for T, A in zip(periods, amps):
        n = int(round(T / dt))
        tau = np.arange(n) * dt
        ts.append(t0 + tau)
        xs.append(A * (1 - np.cos(2 * np.pi * tau / T)))
        vs.append(A * 2 * np.pi / T * np.sin(2 * np.pi * tau / T))
        t0 += T
    t = np.concatenate(ts + [[t0]])
    x = np.concatenate(xs + [[0.0]])
    v = np.concatenate(vs + [[0.0]])
    lt = loops_table(t, x, k * x + c * v)
    assert len(lt) == 5
    np.testing.assert_allclose(lt["period"], periods, rtol=1e-9)
    np.testing.assert_allclose(lt["amplitude"], amps, rtol=1e-12)
    np.testing.assert_allclose(lt["c"], c, rtol=2e-5)  # polygon error (2π/N)²/6 with N >= 1200


def test_cycle_detection_ignores_noise_and_partial_start():
    rng = np.random.default_rng(1)
    t = np.linspace(0, 10.3, 20001)  # starts mid-stroke (x = 0), ends mid-cycle
    x = np.sin(2 * np.pi * t) + 0.05 * rng.standard_normal(t.size)
    cyc = detect_cycles(t, x)
    # maxima at 0.25, 1.25, ..., 10.25 s (the last one is reached before the end): 10 max-to-max cycles;
    # the start at x = 0 is half a stroke from the first maximum and is not a turning point
    assert len(cyc) == 10
    assert cyc[0].start == np.argmin(np.abs(t - 0.25)) or abs(t[cyc[0].start] - 0.25) < 0.03
    periods = [c.t_stop - c.t_start for c in cyc]
    # a turning time is the noisy sample extreme, which wanders over the flat top (±0.3 rad where
    # 1 - cos θ is within 1σ of the peak): single periods scatter by a few %, their mean telescopes
    np.testing.assert_allclose(periods, 1.0, atol=0.06)
    assert np.mean(periods) == pytest.approx(1.0, abs=0.01)


# ------------------------------------------------------------------ round trip with seed-000 noise
def test_round_trip_table2_quasi_static_hip_low_gain():
    """Seed 000 Table 2, quasi-static, low gain, hip: k = 8.30e4 N/m, c = 4.50e5 N s/m.

    Synthetic test as in the paper: 0.2 Hz, ±2 mm stroke (leg pulled up and pushed down slowly), force
    of a few hundred N on top of a 300 N preload. Sensor noise of the seed: load cell 0-5 kN ±0.5 %,
    taken as σ = 25 N Gaussian (the whole band as one sigma, conservative); stroke from the hip
    encoder (0.0045° resolution) through the 0.045 m lever arm -> quantisation 3.5 µm.
    """
    rng = np.random.default_rng(2024)
    k, c = 8.30e4, 4.50e5
    t, x, F = sine_record(k, c, 2e-3, 0.2, n_per=5000, cycles=5, f0=300.0)
    q = 0.045 * np.deg2rad(0.0045)
    xq = np.round(x / q) * q
    Fn = F + 25.0 * rng.standard_normal(F.size)
    res = identify_hysteresis(t, xq, Fn)
    assert res.repetition == "loop" and len(res.repetitions) == 4
    print(f"\nround trip: k = {res.k:.5g} (true {k:.4g}), c = {res.c:.5g} (true {c:.4g})")
    assert abs(res.k / k - 1) < 0.02
    assert abs(res.c / c - 1) < 0.10
    lo, hi = res.table.loc["k", ["ci_low", "ci_high"]]
    assert lo < res.k < hi


def test_interval_coverage_monte_carlo():
    """400 noisy five-repetition stiffness experiments: the 95 % t-interval covers k 95 % ± 3 % of the time."""
    rng = np.random.default_rng(7)
    k_true, n_exp, n_rep, n = 8.3e4, 400, 5, 200
    x = 2e-3 * np.sin(np.linspace(0, 2 * np.pi, n, endpoint=False))
    covered = 0
    for _ in range(n_exp):
        ks = [stiffness_rms(x, k_true * x + 25.0 * rng.standard_normal(n)).slope for _ in range(n_rep)]
        iv = mean_interval(ks, 0.95)
        covered += iv.low <= k_true <= iv.high
    rate = covered / n_exp
    print(f"\ncoverage {rate:.3f}")
    assert abs(rate - 0.95) <= 0.03


# ------------------------------------------------------------------ friction
def test_coulomb_loop_area_and_fit():
    # triangle-wave stroke, force = pure Coulomb friction + spring + preload
    Fc, k, F0 = 5.4, 40.0, 49.0
    t = np.arange(0, 40.0, 0.01)
    phase = (t / 8.0) % 1.0
    x = 0.02 * (1 - 2 * np.abs(2 * phase - 1))  # -0.02..0.02 m, period 8 s
    v = np.gradient(x, t)
    F = F0 + k * x + Fc * np.sign(v)
    lt = loops_table(t, x, F)
    assert len(lt) == 5  # starts at a minimum and ends one sample short of one: both edges are kept
    # loop = parallelogram of height 2 F_c: area 4 F_c X, less the corners cut at each reversal, where the
    # sampled sign(ẋ) passes through 0 over one stroke step (0.1 mm of X = 20 mm: below 0.5 %)
    np.testing.assert_allclose(lt["friction"], Fc, rtol=5e-3)
    fit = coulomb_fit(t, x, F)
    assert fit["friction"] == pytest.approx(Fc, rel=1e-3)
    assert fit["k"] == pytest.approx(k, rel=1e-3)


# ------------------------------------------------------------------ drop test (Eqs. 6-7)
def drop_record(m=4.5, k=2e4, zeta=0.6, h=0.05, t0=0.05, T=1.0, dt=1e-4):
    """Mass m lands at v0 = sqrt(2 g h) on a spring-damper (k, c) at t0 and stays down (closed form).

    Compression x = x_s + e^{-ζωτ}(A cos ω_d τ + B sin ω_d τ), x_s = m g / k, x(0) = 0, ẋ(0) = v0;
    ground force F = k x + c ẋ (0 before touchdown; after a lift-off the body is in flight, F = 0).
    """
    w = np.sqrt(k / m)
    c = 2 * zeta * np.sqrt(k * m)
    wd = w * np.sqrt(1 - zeta**2)
    v0 = np.sqrt(2 * G * h)
    t = np.arange(0, T, dt)
    tau = t - t0
    A = -m * G / k
    B = (v0 + zeta * w * A) / wd
    e = np.exp(-zeta * w * tau)
    x = m * G / k + e * (A * np.cos(wd * tau) + B * np.sin(wd * tau))
    xd = e * ((-zeta * w * A + wd * B) * np.cos(wd * tau) + (-zeta * w * B - wd * A) * np.sin(wd * tau))
    F = np.where(tau >= -1e-12, k * x + c * xd, 0.0)
    neg = np.flatnonzero((tau > 0) & (F <= 0))
    if neg.size:
        F[neg[0]:] = 0.0
    return t, F, c, v0, x


def test_drop_momentum_balance_recovers_c():
    m, k = 4.5, 2e4
    t, F, c, v0, x = drop_record(m=m, k=k, zeta=0.6)
    assert F[t > 0.05].min() > 0  # the body stays on the ground, so Eq. 7 applies
    r = drop_damping(t, F, m)
    # Eq. 7 over touchdown..end (body at rest): v_i; trapezoid quadrature at dt = 0.1 ms
    assert r.v_impact == pytest.approx(v0, rel=1e-4)
    assert r.t_impact == pytest.approx(0.05, abs=1e-9)
    assert r.dl_max == pytest.approx(x.max(), rel=1e-4)
    # momentum-reconstructed least squares: c to 0.1 % (quadrature error of the double integration)
    assert r.c == pytest.approx(c, rel=1e-3)
    assert r.k == pytest.approx(k, rel=1e-3)
    # Eq. 6 as printed is an energy-equivalence estimate: c_eq6 = m v_i² ΔT / (2π² Δl_max²)
    assert r.c_eq6 == pytest.approx(m * r.v_impact**2 * r.duration / (2 * np.pi**2 * r.dl_max**2), rel=1e-12)
    print(f"\ndrop: c = {c:.4g}, momentum fit {r.c:.4g}, Eq. 6 as printed {r.c_eq6:.4g} (ΔT = {r.duration:.4g} s)")


def test_drop_with_lift_off_needs_the_impact_speed():
    t, F, c, v0, _ = drop_record(zeta=0.2)
    with pytest.raises(DataError, match="lift-off"):
        drop_damping(t, F, 4.5)
    r = drop_damping(t, F, 4.5, v_impact=v0)
    assert r.lift_off
    assert r.c == pytest.approx(c, rel=1e-3)


def test_drop_with_noise_and_measured_stroke():
    # force plate noise 2 N; 0.1 s before and 0.3 s after touchdown (the baseline error times the
    # window length biases the impulse of Eq. 7, so the record is kept short)
    rng = np.random.default_rng(3)
    t, F, c, v0, x = drop_record(zeta=0.6, t0=0.1, T=0.4)
    Fn = F + 2.0 * rng.standard_normal(F.size)
    r = drop_damping(t, Fn, 4.5)
    assert r.v_impact == pytest.approx(v0, rel=0.015)
    assert r.c == pytest.approx(c, rel=0.03)
    xs = np.where(t >= 0.1, x, 0.0)
    r2 = drop_damping(t, F, 4.5, stroke=-xs)  # any sign convention for the stroke
    assert r2.c == pytest.approx(c, rel=2e-3)


# ------------------------------------------------------------------ battery (seed 003 Eq. 9)
def test_battery_exact_and_standard_errors(tmp_path):
    rng = np.random.default_rng(5)
    i = rng.uniform(0, 20, 200)
    fit = fit_battery(i, 37.17 - 0.13 * i)
    # Exact data: round-off of a least-squares fit, eps × cond of the design matrix [1, i]
    # (23 here) × the 37 V scale, 1.2e-11 V; a wrong model leaves residuals of order volts.
    eps, cond = np.finfo(float).eps, np.linalg.cond(np.column_stack([np.ones_like(i), i]))
    tol_v = 64 * eps * cond * 37.17
    assert fit.v_nom == pytest.approx(37.17, abs=tol_v)
    assert fit.r_s == pytest.approx(0.13, rel=1e-12)
    assert fit.rms < tol_v and fit.r_s_se < tol_v
    # the standard error predicts the scatter of R_s over repeated noisy fits
    rs, se = [], []
    for _ in range(300):
        f = fit_battery(i, 37.17 - 0.13 * i + 0.05 * rng.standard_normal(i.size))
        rs.append(f.r_s)
        se.append(f.r_s_se)
    assert np.std(rs, ddof=1) == pytest.approx(np.mean(se), rel=0.15)
    p = plot_battery(fit, tmp_path / "battery.png")
    assert p.stat().st_size > 1000


def test_hysteresis_figure(tmp_path):
    t, x, F = sine_record(1e3, 20.0, 0.01, 1.0, n_per=200, cycles=4)
    res = identify_hysteresis(t, x, F)
    out = plot_hysteresis(res, tmp_path / "loops.png")
    assert out.stat().st_size > 1000


# ------------------------------------------------------------------ bad input
def _csv(tmp_path, frame, name="bad.csv"):
    p = tmp_path / name
    frame.to_csv(p, index=False)
    return p


def _good(n=400):
    t = np.arange(n) * 0.01
    x = 0.01 * np.sin(2 * np.pi * t)
    return pd.DataFrame({"time": t, "stroke": x, "force": 100 * x + np.cos(2 * np.pi * t)})


COLS = {"force": "force", "stroke": "stroke", "time": "time"}


def test_bad_missing_column(tmp_path):
    p = _csv(tmp_path, _good().drop(columns="force"))
    with pytest.raises(DataError, match=r"bad\.csv.*'force'.*Available columns"):
        load_record(p, COLS)


def test_bad_non_numeric(tmp_path):
    d = _good().astype(object)
    d.loc[4, "stroke"] = "n/a?"
    with pytest.raises(DataError, match=r"'stroke' is not numeric at data row 5 \(1-based"):
        load_record(_csv(tmp_path, d), COLS)


def test_bad_nan(tmp_path):
    d = _good()
    d.loc[9, "force"] = np.nan
    with pytest.raises(DataError, match=r"'force' is empty \(NaN\) at data row 10"):
        load_record(_csv(tmp_path, d), COLS)


def test_bad_unsorted_and_duplicate_time(tmp_path):
    d = _good()
    d.loc[[20, 21], "time"] = d.loc[[21, 20], "time"].to_numpy()
    with pytest.raises(DataError, match=r"'time' goes backwards at data row 22"):
        load_record(_csv(tmp_path, d), COLS)
    d = _good()
    d.loc[31, "time"] = d.loc[30, "time"]
    with pytest.raises(DataError, match=r"'time' repeats at data row 32"):
        load_record(_csv(tmp_path, d, "dup.csv"), COLS)


def test_bad_constant_signal(tmp_path):
    d = _good()
    d["stroke"] = 1.5
    with pytest.raises(DataError, match=r"column 'stroke' is constant"):
        load_record(_csv(tmp_path, d), COLS)


def test_bad_too_few_cycles(tmp_path):
    d = _good(160)  # 1.6 periods: one complete cycle, no interval possible
    rec = load_record(_csv(tmp_path, d), COLS)
    with pytest.raises(DataError, match=r"column 'stroke' gives 1 complete cycle"):
        identify_hysteresis(rec["time"], rec["stroke"], rec["force"], run=rec.run, source=rec.source)


def test_bad_unit_and_reversed_force(tmp_path):
    from proleg.identify import parse_units

    with pytest.raises(DataError, match="unknown unit 'furlong'"):
        parse_units("stroke=furlong")
    d = _good()
    rec = load_record(_csv(tmp_path, d), COLS)
    with pytest.raises(DataError, match="force sign is reversed"):
        identify_hysteresis(rec["time"], rec["stroke"], -rec["force"])


def test_runs_from_time_restart_and_run_column(tmp_path):
    parts = []
    for r in range(3):
        d = _good(250)
        d["run"] = f"R{r}"
        parts.append(d)
    d = pd.concat(parts, ignore_index=True)  # time restarts at 0 for every run
    rec = load_record(_csv(tmp_path, d), COLS)
    assert rec.nruns == 3
    res = identify_hysteresis(rec["time"], rec["stroke"], rec["force"], run=rec.run)
    assert res.repetition == "run" and len(res.repetitions) == 3
    np.testing.assert_allclose(res.repetitions["k"], 100.0, rtol=1e-6)
    rec2 = load_record(_csv(tmp_path, d, "runs.csv"), COLS, run_col="run")
    assert rec2.nruns == 3
    # absolute clock with pauses between runs: a jump of more than 50 median intervals starts a run
    d3 = pd.concat([p.assign(time=p["time"] + 100.0 * i) for i, p in enumerate(parts)], ignore_index=True)
    assert load_record(_csv(tmp_path, d3, "pauses.csv"), COLS).nruns == 3
    d2 = pd.concat([parts[0], parts[1], parts[0].assign(time=parts[0]["time"] + 10)], ignore_index=True)
    with pytest.raises(DataError, match="not contiguous"):
        load_record(_csv(tmp_path, d2, "mixed.csv"), COLS, run_col="run")
