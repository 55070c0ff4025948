"""Scout II, the decided reading (issue 44): the leg damping is fitted on the measured speed only,
and the predictions come from runs at the fitted value that the fit never saw.

The fit and the predictions are driven here by a stand-in for ``scout2_study.run_point`` (a
known speed-against-damping law, and specific resistances that carry a tag), so the tests are
fast and can fail: a helper that looked at a predicted quantity, or a prediction that reused a
calibration run, changes what they see. The full-size runs are bench/scout2_reading.py.
"""

import inspect
from types import SimpleNamespace

import numpy as np
import pytest

from proleg.errors import ModelError
from proleg.papers import scout2_reading as R
from proleg.papers import scout2_study as S
from proleg.robots import scout2_data as D


def law(b):
    """Model II's speed [m/s] against the damping [N s/m]: bounds below 44, stalls above."""
    return 2.4 - 0.03 * b if b < 44.0 else np.nan


class FakeRuns:
    """Stand-in for run_point: records every call; the runs' specific resistances are ``sr``."""

    def __init__(self, sr=1.0, tag="run"):
        self.calls, self.sr, self.tag = [], sr, tag

    def __call__(self, model, t_end, *, base=None, delta=0.0, **params):
        b = params.get("leg_damping", D.LEG_DAMPING)
        self.calls.append((model, dict(params), self.tag))
        v = law(b) if model == "II" else (law(b) + 0.2 if np.isfinite(law(b)) else np.nan)
        stalled = not np.isfinite(v)
        m = {"forward_speed": v, "period": 0 if stalled else 1, "fell": False, "stalled": stalled, "strides": 0 if stalled else 8,
             "specific_resistance_electrical": self.sr, "specific_resistance_mechanical": 0.3 * self.sr, "stride_frequency": 2.5,
             "duty_factor_back": 0.3, "duty_factor_front": 0.3, "pitch_max": 8.0, "pitch_min": -6.0, "height_max": 0.33, "height_min": 0.3}
        return SimpleNamespace(metrics=m, model=model, tag=self.tag, leg_damping=b)


def test_the_fit_sees_only_the_measured_speed(monkeypatch):
    """The helper's inputs name only the speed target and the range; its result does not move
    when every other quantity of the runs (the specific resistances) changes."""
    allowed = {"t_end", "base", "target_speed", "bounds", "grid", "xtol", "rows", "log"}
    assert set(inspect.signature(R.calibrate_leg_damping).parameters) == allowed
    assert R.calibrate_leg_damping.__kwdefaults__["target_speed"] == D.SPEED_MEASURED == 1.286  # seed 003 §5.2
    fits = []
    for sr in (1.0, 7.0):
        fake = FakeRuns(sr=sr)
        monkeypatch.setattr(S, "run_point", fake)
        rows = []
        cal, runs = R.calibrate_leg_damping(8.0, rows=rows)
        fits.append(cal.value)
        assert all(model == "II" and set(p) == {"leg_damping"} for model, p, _ in fake.calls)  # Model II, only b changes
        assert cal.fitted_on == (R.SPEED_QUANTITY,) and cal.name == "leg_damping"
        assert cal.bounds == pytest.approx(R.DAMPING_RANGE) == (0.3 * 55.0, 55.0)
        # the law's root: 2.4 - 0.03 b = 1.286 at b = 37.13; bisected to 0.5 N s/m
        assert cal.value == pytest.approx((2.4 - 1.286) / 0.03, abs=0.5) and not cal.at_bound
        assert abs(cal.achieved - 1.286) <= 0.03 * 0.5
        # the speed-against-damping rows: Table 6 as printed (55) stalls, speed 0
        top = next(r for r in rows if r["leg damping [N s/m]"] == 55.0)
        assert top["stalled"] and top["speed [m/s]"] == 0.0
    assert fits[0] == fits[1]


def test_no_damping_in_range_gives_the_speed(monkeypatch):
    """Every run stalls: the closest sample is returned flagged, with the table of what was tried."""
    fake = FakeRuns()
    monkeypatch.setattr(S, "run_point", fake)
    monkeypatch.setattr(R, "bound_speed", lambda run: 0.0)
    rows = []
    cal, _ = R.calibrate_leg_damping(8.0, grid=3, rows=rows)
    assert cal.at_bound and cal.achieved == 0.0
    assert [r["leg damping [N s/m]"] for r in rows] == pytest.approx([55.0, 35.75, 16.5])


def test_predictions_come_from_runs_at_the_fitted_value_only(monkeypatch):
    """run_reading: the fit's runs (tag 'fit') are never the predictions' runs (tag 'predict');
    every predicted run uses the fitted damping, and the predicted specific resistances are those
    of the prediction runs."""
    calls = []
    fit, pred = FakeRuns(sr=1.0, tag="fit"), FakeRuns(sr=1.7, tag="predict")
    phase = {"now": fit}

    def run_point(model, t_end, **kw):
        r = phase["now"](model, t_end, **kw)
        calls.append((phase["now"].tag, model, kw.get("leg_damping")))
        return r

    real_predict = R.predict

    def predict(b, *a, **kw):
        phase["now"] = pred
        return real_predict(b, *a, **kw)

    monkeypatch.setattr(S, "run_point", run_point)
    monkeypatch.setattr(R, "predict", predict)
    monkeypatch.setattr(R, "stance_phases", lambda run, transient=None: {})
    out = R.run_reading(8.0, low_speed_target=None)
    cal = out["calibration"]
    assert out["met"]
    pred_calls = [c for c in calls if c[0] == "predict"]
    assert {c[1] for c in pred_calls} == {"I", "II"} and all(c[2] == cal.value for c in pred_calls)
    for row in out["rows"]:
        assert row["SR electrical"] == 1.7  # the prediction runs' numbers, not the fit's (1.0)
        assert row["leg damping [N s/m]"] == cal.value
    assert out["rows"][1]["speed [m/s]"] == pytest.approx(law(cal.value))
    assert out["prediction"]["Model I"].tag == "predict" and out["prediction"]["Model II"].tag == "predict"
    # the as-printed runs are Table 6's damping (the stall), shown beside the calibrated ones
    assert all(r.leg_damping == 55.0 and r.metrics["stalled"] for r in out["printed"].values())


def test_bound_speed_counts_only_a_steady_bound():
    ok = {"forward_speed": 1.3, "period": 2, "fell": False, "stalled": False, "strides": 7}
    assert R.bound_speed(SimpleNamespace(metrics=ok)) == 1.3
    for change in ({"period": 0}, {"fell": True}, {"stalled": True}, {"strides": 0}, {"forward_speed": np.nan}):
        assert R.bound_speed(SimpleNamespace(metrics={**ok, **change})) == 0.0


def test_bad_input():
    with pytest.raises(ModelError, match="calibrate_leg_damping: bounds"):
        R.calibrate_leg_damping(8.0, bounds=(55.0, 16.5))
    with pytest.raises(ModelError, match="grid"):
        R.calibrate_leg_damping(8.0, grid=1)
    with pytest.raises(ModelError, match="target_speed"):
        R.calibrate_leg_damping(8.0, target_speed=-1.0)
    with pytest.raises(ModelError, match="leg_damping"):
        R.predict(-3.0, 8.0)


def test_the_reading_stops_where_no_damping_bounds(monkeypatch):
    """Issue 44: if no damping in the range makes Model II bound at Table 4, report that and stop:
    no prediction run is made."""
    fake = FakeRuns()
    monkeypatch.setattr(S, "run_point", fake)
    monkeypatch.setattr(R, "bound_speed", lambda run: 0.0)
    called = []
    monkeypatch.setattr(R, "predict", lambda *a, **k: called.append(a))
    out = R.run_reading(8.0, grid=5)
    assert out["prediction"] is None and not called and not out["met"] and not out["rows"]
    assert "no leg damping in 16.5–55 N s/m" in out["stopped"] and "sampled at 5 values" in out["stopped"]
    assert [r["leg damping [N s/m]"] for r in out["speed_vs_damping"]] == pytest.approx(np.linspace(16.5, 55.0, 5))
    assert len(fake.calls) == 2 + 5  # the two as-printed runs and the grid, nothing after


@pytest.mark.slow
def test_scenario_reports_the_stop(tmp_path):
    """The scenario end to end at reduced size (2 s runs, the range's two ends): both ends of the
    damping range leave Model II without a bound at Table 4 (bench/results/scout2_calibration.md
    at full size), so the report states the calibration's failure beside the as-printed runs and
    predicts nothing."""
    import pandas as pd

    from proleg.papers.scout2_report import run_bound

    path = run_bound(tmp_path, t_end=2.0, grid=2, low_speed=False, progress=False)
    html = path.read_text()
    assert "there is nothing to calibrate, so nothing is predicted" in html
    sweep = pd.read_parquet(tmp_path / "speed_vs_damping.parquet")
    assert list(sweep["leg damping [N s/m]"]) == pytest.approx([16.5, 55.0]) and (sweep["speed [m/s]"] == 0).all()
    assert sweep.set_index("leg damping [N s/m]").loc[55.0, "stalled"]  # Table 6 as printed: the stall
    assert not (tmp_path / "fig7_points.parquet").exists()
