"""proleg.identify.calibration: a parameter fitted on synthetic data is recovered, and the
held-out score uses only held-out data (issue 31)."""

import numpy as np
import pytest

from proleg.errors import ConvergenceError, DataError
from proleg.identify.calibration import Calibrated, calibrate, held_out_score

A_TRUE = 2.37  # synthetic "truth": y(x) = a x² + sin(a)


def model(a):
    return {f"y({x})": a * x**2 + np.sin(a) for x in (1, 2, 3)}


def test_one_quantity_recovered_by_bracketing():
    data = model(A_TRUE)
    hist = []
    cal = calibrate("a", model, {"y(1)": data["y(1)"]}, (0.5, 5.0), unit="-", source="synthetic", xtol=1e-9, history=hist, max_evals=60)
    assert isinstance(cal, Calibrated) and cal.fitted_on == ("y(1)",)
    assert abs(cal.value - A_TRUE) < 2e-9  # bisection to xtol on a monotone residual
    assert 0.5 <= cal.value <= 5.0 and len(hist) <= 2 + 33  # two ends + log2(4.5e9) halvings


def test_several_quantities_least_squares():
    data = model(A_TRUE)
    cal = calibrate("a", model, {"y(1)": data["y(1)"], "y(2)": data["y(2)"]}, (0.5, 5.0), xtol=1e-7, max_evals=80)
    assert abs(cal.value - A_TRUE) < 1e-6


def test_held_out_score_uses_only_held_out_data():
    data = model(A_TRUE)
    cal = calibrate("a", model, {"y(1)": data["y(1)"]}, (0.5, 5.0), xtol=1e-10, max_evals=80)
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
        calibrate("a", model, {"y(1)": 100.0}, (0.5, 5.0))
