"""``integrator="auto"`` on smooth closed loops (issue 43, item 2): Radau5 on joint coordinates,
at rtol 1e-6 when no tolerance is asked for, so that the error rule of solvers/auto.py (a smooth
model's global error over a few tens of periods within about 100× rtol) holds for loops too.

The generalized-α method that ran before is second order: on bench/closed_loops_defaults.py's
ladder of 6 parallelogram loops its phase error at its defaults (rtol 1e-6) reached 4.8e-3 m
after 30 s (27 periods), 48× over the bound (bench/results/closed_loops_defaults.md)."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

import proleg as pl
from proleg.solvers.auto import LOOPS_RTOL, JointRadau5

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "bench"))

from closed_loops_defaults import ladder_error, ladder_system  # noqa: E402


@pytest.fixture(scope="module")
def ladder():
    return ladder_system()


def test_smooth_loops_get_radau5_on_joint_coordinates(ladder):
    ig, why = pl.Auto().choose(ladder, 10.0)
    assert type(ig) is JointRadau5 and isinstance(ig, pl.Radau5)
    assert (ig.rtol, ig.atol) == (LOOPS_RTOL, LOOPS_RTOL / 10) == (1e-6, 1e-7)
    assert "closed loops" in why and "no tolerance asked for" in why and "joint coordinates" in why
    assert ig.describe() == "Radau5(rtol=1e-06, atol=1e-07) on joint coordinates"
    ig, why = pl.Auto(rtol=1e-8).choose(ladder, 10.0)
    assert type(ig) is JointRadau5 and (ig.rtol, ig.atol) == (1e-8, 1e-9) and "rtol 1e-08 asked for" in why
    # other coordinates named: Radau5 on them with a tolerance, else the α-method (which says its limit)
    ig, why = pl.Auto(rtol=1e-8).choose(ladder, 10.0, coordinates="planar")
    assert type(ig) is pl.Radau5
    ig, why = pl.Auto().choose(ladder, 10.0, coordinates="planar")
    assert isinstance(ig, pl.GeneralizedAlpha) and "phase error grows" in why
    # an α-method option still selects the α-method
    assert isinstance(pl.Auto(max_newton=5).choose(ladder, 10.0)[0], pl.GeneralizedAlpha)


def test_ladder_at_the_defaults_keeps_the_error_rule(ladder):
    """The 6-loop ladder, 10 s (~9 periods) with nothing asked for: every part's centre of mass
    within 100 × rtol = 1e-4 m of the exact motion (bench/results/closed_loops_defaults.md: 3e-7
    m after 30 s; the α-method at its defaults was 1.7e-3 m off after 10 s)."""
    r = pl.simulate(ladder, t_end=10.0, dt_output=0.05, progress=False)
    assert r.ok and r.coordinates == "joint" and r.stats["integrator"].startswith("Radau5(rtol=1e-06")
    end, worst = ladder_error(r)
    assert worst <= 100 * LOOPS_RTOL, (end, worst)
