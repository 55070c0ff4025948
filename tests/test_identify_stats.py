"""Statistics over repetitions (seed 000 Table 2: mean, relative σ, 95 % Student-t interval, n − 1 dof)."""

import numpy as np
import pandas as pd
import pytest

from proleg.errors import DataError
from proleg.identify import mean_interval, repetition_check, repetitions_table

# t_{0.975, 4}: the 95 % two-sided Student quantile for five repetitions (tables: 2.776)
T975_4 = 2.7764451051977987


def test_mean_interval_by_hand():
    v = np.array([8.2e4, 8.3e4, 8.4e4, 8.25e4, 8.35e4])  # five repetitions, as in seed 000
    iv = mean_interval(v)
    mean = v.mean()
    s = np.sqrt(np.sum((v - mean) ** 2) / 4)
    # Round-off: the mean to a few ulp (another summation order, e.g. other SIMD lanes); the
    # deviations v − mean cancel, so s carries the mean's error amplified by mean/s (≈ 100 here):
    # 64 eps × mean/s relative (1.5e-12). Dividing by n instead of n − 1 is off by 12 %.
    eps = np.finfo(float).eps
    tol_s = 64 * eps * mean / s
    assert iv.n == 5 and iv.mean == pytest.approx(mean, rel=64 * eps)
    assert iv.std == pytest.approx(s, rel=tol_s)
    assert iv.t == pytest.approx(T975_4, rel=1e-12)
    assert iv.low == pytest.approx(mean - T975_4 * s / np.sqrt(5), rel=tol_s)
    assert iv.high == pytest.approx(mean + T975_4 * s / np.sqrt(5), rel=tol_s)
    assert iv.rel_sigma == pytest.approx(s / mean, rel=tol_s)
    lo, hi = iv.prediction
    # hi − mean cancels too: its error is the mean's, relative to T s sqrt(1.2) ≈ 2400
    assert hi - mean == pytest.approx(T975_4 * s * np.sqrt(1 + 1 / 5), rel=tol_s)
    assert mean_interval(v, 0.99).half_width > iv.half_width


def test_repetitions_table_and_checks():
    rng = np.random.default_rng(0)
    k = 8.30e4 * (1 + 0.01 * rng.standard_normal(5))  # Table 2 hip k, σ = 1 %
    c = 4.50e5 * (1 + 0.22 * rng.standard_normal(5))  # hip c, σ = 22 %
    tb = repetitions_table({"k": k, "c": c}, units={"k": "N/m", "c": "N s/m"})
    assert list(tb.index) == ["k", "c"]
    for col in ("n", "mean", "std", "rel_sigma", "ci_low", "ci_high", "pi_low", "pi_high", "n_inside_ci",
                "n_inside_pi", "all_inside", "unit"):
        assert col in tb.columns
    assert tb.loc["k", "n"] == 5 and tb.loc["c", "unit"] == "N s/m"
    # round-off of a standard deviation: 64 eps × mean/s (see test_mean_interval_by_hand)
    tol = 64 * np.finfo(float).eps * np.mean(k) / np.std(k, ddof=1)
    assert tb.loc["k", "rel_sigma"] == pytest.approx(np.std(k, ddof=1) / np.mean(k), rel=tol)
    assert tb.loc["k", "ci_low"] < tb.loc["k", "mean"] < tb.loc["k", "ci_high"]
    chk = repetition_check(k)
    assert chk["inside_ci"].sum() == tb.loc["k", "n_inside_ci"]
    assert chk["inside_pi"].sum() == tb.loc["k", "n_inside_pi"]
    # a DataFrame works the same way
    tb2 = repetitions_table(pd.DataFrame({"k": k}))
    assert tb2.loc["k", "mean"] == tb.loc["k", "mean"]


def test_prediction_interval_covers_single_repetitions():
    # the interval of the *mean* is narrower than the spread of single values; the prediction interval
    # holds one further repetition with probability 0.95
    rng = np.random.default_rng(11)
    hits = 0
    trials = 2000
    for _ in range(trials):
        v = rng.standard_normal(6)
        lo, hi = mean_interval(v[:5]).prediction
        hits += lo <= v[5] <= hi
    assert abs(hits / trials - 0.95) < 0.015


def test_too_few_or_bad_repetitions():
    with pytest.raises(DataError, match="at least 2"):
        mean_interval([1.0])
    with pytest.raises(DataError, match=r"c: repetition 2 is nan"):
        repetitions_table({"c": [1.0, np.nan, 2.0]})
    iv = mean_interval([3.0, 3.0, 3.0])  # identical repetitions: a degenerate, finite interval
    assert iv.low == iv.high == 3.0
