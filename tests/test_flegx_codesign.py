"""FLEGX jump law as design variables (issue 30, proleg.papers.flegx_codesign).

- The design law (``MotionLaw(design=True)``: push duration and extended pose read from the
  System) imposes the same joint motions as the hand law it starts from, and, after
  ``with_params(law_t_push=..., law_extend_knee=...)``, the same as a hand law built with those
  values: Φ(q, t) of the assembled systems agree to rounding at times through squat, push and
  retraction (no simulation: Φ is where a motion law enters).
- The reduced co-design's bookkeeping (:func:`push_at_limits`) on a synthetic grid: the
  binding constraint is the one whose slack reaches zero at the longest push, and the optimum
  is interpolated there.
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
                         "max_stress": 600e6, "peak_hip_torque": 40.0, "peak_knee_torque": 77.0 * (1 + 2 * (0.225 - tp)),
                         "take_off_time": 1.3, "foot_clearance": 0.05, "tip_displacement": 0.01})

    class FakeStudy:
        def evaluate(self, table, **kw):
            return rows.copy()

    monkeypatch.setattr(FC, "codesign_study", lambda *a, **k: (FakeStudy(), MotionLaw(design=True)))
    out = FC.push_at_limits(3, 2, pushes=tuple(tp))
    assert out["binding"] == "peak_knee_torque" and out["monotone"]
    assert out["t_push_s"] == pytest.approx(0.225, abs=1e-12)
    assert out["jump_mm"] == pytest.approx(1e3 * (0.5 - 0.225), abs=1e-9)
    assert out["stress_takeoff_MPa"] < 520.0


def test_report_sentences_are_computed_from_the_codesign_rows(monkeypatch, tmp_path):
    """The FLEGX study report's co-design lines carry the run's numbers (none frozen)."""
    from proleg.papers import flegx_report

    def fake(c, case, lm, store=None):
        return {"configuration": c, "link_case": case, "link_model": lm, "paper_jump_mm": 100.0 + c, "paper_stress_MPa": 520.0,
                "grid": None, "jump_mm": 50.0 + 10 * c, "stress_takeoff_MPa": 500.0 + c, "peak_hip_Nm": 60.0, "peak_knee_Nm": 77.0,
                "t_push_s": 0.2 + 0.01 * c, "binding": "peak_knee_torque"}

    monkeypatch.setattr(FC, "push_at_limits", fake)
    extra = []
    head = flegx_report._codesign_section(tmp_path, (1, 2), extra)
    assert "No. 2 > No. 1" in head and "paper No. 2 > No. 1" in head
    assert "push 0.220 s → 70.0 mm at 502 MPa" in extra[1] and "binding: peak_knee_torque" in extra[1]
    assert (tmp_path / "codesign.parquet").exists()
