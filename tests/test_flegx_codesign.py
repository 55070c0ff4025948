"""FLEGX jump law as design variables and Table I by co-design (issue 30, proleg.papers.flegx_codesign).

- The design law (``MotionLaw(design=True)``: push duration and extended pose read from the
  System) imposes the same joint motions as the hand law it starts from, and, after
  ``with_params(law_t_push=..., law_extend_knee=...)``, the same as a hand law built with those
  values: Φ(q, t) of the assembled systems agree to rounding at times through squat, push and
  retraction (no simulation: Φ is where a motion law enters).
- The limits' phase: take-off (seed 002 §IV, Table I's phase) or the whole run; a wrong name errs.
- The reduced co-design's bookkeeping (:func:`push_at_limits`) on a synthetic grid: the
  binding constraint is the one whose slack reaches zero at the longest push, and the optimum
  is interpolated there.
- A reduced real co-design (No. 4, PRBM, case 2; push and knee extension; 8 CMA-ES trials after
  a 4-push start grid): the optimum is feasible, clears more than flegx_jump's hand law, and its
  stress up to take-off is at the 520 MPa limit (the binding constraint, within 5 %).
"""

import warnings

import jax.numpy as jnp
import numpy as np
import pandas as pd
import pytest

import proleg as pl
from proleg.assembly.system import constraints
from proleg.papers import flegx_codesign as FC
from proleg.robots.flegx import flegx
from proleg.papers.flegx_jump import MotionLaw, _add_motions
from proleg.units import deg


def _system(law, configuration):
    m = flegx(configuration, 2, "rigid", stand=law.stand)
    _add_motions(m, law)
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=".*redundant constraint.*")
        return pl.assemble(m)


@pytest.mark.parametrize("configuration", [3, 4])  # knee driven directly (No. 3), through the tendons (No. 4)
def test_design_law_imposes_the_hand_law_and_follows_its_variables(configuration):
    design = _system(MotionLaw(design=True), configuration)
    q = design.params["q_init"]
    ts = [0.1, 0.5, 1.0, 1.1, 1.2, 1.3, 1.45, 1.6]  # settle, squat, hold, push, retract
    for law_kw, params in (({}, {}), ({"t_push": 0.22, "extend": (-30 * deg, 25 * deg)},
                                      {"law_t_push": 0.22, "law_extend_hip": -30 * deg, "law_extend_knee": 25 * deg})):
        hand = _system(MotionLaw(**law_kw), configuration)
        sd = design.with_params(params) if params else design
        for t in ts:
            a, b = np.asarray(constraints(sd, q, jnp.asarray(t))), np.asarray(constraints(hand, q, jnp.asarray(t)))
            np.testing.assert_allclose(a, b, atol=1e-12)
    # the variables change the motion (the retraction start moves with the push's end)
    a = np.asarray(constraints(design.with_params(law_t_push=0.22), q, jnp.asarray(1.3)))
    b = np.asarray(constraints(design, q, jnp.asarray(1.3)))
    assert np.max(np.abs(a - b)) > 1e-3


def test_push_at_limits_finds_the_binding_constraint(monkeypatch):
    # synthetic grid: jump falls with the push; the stress reaches 520 MPa at 0.20 s, the knee
    # torque 77 N m at 0.225 s (the last to be met as the push shortens: it binds)
    tp = np.array([0.16, 0.20, 0.25, 0.30])
    rows = pd.DataFrame({"law_t_push": tp, "jump_height": 0.5 - tp, "max_stress_takeoff": 520e6 * (1 + (0.20 - tp)),
                         "max_stress": 600e6, "peak_hip_torque_takeoff": 40.0, "peak_knee_torque_takeoff": 77.0 * (1 + 2 * (0.225 - tp)),
                         "peak_hip_torque": 500.0, "peak_knee_torque": 95.0,  # the landing's: not the take-off phase
                         "take_off_time": 1.3, "apex_time": 1.4, "foot_clearance": 0.4 - tp, "flight_rise": 0.1, "tip_displacement": 0.01,
                         "takeoff_in_push": 0.5})

    class FakeStudy:
        def evaluate(self, table, **kw):
            return rows.copy()

    monkeypatch.setattr(FC, "codesign_study", lambda *a, **k: (FakeStudy(), MotionLaw(design=True)))
    out = FC.push_at_limits(3, 2, pushes=tuple(tp))
    assert out["binding"] == "peak_knee_torque_takeoff" and out["monotone"]
    assert out["t_push_s"] == pytest.approx(0.225, abs=1e-12)
    assert out["jump_mm"] == pytest.approx(1e3 * (0.5 - 0.225), abs=1e-9)
    assert out["height_mm"] == pytest.approx(1e3 * (0.4 - 0.225), abs=1e-9)
    assert out["stress_MPa"] < 520.0
    # over the whole run the landing's 500 N m hip torque violates the rating at every push
    out = FC.push_at_limits(3, 2, pushes=tuple(tp), phase="all")
    assert "infeasible on the grid" in out["binding"] and "peak_hip_torque" in out["binding"]


def test_constraint_phase_and_its_errors():
    assert set(FC.constraints("takeoff")) == {"max_stress_takeoff", "peak_hip_torque_takeoff", "peak_knee_torque_takeoff", "takeoff_in_push"}
    assert set(FC.constraints("all")) == {"max_stress", "peak_hip_torque", "peak_knee_torque", "takeoff_in_push"}
    assert FC.CONSTRAINTS == FC.constraints(FC.CONSTRAINT_PHASE) and FC.CONSTRAINT_PHASE == "takeoff"
    assert all(b == (("<=", 520e6) if "stress" in k else ("<=", 1.0) if k == "takeoff_in_push" else ("<=", 77.0)) for k, b in FC.CONSTRAINTS.items())
    with pytest.raises(pl.ModelError, match="phase 'landing'.*takeoff"):
        FC.constraints("landing")
    with pytest.raises(pl.ModelError, match="law_stiffness.*law_t_push"):
        FC.codesign_study(4, 2, "prbm", space={"law_stiffness": (1.0, 2.0)})
    with pytest.raises(pl.ModelError, match="objective 'mass'"):
        FC.optimise_law(4, 2, objective="mass")
    with pytest.raises(pl.ModelError, match="n_trials = 4.*batch = 4"):
        FC.optimise_law(4, 2, n_trials=4, batch=4)


def test_law_shape_is_the_step_from_the_squat():
    sh = FC.law_shape(0.25, -20 * deg, 40 * deg)
    assert sh["stroke_hip_deg"] == pytest.approx(30.0) and sh["stroke_knee_deg"] == pytest.approx(-60.0)
    assert sh["speed_knee_dps"] == pytest.approx(1.5 * -60.0 / 0.25)  # cubic STEP: peak speed 1.5 Δθ / T at mid-push


def test_reduced_codesign_binds_and_beats_the_hand_law(tmp_path):
    space = {"law_t_push": (0.20, 0.32), "law_extend_knee": (30.0 * deg, 50.0 * deg)}
    r = FC.optimise_law(4, 2, "prbm", space=space, n_trials=8, batch=4, start=4, polish=4, reference={}, store=tmp_path)
    assert r["feasible"] and r["ref_feasible"]
    # the hand law (0.30 s to (−20°, 40°)) is within the limits and lower: the optimiser must find a faster push
    assert r["height_mm"] > 1.5 * r["ref_height_mm"], r
    assert r["stress_MPa"] <= 520.0 and r["peak_hip_Nm"] <= 77.0 and r["peak_knee_Nm"] <= 77.0
    # the stress up to take-off is the active limit (8 trials: within 5 % of 520 MPa; the full runs report 2 %)
    assert r["stress_MPa"] >= 0.95 * 520.0, r
    assert r["peak_hip_Nm"] <= r["peak_hip_all_Nm"] and r["peak_knee_Nm"] <= r["peak_knee_all_Nm"]  # take-off ⊂ the run


def test_report_lines_are_computed_from_the_codesign_rows(monkeypatch, tmp_path):
    """The FLEGX study report's co-design lines and table carry the run's numbers (none frozen)."""
    from proleg.papers import flegx_report

    def fake(configurations, cases, lm, **kw):
        assert kw["n_trials"] == flegx_report.CODESIGN_TRIALS and kw["reference"] == {}
        return pd.DataFrame([{
            "configuration": c, "link_case": 2, "paper_mass_kg": 8.0, "total_mass_kg": 8.0 + c, "paper_jump_mm": 100.0 + c,
            "paper_stress_MPa": 520.0, "height_mm": 50.0 + 10 * c, "jump_mm": 60.0 + 10 * c, "stress_MPa": 500.0 + c,
            "peak_hip_Nm": 60.0, "peak_knee_Nm": 77.0, "t_push_s": 0.2 + 0.01 * c, "extend_hip_deg": -20.0, "extend_knee_deg": 40.0,
            "binding": "peak_knee_torque_takeoff", "history_mm": "40.0 50.0", "converged": False, "ref_height_mm": 30.0,
            "ref_feasible": True, "feasible": True} for c in configurations])

    monkeypatch.setattr(FC, "optimise_table_i", fake)
    extra = []
    head, tab = flegx_report._codesign_section(tmp_path, (1, 2), extra)
    assert "No. 2 > No. 1" in head and "paper No. 2 > No. 1" in head
    assert "push 0.220 s to (-20.0°, 40.0°) → foot clearance 70.0 mm (guide rise 80.0 mm) at 502 MPa" in extra[1]
    assert "binding: peak_knee_torque_takeoff" in extra[1] and "not converged" in extra[1]
    assert list(tab["co-designed foot clearance [mm]"]) == [60.0, 70.0] and list(tab["mass [kg]"]) == [9.0, 10.0]
    assert (tmp_path / "codesign.parquet").exists()
