"""HyQ jump (robots/hyq_jump.py, papers/hyq_jump.py): the limit diagnostics against constructed
samples (fast), the model's design variables, and on the whole robot (slow: one vmapped compile
of the hydraulic jump, several minutes on 2 cores) the check that the limit the jump names is
the one that binds. The designed jump's figures are ``proleg run hyq-jump``."""

import numpy as np
import pytest

pytest.importorskip("yourdfpy", reason="yourdfpy is not installed: pip install -e .[test]")

from proleg.errors import ModelError  # noqa: E402
from proleg.robots.hyq_jump import LIMIT_SHARE, jump_limits  # noqa: E402

PS = 16e6
RATING = 140.0


def _samples(nt=100, n=8):
    """A push with nothing at a limit: torques at half the rating, spool at half, the fed chamber
    at 0.7 p_s and the other at 0.3 p_s."""
    return (np.full((nt, n + 4), 0.5 * RATING), np.full((nt, n), 0.5), np.full((nt, n), 0.7 * PS), np.full((nt, n), 0.3 * PS))


def test_jump_limits_names_each_limit():
    """Each limit is named when it alone is active in a share of the push above LIMIT_SHARE: the
    torque reference at the rating; the whole supply pressure across a piston (fed chamber
    ≥ 0.9 p_s, the other ≤ 0.1 p_s: pressure), whether or not the spool is at its stop; the
    spool at its stop with a large valve drop (flow)."""
    tau, xv, pf, po = _samples()
    assert jump_limits(tau, xv, pf, po, PS, RATING)["limit"] == "none"
    k = slice(0, 30)  # 30 % of the push
    t2 = tau.copy()
    t2[k, 1] = -RATING
    m = jump_limits(t2, xv, pf, po, PS, RATING)
    assert m["limit"] == "torque" and m["share_torque"] == pytest.approx(0.3) and m["share_pressure"] == m["share_flow"] == 0.0
    x2, f2, o2 = xv.copy(), pf.copy(), po.copy()
    f2[k, 3], o2[k, 3] = 0.95 * PS, 0.0
    m = jump_limits(tau, x2, f2, o2, PS, RATING)
    assert m["limit"] == "pressure" and m["share_pressure"] == pytest.approx(0.3) and m["share_flow"] == 0.0
    x2[k, 3] = 1.0  # the spool at its stop too: still pressure
    assert jump_limits(tau, x2, f2, o2, PS, RATING)["limit"] == "pressure"
    f2[k, 3], o2[k, 3] = 0.6 * PS, 0.3 * PS  # spool at its stop across a large drop: flow
    m = jump_limits(tau, x2, f2, o2, PS, RATING)
    assert m["limit"] == "flow" and m["share_flow"] == pytest.approx(0.3) and m["share_pressure"] == 0.0
    # every limit above LIMIT_SHARE is named, largest first; below it nothing is
    x2[:60, 5] = -1.0
    assert jump_limits(t2, x2, f2, o2, PS, RATING)["limit"] == "flow+torque"
    # a hydraulic joint at the rating whose spool is at its stop is flow-limited, not torque-limited
    x4, t4 = xv.copy(), tau.copy()
    x4[k, 2], t4[k, 2] = 1.0, RATING
    m = jump_limits(t4, x4, pf, po, PS, RATING)
    assert m["limit"] == "flow" and m["share_torque"] == 0.0
    few = int(LIMIT_SHARE * 100) - 1
    t3 = tau.copy()
    t3[:few, 0] = RATING
    assert jump_limits(t3, xv, pf, po, PS, RATING)["limit"] == "none"
    # torque sources: no hydraulic columns
    assert jump_limits(t2, np.zeros((100, 0)), np.zeros((100, 0)), np.zeros((100, 0)), 1.0, RATING)["limit"] == "torque"


def test_jump_model_variables_and_errors():
    """The push's law, the rating, the supply and the valve are model variables (a study changes
    them without recompiling); bad settings raise at build time."""
    import proleg as pl
    from proleg.robots.hyq_jump import JumpLaw, hyq_jump_model

    model = hyq_jump_model(JumpLaw(t_push=0.2, rise=0.15))
    sys_ = pl.assemble(model)
    for k, v in (("jump_t_push", 0.2), ("jump_rise", 0.15), ("jump_torque_limit", 140.0), ("hyq_supply_pressure", PS)):
        assert float(sys_.params[f"variable_{k}"]) == pytest.approx(v)
    assert model.jump["z_stand"] - model.jump["z_c"] > 0.1  # crouched well below standing
    with pytest.raises(ModelError, match="actuators"):
        hyq_jump_model(actuators="pneumatic")
    with pytest.raises(ModelError, match="t_push"):
        hyq_jump_model(JumpLaw(t_push=0.0))


def test_binding_confirmed_and_limit_codes():
    from proleg.papers.hyq_jump import binding_confirmed, limit_code, limit_name

    for name in ("none", "torque", "pressure+flow", "flow+torque"):
        assert set(limit_name(limit_code(name)).split("+")) == set(name.split("+"))
    gains = {"torque": 0.0, "pressure": 0.032, "flow": 0.048}
    assert binding_confirmed("pressure+flow", gains) and binding_confirmed("flow+pressure", gains)
    assert not binding_confirmed("pressure", gains) and not binding_confirmed("torque", gains)


@pytest.mark.slow
def test_jump_named_limit_binds():
    """The designed jump (JUMP_DESIGN) names its limits; raising each named limit alone by 30 %
    raises the height by more than RISE_TOL (1 cm), and raising each other limit alone changes it
    by less. One vmapped batch of six variants (papers.hyq_jump.limit_check)."""
    from proleg.papers.hyq_jump import RISE_TOL, binding_confirmed, limit_check

    rows = limit_check(factor=1.3).set_index("raised")
    assert (rows["status"] == "success").all(), rows[["status", "reason"]]
    named = rows.loc["none", "limit"]
    assert named != "none"
    assert binding_confirmed(named, rows["height_gain"].to_dict()), (named, RISE_TOL, rows[["height", "height_gain", "limit"]])
