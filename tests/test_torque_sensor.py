"""Torque sensor FE study (issue 17): equilibrium, mirror symmetry, closed form, bad geometry.

Coarse meshes keep these fast; the default-mesh numbers and the convergence study live in the
scenario (proleg run torque-sensor-study) and bench/torque_sensor.py.
"""

import math

import numpy as np
import pytest

from proleg.errors import ModelError
from proleg.fem import material
from proleg.robots.sensor_fe import torque_sensor_analysis
from proleg.robots.torque_sensor import sensor_design

AL = material("ergal")


@pytest.fixture(scope="module")
def hollow():
    return torque_sensor_analysis("hollow", mesh_size=0.004)


def test_hollow_tube_matches_torsion_theory_and_balances(hollow):
    m = hollow.metrics
    d = hollow.design.dims
    ro, ri, L = d["r_out"], d["r_out"] - d["wall"], d["length"]
    J = math.pi / 2 * (ro**4 - ri**4)
    assert m["twist"] == pytest.approx(math.degrees(140.0 * L / (AL.G * J)), rel=0.02)
    # gauge at 45 deg on the surface: eps = gamma / 2 = T r / (2 G J)
    assert m["gauge_strain"] == pytest.approx(140.0 * ro / (2 * AL.G * J), rel=0.03)
    assert m["reaction_torque_error"] < 1e-6  # the fixed face carries the applied torque back
    assert not m["gauge_planar"]  # curved surface under the grid
    assert not m["strain_in_range"]  # too little strain: the paper's verdict on the hollow cylinder


def test_cw_and_ccw_mirror_for_a_symmetric_design(hollow):
    g = hollow.gauges.set_index(["case", "gauge", "direction"])["strain"].unstack()
    # mirror plane through the axis: CW = -CCW up to the mesh's asymmetry (3e-4 at this mesh)
    assert np.allclose(g["CW"], -g["CCW"], rtol=1e-3, atol=0)
    # the bridge averages the four gauges: the mesh asymmetry cancels (2.6e-7 at this mesh)
    assert hollow.metrics["calibration_mismatch"] < 1e-5


def test_tension_links_equilibrium_and_bidirectionality():
    r = torque_sensor_analysis("tension_links", mesh_size=0.005, refine_gauges=False)
    m = r.metrics
    assert m["reaction_torque_error"] < 1e-6
    assert m["gauge_planar"]
    assert not m["gauge_reachable"]  # planar but the ring is too close (seed 001, third concept)
    # links stretched one way, compressed the other: the stress-stiffened response differs
    assert 1e-3 < m["calibration_mismatch"] < 0.2
    assert m["safety_factor"] > 1.0
    # rigid interfaces: case B (motor side fixed, torque on the ring) is case A with the opposite
    # relative rotation plus a rigid rotation: opposite gauge strains. Linear theory makes them
    # exact; the geometric stiffness also acts on the rigid rotation of the prestressed part, a
    # second-order difference (1.4 % at this mesh)
    g = r.gauges.set_index(["case", "direction", "gauge"])["strain"]
    assert np.allclose(g.loc["B"], -g.loc["A"], rtol=0.03, atol=0)
    assert not np.allclose(g.loc["B"], -g.loc["A"], rtol=1e-3, atol=0)


@pytest.mark.parametrize("concept, dims, match", [
    ("spokes", dict(r_hub=0.031), "r_ring"),  # hub beyond the ring: self-intersection
    ("open_links", dict(neck_width=0.008), "neck_width"),  # neck wider than the link
    ("open_links", dict(r_link=0.016), "r_link"),  # link outside the hub
    ("tension_links", dict(link_width=0.0015), "link_width"),  # wall thinner than half the mesh
    ("hollow", dict(wall=0.0015), "wall"),
    ("spokes", dict(r_out=0.05), "r_out"),  # outside the envelope
    ("open_links", dict(neck_length=0.0055), "free length"),  # neck + the end mill's arcs longer than the link
    ("final", dict(spoke_width=0.008), "spoke_width"),  # the final concept is a spoke sensor: 8 spokes overlap
])
def test_bad_geometry_names_the_parameter(concept, dims, match):
    with pytest.raises(ModelError, match=match):
        sensor_design(concept, 0.004, **dims)


def test_zero_torque_is_refused():
    with pytest.raises(ModelError, match="torque"):
        torque_sensor_analysis("final", torque=0.0)


@pytest.mark.parametrize("kw, match", [
    (dict(interface="glued"), "interface"),
    (dict(cases=("B",)), "cases"),
    (dict(mesh_size=-0.001), "mesh_size"),
    (dict(concept="bellows"), "bellows"),
    (dict(link_width=0.005), "link_width"),  # a dimension of another concept
    (dict(neck_width=0.005), "open_links"),  # the final concept before issue 44: the error names its new name
])
def test_bad_analysis_options_name_the_parameter(kw, match):
    with pytest.raises(ModelError, match=match):
        torque_sensor_analysis(**{"concept": "final", **kw})


def test_bad_optimisation_options():
    from proleg.papers.sensor_study import optimize_sensor

    with pytest.raises(ModelError, match="n_trials"):
        optimize_sensor(n_trials=0)
    with pytest.raises(ModelError, match="workers"):
        optimize_sensor(n_trials=1, workers=0)


@pytest.mark.slow
def test_optimisation_is_resumable(tmp_path):
    """Two calls on one store: the second continues the first's study (each trial an FE solve) and
    re-solves nothing that the Parquet store already holds."""
    from proleg.study import Store
    from proleg.papers.sensor_study import optimize_sensor

    store = tmp_path / "opt"
    first = optimize_sensor(store, n_trials=1, workers=1, search_mesh=0.006)
    assert len(first.rows) == 1 and first.best["trial"] == 0
    assert first.best["feasible"]  # trial 0 is the default design: inside the gauge range, elastic, reachable
    assert 2e-4 < first.best["gauge_strain"] <= 6e-4
    again = optimize_sensor(store, n_trials=2, workers=1, search_mesh=0.006)
    assert len(again.study.trials) == 2 and len(again.rows) == 2
    assert len(Store(store).read()) == 2  # trial 0 read back from the store, not solved again
    assert again.rows.gauge_strain.iloc[0] == first.rows.gauge_strain.iloc[0]


def test_swept_mesh_bad_input():
    from proleg.fem.mesh import mesh_extruded

    def ball(occ):
        occ.addSphere(0, 0, 0.01, 0.005)  # no planar face at z = 0 to sweep

    with pytest.raises(ModelError, match="no planar face at z = 0"):
        mesh_extruded(ball, 0.003, 0.01)
    with pytest.raises(ModelError, match="thickness"):
        mesh_extruded(ball, 0.003, 0.0)
