"""identify.calibration (issue 31): a parameter fitted on synthetic data is recovered, the fit
declares what it was fitted on, and a held-out score uses only held-out data."""

import math

import numpy as np
import pandas as pd
import pytest

from proleg.errors import ConvergenceError, DataError
from proleg.identify.calibration import Calibrated, calibrate, check_held_out, fit_to, held_out_score, split_scores


def spring_mass_hz(k, m=2.0):
    return math.sqrt(k / m) / (2 * math.pi)


def test_parameter_recovered_from_synthetic_data():
    """A 2 kg mass on a spring of 5e4 N/m rings at f = sqrt(k/m)/2pi; the calibration on that
    frequency recovers k to the root finder's tolerance (rtol 1e-10 in log k)."""
    k_true = 5e4
    cal = calibrate(spring_mass_hz, name="k", bounds=(1e3, 1e6), unit="N/m", target=spring_mass_hz(k_true),
                    fitted_on="first mode", source="synthetic", rtol=1e-12)
    assert isinstance(cal, Calibrated) and cal.fitted_on == ("first mode",)
    assert cal.value == pytest.approx(k_true, rel=1e-9)
    assert not cal.at_bound and cal.achieved == pytest.approx(cal.target, rel=1e-9)
    row = cal.row()
    assert row["bounds"] == "1000 .. 1e+06" and row["fitted_on"] == "first mode"


def test_target_outside_range_ends_on_a_bound():
    cal = calibrate(spring_mass_hz, name="k", bounds=(1e3, 1e4), unit="N/m", target=spring_mass_hz(1e6),
                    fitted_on=("f1",), source="synthetic")
    assert cal.at_bound and cal.value == 1e4
    with pytest.raises(DataError, match="bounds"):
        calibrate(spring_mass_hz, name="k", bounds=(0.0, 1e4), unit="N/m", target=1.0, fitted_on="f1", source="s")


def test_split_scores_keep_the_held_out_prediction_apart():
    """Two masses on one spring type: k fitted on mass A's frequency, mass B's predicted. The
    predicted table holds B only; scoring A as validation is refused."""
    k_true = 3e4
    meas = {"mass A": spring_mass_hz(k_true, 1.0), "mass B": spring_mass_hz(k_true, 4.0)}
    cal = calibrate(lambda k: spring_mass_hz(k, 1.0), name="k", bounds=(1e3, 1e6), unit="N/m",
                    target=meas["mass A"], fitted_on="mass A", source="synthetic")
    tab = pd.DataFrame({"quantity": ["mass A", "mass B"],
                        "model [Hz]": [spring_mass_hz(cal.value, 1.0), spring_mass_hz(cal.value, 4.0)],
                        "measured [Hz]": [meas["mass A"], meas["mass B"]]})
    fitted, predicted = split_scores(tab, [cal])
    assert list(fitted["quantity"]) == ["mass A"] and list(predicted["quantity"]) == ["mass B"]
    # the held-out prediction is a prediction: mass B at half mass A's frequency (m 4x)
    assert predicted["model [Hz]"].iloc[0] == pytest.approx(meas["mass B"], rel=1e-8)
    check_held_out(predicted["quantity"], [cal])
    with pytest.raises(DataError, match="mass A"):
        check_held_out(tab["quantity"], [cal])
    with pytest.raises(DataError, match="quantity"):
        split_scores(tab.rename(columns={"quantity": "q"}), [cal])
    assert np.isfinite(cal.value)


# -- fit_to / held_out_score (Scout II's leg friction) --


A_TRUE = 2.37  # synthetic "truth": y(x) = a x² + sin(a)


def model(a):
    return {f"y({x})": a * x**2 + np.sin(a) for x in (1, 2, 3)}


def test_one_quantity_recovered_by_bracketing():
    data = model(A_TRUE)
    hist = []
    cal = fit_to("a", model, {"y(1)": data["y(1)"]}, (0.5, 5.0), unit="-", source="synthetic", xtol=1e-9, history=hist, max_evals=60)
    assert isinstance(cal, Calibrated) and cal.fitted_on == ("y(1)",)
    assert abs(cal.value - A_TRUE) < 2e-9  # bisection to xtol on a monotone residual
    assert 0.5 <= cal.value <= 5.0 and len(hist) <= 2 + 33  # two ends + log2(4.5e9) halvings


def test_several_quantities_least_squares():
    data = model(A_TRUE)
    cal = fit_to("a", model, {"y(1)": data["y(1)"], "y(2)": data["y(2)"]}, (0.5, 5.0), xtol=1e-7, max_evals=80)
    assert abs(cal.value - A_TRUE) < 1e-6


def test_held_out_score_uses_only_held_out_data():
    data = model(A_TRUE)
    cal = fit_to("a", model, {"y(1)": data["y(1)"]}, (0.5, 5.0), xtol=1e-10, max_evals=80)
    pred = model(cal.value)
    rows = held_out_score(cal, pred, {"y(2)": data["y(2)"], "y(3)": data["y(3)"]})
    assert [r["quantity"] for r in rows] == ["y(2)", "y(3)"]
    assert max(abs(r["relative error [%]"]) for r in rows) < 1e-6
    # the fitted quantity is refused, never scored as agreement
    with pytest.raises(DataError, match="y\\(1\\)"):
        held_out_score(cal, pred, {"y(1)": data["y(1)"], "y(2)": data["y(2)"]})
    # a wrong held-out measurement shows as a prediction error (the score reads the held-out data)
    rows = held_out_score(cal, pred, {"y(3)": 1.1 * data["y(3)"]})
    assert rows[0]["relative error [%]"] == pytest.approx(100 * (1 / 1.1 - 1), rel=1e-6)


def test_no_bracket_is_reported_not_widened():
    with pytest.raises(ConvergenceError, match="justified range"):
        fit_to("a", model, {"y(1)": 100.0}, (0.5, 5.0))
