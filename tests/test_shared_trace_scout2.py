"""Scout II designs share one trace (issue 42, item 3: builders pass derived numbers through params).

The Scout II builder's drives (gear and belt ratios and efficiencies, motor constants, amplifier
and battery numbers, the Model II belt stage's losses) reach the trace as ``joint_actuator_drive_*``
and ``joint_actuator_belt_*`` parameters, and the bounding controller's retraction law reads its
Eq. 4 / Eq. 6 numbers as design variables (``retraction_*``), so two designs with another gear
ratio, motor or leg length are one structure whose physics reads no number outside ``params``;
a run of the second design on the first one's executables equals a compile of its own.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from test_shared_trace import RTOL, _check_builder, cache  # noqa: F401 (cache is a fixture)

import proleg as pl
import proleg.compile_cache as cc
from proleg.drives.dcmotor import DCMotorDrive

#: another drive (gear ratio, motor constants, armature resistance, peak current) and leg length
OTHER = dict(drive=DCMotorDrive(gear_ratio=60.0, K_T=0.045, K_omega=0.045, R_a=1.0, i_max=22.0), leg_length=0.31, height=0.34)

#: 0.1 s from the standing start: the 3 cm drop (78 ms) and touchdown, so the toes' contact, the
#: legs' springs and stops and the controller's flight → retraction switch all run
T_END = 0.1


def _run(model):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return pl.simulate(pl.assemble(model), t_end=T_END, dt_output=0.01, progress=False)


def _alone(model, monkeypatch):
    """``model`` run with sharing off (a compile of its own)."""
    with monkeypatch.context() as m:
        m.setenv("PROLEG_SHARE_STRUCTURES", "0")
        cc.clear()
        return _run(model)


def _answer(result):
    a = result.actuator("front_motor")
    return {"q": np.asarray(result.q), "effort": np.asarray(a["effort"]), "current": np.asarray(a["current"])}


@pytest.mark.parametrize("variant", ["I", "II"])
def test_two_scout2_designs_are_one_structure_and_read_only_params(variant):
    """Another drive and leg length: the same structure key, and ``numbers_read`` is empty (the
    drives' numbers and the retraction law's are parameters, and they differ)."""
    _check_builder(lambda: pl.robots.scout2(variant), lambda: pl.robots.scout2(variant, **OTHER))
    a, b = pl.assemble(pl.robots.scout2(variant)), pl.assemble(pl.robots.scout2(variant, **OTHER))
    for k in ("joint_actuator_drive_gear_ratio", "joint_actuator_drive_K_T", "variable_retraction_tau_max"):
        assert not np.array_equal(np.asarray(a.params[k]), np.asarray(b.params[k])), k
    if variant == "II":  # the belt stage's no-load drag scales with the drive's full torque
        assert not np.array_equal(np.asarray(a.params["joint_actuator_belt_drag"]), np.asarray(b.params["joint_actuator_belt_drag"]))


# Model II's run (belt stage, leg friction) adds ~50 s of compile to the fast suite: slow; its
# structure and params test above stays fast.
@pytest.mark.parametrize("variant", ["I", pytest.param("II", marks=pytest.mark.slow)])
def test_a_second_scout2_design_runs_on_the_first_ones_executables(cache, monkeypatch, variant):
    """The default design compiles; the second (another drive and leg length) is decided once and
    then exports nothing; its answer equals a compile of its own to round-off (RTOL of
    test_shared_trace), and differs from the first design's (the numbers are used)."""
    first = _answer(_run(pl.robots.scout2(variant)))
    exported = cc.stats["exported"]
    shared = cc.stats["shared"]
    second = _answer(_run(pl.robots.scout2(variant, **OTHER)))
    assert cc.stats["exported"] == exported, cc.stats.get("why_not_shared")
    assert cc.stats["shared"] > shared
    assert np.max(np.abs(first["q"][-1] - second["q"][-1])) > 1e-3
    ref = _answer(_alone(pl.robots.scout2(variant, **OTHER), monkeypatch))
    for k in second:
        np.testing.assert_allclose(second[k], ref[k], rtol=RTOL, atol=RTOL * max(1.0, np.max(np.abs(ref[k]))), err_msg=k)
