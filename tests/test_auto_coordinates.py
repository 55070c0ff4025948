"""coordinates="auto" (assembly/coordinates.py ``auto_coordinates``): planar where the joints confine
every part to a plane; joint coordinates for a loop-free tree on a floating base (a legged robot:
bench/results/whole_robot.md); else absolute (joint coordinates measured slower including
compile on models without a floating base, bench/coordinates.py). The rule is read from the
topology, coordinate_set follows it, and ``integrator="auto"`` (solvers/auto.py) gives a
floating-base tree with contacts generalized-α with the Newton matrix reused, and a smooth one
Tsit5 (its quaternion normalisation is no closed loop)."""

import math
import warnings

import numpy as np
import pytest
from test_core_fourbar import build as four_bar
from test_joint_coordinates import floating_chain
from test_planar import chain

import proleg as pl
from proleg.assembly.coordinates import auto_coordinates, coordinate_set
from proleg.errors import ProlegWarning


def heavy_top():
    """A top on a spherical joint: not planar, a cut joint in joint coordinates."""
    model = pl.Model("top", gravity=(0.0, 0.0, -9.81))
    top = model.add_part("top", mass=1.0, inertia=(0.004, 0.004, 0.008), position=(0.1 * math.sin(0.3), 0.0, 0.1 * math.cos(0.3)))
    model.add_joint(pl.Spherical("tip", top, model.ground, at=(0.0, 0.0, 0.0)))
    return model


def walker(contacts=True, loop=False):
    """A floating trunk with two 2-link legs on revolutes about crossed axes (not planar), foot
    spheres with friction and PD servos: the shape of a legged robot. ``loop`` ties the two
    feet with a spherical joint (a closed loop through the trunk)."""
    model = pl.Model("walker", gravity=(0.0, 0.0, -9.81))
    trunk = model.add_part("trunk", mass=4.0, inertia=(0.02, 0.05, 0.05), position=(0.0, 0.0, 0.4))
    for side, y in (("l", 0.1), ("r", -0.1)):
        hip = model.add_part(f"{side}_thigh", mass=0.5, inertia=(0.002, 0.002, 0.0005), position=(0.0, y, 0.3))
        shank = model.add_part(f"{side}_shank", mass=0.3, inertia=(0.001, 0.001, 0.0002), position=(0.0, y, 0.12))
        model.add_joint(pl.Revolute(f"{side}_hip", hip, trunk, at=(0.0, y, 0.4), axis=(1.0, 0.0, 0.0)))
        model.add_joint(pl.Revolute(f"{side}_knee", shank, hip, at=(0.0, y, 0.2), axis=(0.0, 1.0, 0.0)))
        foot = model.add_marker(shank, f"{side}_foot", position=(0.0, y, 0.02))
        if contacts:
            model.add_contact(pl.SphereContact(f"{side}_foot.contact", foot, radius=0.02, mu_static=0.8, mu_dynamic=0.8, v_stiction=0.1, v_friction=1.0))
            for j in (f"{side}_hip", f"{side}_knee"):
                model.add_controller(pl.PID(f"{j}.servo", j, kp=50.0, kd=1.0, setpoint=0.0, period=1e-3))
    if loop:
        model.add_joint(pl.Spherical("tie", model.part("l_shank"), model.part("r_shank"), at=(0.0, 0.0, 0.1)))
    return model


def bushing_block():
    """One free part held by a bushing only: its joint coordinates would be its absolute ones."""
    model = pl.Model("bushing_block", gravity=(0.0, 0.0, -9.81))
    part = model.add_part("block", mass=1.0, inertia=(0.01, 0.02, 0.02), position=(0.2, 0.0, 0.0))
    mi = model.add_marker(part, "i", position=(0.0, 0.0, 0.0))
    mj = model.add_marker(model.ground, "j", position=(0.0, 0.0, 0.0))
    model.add_force(pl.Bushing("mount", mi, mj, stiffness=(1e5, 1e5, 1e5, 1e3, 1e3, 1e3)))
    return model


@pytest.mark.filterwarnings("ignore:.*redundant")
@pytest.mark.parametrize(
    "build, expected",
    [(lambda: chain(3), "planar"), (four_bar, "planar"), (floating_chain, "joint"), (heavy_top, "absolute"),
     (walker, "joint"), (lambda: walker(loop=True), "absolute"), (bushing_block, "absolute")],
    ids=["chain3", "four_bar", "floating_chain", "heavy_top", "walker", "walker_loop", "bushing_block"],
)
def test_auto_picks_what_the_rule_says(build, expected):
    system = pl.assemble(build())
    kind, why = auto_coordinates(system)
    assert kind == expected and why
    assert coordinate_set(system, system.params["q_init"], "auto").kind == expected


def test_auto_integrator_for_floating_base_trees():
    """The table's floating-base rows: contacts and servos → generalized-α with the Newton matrix
    reused (said in the reason); a smooth free
    flight → Tsit5 at its defaults (the normalisation row is no loop); a tolerance or another
    coordinate set asked for is kept."""
    ig, why = pl.Auto().choose(pl.assemble(walker()), 1.0)
    assert isinstance(ig, pl.GeneralizedAlpha) and ig.jacobian_reuse and ig.error_on == "positions"
    assert "floating-base tree" in why and "reused" in why and "joint coordinates" in why
    ig, _ = pl.Auto(rtol=1e-8, jacobian_reuse=False).choose(pl.assemble(walker()), 1.0)
    assert isinstance(ig, pl.GeneralizedAlpha) and ig.rtol == 1e-8 and not ig.jacobian_reuse
    ig, why = pl.Auto().choose(pl.assemble(walker()), 1.0, coordinates="absolute")
    assert isinstance(ig, pl.GeneralizedAlpha) and not ig.jacobian_reuse  # absolute asked for: the rule of other models
    ig, why = pl.Auto().choose(pl.assemble(walker(contacts=False)), 1.0)
    assert isinstance(ig, pl.Tsit5) and ig.rtol == 1e-7 and "loop-free tree" in why
    ig, why = pl.Auto().choose(pl.assemble(walker(contacts=False, loop=True)), 1.0)
    assert isinstance(ig, pl.Radau5) and "tie" in why and "joint coordinates" in why  # smooth loops (issue 43)


def test_walker_runs_at_the_defaults_in_joint_coordinates():
    """0.1 s of the walker dropping 1 cm onto its feet at the defaults: joint coordinates, the
    α-method with reuse, and the same answer as absolute coordinates with a fresh Newton matrix
    every step (both at rtol 1e-6: positions within 1e-4 m, the α-method's error at that
    tolerance over a touchdown)."""
    model = walker()
    system = pl.assemble(model)
    ra = pl.simulate(system, 0.1, 0.01, progress=False)
    assert ra.coordinates == "joint" and ra.integrator.jacobian_reuse, ra.stats["integrator_reason"]
    rb = pl.simulate(system, 0.1, 0.01, progress=False, coordinates="absolute", integrator=pl.GeneralizedAlpha())
    assert rb.coordinates == "absolute"
    assert ra.stats["jacobians"] < ra.stats["steps"]
    np.testing.assert_allclose(np.asarray(ra.q)[:, :3], np.asarray(rb.q)[:, :3], atol=1e-4)


def _fake_result(steps, rejected):
    class R:
        stats = {"steps": steps, "rejected": rejected}

    return R()


def test_stick_slip_warning_names_the_contacts_once():
    """Many rejected steps with a friction contact: one ProlegWarning naming the contacts and the
    transition velocities; few rejections, or no friction, stay silent (the check reads the
    driver's step counters only)."""
    from proleg.analyses.simulate import _warn_stick_slip

    system = pl.assemble(walker())
    with pytest.warns(ProlegWarning, match=r"l_foot\.contact.*v_stiction 0\.1") as rec:
        _warn_stick_slip(system, _fake_result(1000, 900))
    assert len([w for w in rec if issubclass(w.category, ProlegWarning)]) == 1
    with warnings.catch_warnings():
        warnings.simplefilter("error", ProlegWarning)
        _warn_stick_slip(system, _fake_result(1000, 50))
        _warn_stick_slip(pl.assemble(walker(contacts=False)), _fake_result(1000, 900))
