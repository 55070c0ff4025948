"""flegx-study's shared law (issue 30: no law picked by hand): the one law every configuration
runs is the shortest push that keeps all of them within the limits up to take-off
(:func:`proleg.papers.flegx_study.shared_push`, seed 002 §IV).

- The bookkeeping on synthetic push grids (a fake study): each configuration's shortest
  feasible push, the longest of them shared, its configuration and constraint binding, the
  others within their limits there, the refinement inside the binding bracket (only the
  configurations whose push lies in it), the error when a configuration breaks a limit at
  every push, and push_at_limits' "first" rule against a late limit spike (measured on No. 2).
- The report: ``run_study`` runs the variants at the push found (its own store), writes the
  per-configuration pushes, and its text names the binding configuration; no frozen numbers.
- A reduced real search (PRBM, case 2, No. 2 and 4, a coarse grid refined once): the shared
  push's binding configuration sits at 520 MPa when simulated at that push, the other within
  the limits (slow: about 3 min on a loaded 2-core machine).
"""

import numpy as np
import pandas as pd
import pytest

import proleg as pl
from proleg.papers import flegx_codesign as FC
from proleg.papers import flegx_study as FS
from proleg.papers.flegx_jump import MotionLaw

#: synthetic laws per configuration: the stress reaches 520 MPa at t_s, the knee torque 77 N m at t_k
LIMITS = {1: (0.21, 0.18), 2: (0.337, 0.30), 3: (0.19, 0.22), 4: (0.25, 0.20)}


def _fake_rows(configuration, pushes):
    t_s, t_k = LIMITS[configuration]
    tp = np.asarray(pushes, float)
    return pd.DataFrame({"law_t_push": tp, "jump_height": 0.5 - tp, "max_stress_takeoff": 520e6 * (1 + (t_s - tp)),
                         "max_stress": 900e6, "peak_hip_torque_takeoff": 40.0, "peak_knee_torque_takeoff": 77.0 * (1 + 2 * (t_k - tp)),
                         "peak_hip_torque": 500.0, "peak_knee_torque": 95.0, "take_off_time": 1.3, "apex_time": 1.4,
                         "foot_clearance": 0.4 - tp, "flight_rise": 0.1, "tip_displacement": 0.01, "takeoff_in_push": 0.5})


@pytest.fixture
def fake_study(monkeypatch):
    asked = []

    class FakeStudy:
        def __init__(self, configuration):
            self.configuration = configuration

        def evaluate(self, table, **kw):
            asked.append((self.configuration, tuple(table["law_t_push"])))
            return _fake_rows(self.configuration, table["law_t_push"])

    monkeypatch.setattr(FC, "codesign_study", lambda c, *a, **k: (FakeStudy(c), MotionLaw(design=True)))
    return asked


def test_shared_push_is_the_longest_push_at_the_limits(fake_study):
    grid = (0.16, 0.20, 0.25, 0.30, 0.38, 0.45)
    out = FS.shared_push((1, 2, 3, 4), pushes=grid, refine=3, workers=1)
    # No. 2's stress reaches 520 MPa at the longest push of all: it sets the law, its stress binds
    assert out["binding_configuration"] == 2 and out["binding"] == "max_stress_takeoff"
    assert out["t_push_s"] == pytest.approx(LIMITS[2][0], abs=1e-12)  # linear slack: exact on any grid
    assert out["stress_MPa"] == pytest.approx(520.0, abs=1e-9) and out["peak_knee_Nm"] < 77.0
    assert out["within_all"]
    per = out["per_configuration"].set_index("configuration")
    for c, (t_s, t_k) in LIMITS.items():  # each configuration's own shortest push, the later of its two limits
        assert per.loc[c, "t_push_s"] == pytest.approx(max(t_s, t_k), abs=1e-12)
        assert per.loc[c, "binding"] == ("max_stress_takeoff" if t_s >= t_k else "peak_knee_torque_takeoff")
        assert per.loc[c, "rule"] == "first" and per.loc[c, "feasible_after"]
    # at the shared push every configuration holds its limits; the binding one sits on its limit
    assert (per["stress_shared_MPa"] <= 520.0 + 1e-9).all() and (per["knee_shared_Nm"] <= 77.0).all() and per["within_at_shared"].all()
    assert per.loc[2, "stress_shared_MPa"] == pytest.approx(520.0, abs=1e-9)
    assert per.loc[1, "stress_shared_MPa"] == pytest.approx(520.0 * (1 + LIMITS[1][0] - LIMITS[2][0]), rel=1e-12)
    # the refinement: 3 pushes inside (0.30, 0.38], for No. 2 only (the others' pushes lie below the bracket)
    again = fake_study[4:]
    assert [c for c, _ in again] == [2]
    assert set(again[0][1]) == set(grid) | set(np.linspace(0.30, 0.38, 5)[1:-1].round(6))
    assert per.loc[2, "grid_rows"] == len(grid) + 3 and per.loc[1, "grid_rows"] == len(grid)


def test_first_rule_takes_the_first_feasible_push_past_a_late_spike(monkeypatch):
    """A long push that takes off late can break a limit again (measured: No. 2, 0.364 s, 173 N m at the hip):
    'settled' lands past the spike, 'first' at the stress limit before it."""
    tp = np.array([0.30, 0.332, 0.348, 0.364, 0.38, 0.45])
    rows = _fake_rows(2, tp)
    rows["peak_hip_torque_takeoff"] = [12.8, 11.1, 10.3, 173.2, 19.9, 7.8]

    class FakeStudy:
        def evaluate(self, table, **kw):
            return rows.copy()

    monkeypatch.setattr(FC, "codesign_study", lambda *a, **k: (FakeStudy(), MotionLaw(design=True)))
    first = FC.push_at_limits(2, 2, pushes=tuple(tp), rule="first")
    assert first["binding"] == "max_stress_takeoff" and first["t_push_s"] == pytest.approx(LIMITS[2][0], abs=1e-12)
    assert not first["feasible_after"]  # the spike at 0.364 s lies past it
    settled = FC.push_at_limits(2, 2, pushes=tuple(tp))
    assert settled["binding"] == "peak_hip_torque_takeoff" and 0.364 < settled["t_push_s"] < 0.38 and settled["feasible_after"]
    with pytest.raises(pl.ModelError, match="rule 'last'"):
        FC.push_at_limits(2, 2, pushes=tuple(tp), rule="last")


def test_shared_push_errs_when_a_configuration_breaks_a_limit_everywhere(fake_study):
    with pytest.raises(pl.ModelError, match=r"No. 2 within the limits.*max_stress_takeoff.*SHARED_PUSHES"):
        FS.shared_push((1, 2), pushes=(0.16, 0.20, 0.25), workers=1)


def test_shared_law_is_the_documented_law_with_the_push_found():
    law = FS.shared_law({"t_push_s": 0.3456})
    assert law.t_push == 0.3456 and law.t_after == FS.STUDY_T_AFTER
    assert law.extend == MotionLaw().extend and law.squat == MotionLaw().squat


def test_run_study_runs_the_shared_law_and_reports_it(monkeypatch, tmp_path):
    """run_study's wiring: the variants run the law found, in that law's store; the report names the binding configuration."""
    from proleg.papers import flegx_report

    per = pd.DataFrame([{"configuration": c, "t_push_s": t, "binding": "max_stress_takeoff", "stress_MPa": 520.0, "peak_hip_Nm": 10.0,
                         "peak_knee_Nm": 57.0, "height_mm": 30.0 + c, "jump_mm": 50.0 + c, "monotone": True, "feasible_after": True,
                         "stress_shared_MPa": 520.0 - (c != 2) * 60, "hip_shared_Nm": 10.0, "knee_shared_Nm": 50.0, "height_shared_mm": 20.0,
                         "jump_shared_mm": 40.0, "within_at_shared": True} for c, t in ((2, 0.3461), (4, 0.2625))])
    shared = {"t_push_s": 0.3461, "binding_configuration": 2, "binding": "max_stress_takeoff", "stress_MPa": 520.0, "peak_hip_Nm": 10.0,
              "peak_knee_Nm": 57.0, "within_all": True, "per_configuration": per}
    seen = {}

    def fake_table(store_dir, configurations, cases, cb_case, progress=True, workers=None, law=None, **kw):
        seen.update(store=str(store_dir), law=law)
        return pd.DataFrame([{"configuration": c, "link_case": k, "link model": lm, "total_mass": 8.0 + c, "jump_height": 0.05 + 0.01 * c,
                              "foot_clearance": 0.03, "flight_rise": 0.1, "max_stress_takeoff": (490e6 if c == 4 else 519e6),
                              "tip_displacement": 0.05, "peak_hip_torque_takeoff": 12.0, "peak_knee_torque_takeoff": 57.0, "> 510 MPa": c == 2, "apex_in_window": 1.0, "status": "success", "steps": 100,
                              "wall_s": 1.0} for c in configurations for k in cases for lm in ("prbm", "cb") if lm == "prbm" or k == 2])

    monkeypatch.setattr(FS, "shared_push", lambda configurations, **kw: shared)
    monkeypatch.setattr(FS, "run_table_i", fake_table)
    path = flegx_report.run_study(tmp_path, progress=False, configurations=(2, 4), cases=(2,), codesign=False)
    assert seen["law"].t_push == 0.3461 and seen["law"].extend == MotionLaw().extend
    assert seen["store"].endswith("push_0.34610s")
    got = pd.read_parquet(tmp_path / "shared_law.parquet")
    assert list(got["configuration"]) == [2, 4] and list(got["t_push_s"]) == [0.3461, 0.2625]
    tab = flegx_report.shared_law_table(got)
    assert list(tab["sets the shared law"]) == [True, False]
    html = path.read_text()
    assert "Its push, 0.346 s" in html and "No. 2 sets it (binding: max_stress_takeoff, 520 MPa" in html
    assert "No. 4 0.263 s (max_stress_takeoff)" in html and "set by No. 2" in html
    assert "every configuration is within the limits" in html
    t1 = pd.read_parquet(tmp_path / "table1.parquet")
    assert list(t1["prbm hip / knee torque [N m]"]) == ["12.0 / 57.0"] * 2


@pytest.mark.slow
def test_reduced_shared_push_binds_at_the_stress_limit(tmp_path):
    from proleg.papers.flegx_jump import flegx_jump

    out = FS.shared_push((2, 4), pushes=(0.20, 0.30, 0.45), refine=2, store=tmp_path, workers=1)
    assert out["binding_configuration"] == 2 and out["binding"] == "max_stress_takeoff", out
    assert out["stress_MPa"] == pytest.approx(520.0, abs=1e-6)  # interpolated onto the limit
    # simulated at the push found, the binding configuration sits at its limit (interpolation error of the refined grid),
    # the other below its own limits
    for c in (2, 4):
        m = flegx_jump(c, 2, "prbm", t_push=out["t_push_s"], t_after=FS.STUDY_T_AFTER, dt_output=2e-3).metrics
        if c == out["binding_configuration"]:
            assert m["max_stress_takeoff"] == pytest.approx(520e6, rel=0.02), m
        else:
            assert m["max_stress_takeoff"] < 520e6 and m["peak_knee_torque_takeoff"] < 77.0 and m["peak_hip_torque_takeoff"] < 77.0
