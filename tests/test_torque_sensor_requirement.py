"""The torque sensor to its requirement (issue 30 item 4): the spoke FE against Euler–Bernoulli,
the gauge position and envelope parameters, the reduced optimisation and the Pareto front.

The full FE optimisation runs in ``proleg run torque-sensor-study`` and
bench/torque_sensor_requirement.py; here the reduced problem runs on the closed form that the
first test checks against the FE.
"""

import math

import pytest

from proleg.errors import ModelError
from proleg.papers.sensor_requirement import (REQUIREMENT, SPOKE_SPACE, constraints_of, optimize_to_requirement,
                                              pareto_front)
from proleg.robots.sensor_beam import spoke_beam
from proleg.robots.torque_sensor import sensor_design

SLENDER = dict(n_spokes=4, spoke_width=0.0025, thickness=0.004, r_hub=0.010, r_ring=0.034, fillet=0.0,
               gauge_position=0.3)


def test_spoke_fe_against_euler_bernoulli():
    """Four slender spokes (L/w = 9.6), sharp corners, 4 mm mesh. The gauge strain at a given torque
    follows from the moment line, which is nearly statically fixed: FE and beam agree within 2 %
    (measured 1.0 %, and 0.9 % at 3 mm). The FE stiffness is below Euler–Bernoulli by what the beam
    omits: shear (2 (1 + nu) / kappa (w/L)^2 = 3.5 % of the compliance) and the elastic rotation of
    the roots in hub and ring; measured 0.856 of it at 4 mm and 0.848 at 3 mm (converged to 1 %),
    hence the window 0.80..0.90. A wrong lever (F a omitted: 0.64) or beam length falls outside."""
    from proleg.robots.sensor_fe import torque_sensor_analysis

    fe = torque_sensor_analysis("spokes", mesh_size=0.004, stress_stiffening=False, cases=("A",),
                                geometry_checks=False, **SLENDER).metrics
    eb = spoke_beam(140.0, **SLENDER)
    assert fe["gauge_strain"] == pytest.approx(eb["gauge_strain"], rel=0.02)
    assert 0.80 < fe["stiffness"] / eb["stiffness"] < 0.90
    assert fe["reaction_torque_error"] < 1e-6


def test_beam_closed_form_limits():
    """k = 4 n E I (3a^2 + 3aL + L^2) / L^3: a hub of zero radius leaves the clamped-guided beam
    4 E I / L per spoke; the inflection sits at 2L/3 then and moves to L/2 as a/L grows."""
    E, t, w, L = 71.7e9, 0.004, 0.0025, 0.024
    I = t * w**3 / 12
    m = spoke_beam(140.0, E=E, **{**SLENDER, "r_hub": 1e-9, "r_ring": L, "n_spokes": 1})
    assert math.radians(1) * 4 * E * I / L == pytest.approx(m["stiffness"], rel=1e-6)
    assert m["inflection"] == pytest.approx(2 * L / 3, rel=1e-6)
    assert spoke_beam(140.0, **{**SLENDER, "r_hub": 10.0, "r_ring": 10.0 + L})["inflection"] == pytest.approx(L / 2, rel=1e-3)


def test_gauge_position_and_envelope_are_parameters():
    near = sensor_design("spokes", 0.004, gauge_position=0.0).gauges[0].center
    far = sensor_design("spokes", 0.004, gauge_position=1.0).gauges[0].center
    assert far[0] - near[0] > 0.005  # the grid moves along the spoke, towards the ring
    with pytest.raises(ModelError, match="gauge_position"):
        sensor_design("spokes", 0.004, gauge_position=1.5)
    with pytest.raises(ModelError, match="r_out"):
        sensor_design("spokes", 0.004, r_out=0.044)
    sensor_design("spokes", 0.004, r_out=0.044, envelope=dict(r_out=0.045))  # a larger drive flange admits it
    with pytest.raises(ModelError, match="envelope"):
        sensor_design("spokes", 0.004, envelope=dict(diameter=0.09))


def test_reduced_optimisation_meets_the_requirement():
    """CMA-ES over the closed form (200 trials, ~4 s): the optimum twists 0.2..3 deg at 140 N m (the
    accepted range), with gauge strain 0.02..0.06 % and safety factor >= 1. Either the twist target
    (1 deg +- 10 %) is met, or a constraint binds, and the one reported binding is active."""
    r = optimize_to_requirement(n_trials=200, model="beam", batch=8)
    b, req = r.best, REQUIREMENT
    assert req["twist_min"] <= b["twist"] <= req["twist_max"]
    assert req["min_gauge_strain"] <= b["gauge_strain"] <= req["max_gauge_strain"]
    assert b["safety_factor"] >= req["safety"]
    assert r.feasible
    cons = constraints_of(req)
    named = [c for c in r.binding if c in cons]
    for c in named:
        assert 0.0 <= r.slack[c] <= 0.02  # active: within 2 % of its bound
    assert r.target_met or named
    # the closed form reaches the target: 1 deg within 10 %, and the design uses the envelope
    assert r.target_met and abs(b["twist"] - 1.0) < 0.1
    assert b["thickness"] > 0.9 * SPOKE_SPACE["thickness"][1]


def test_pareto_front_with_the_gauge_at_the_peak():
    """Seed 001's rule (gauge where the strain is largest): the most compliant spoke sensor that
    keeps the gauge <= 0.06 % is far stiffer than 700 N m/deg (0.2 deg at 140 N m) -- why the
    optimiser moves the gauge towards the spoke's inflection."""
    samples, front = pareto_front(1500)
    assert len(front) >= 5
    assert (front.stiffness.diff().dropna() < 0).all() and (front.gauge_strain.diff().dropna() > 0).all()
    at_limit = front[front.gauge_strain <= REQUIREMENT["max_gauge_strain"]]
    assert at_limit.stiffness.min() > 140.0 / REQUIREMENT["twist_min"]


@pytest.mark.parametrize("kw, match", [
    (dict(model="shell"), "model"),
    (dict(requirement=dict(twist_target=5.0)), "twist_target"),
    (dict(requirement=dict(torque=-1.0)), "torque"),
    (dict(requirement=dict(strain=1e-3)), "strain"),
    (dict(n_trials=4), "n_trials"),
])
def test_bad_requirement_options(kw, match):
    with pytest.raises(ModelError, match=match):
        optimize_to_requirement(**{"model": "beam", **kw})
