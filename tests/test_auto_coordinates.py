"""coordinates="auto" (assembly/coordinates.py ``auto_coordinates``): planar where the joints confine
every part to a plane, else absolute; never joint (measured slower including compile,
bench/coordinates.py). The rule is read from the topology, and coordinate_set follows it."""

import math

import pytest
from test_core_fourbar import build as four_bar
from test_joint_coordinates import floating_chain
from test_planar import chain

import proleg as pl
from proleg.assembly.coordinates import auto_coordinates, coordinate_set


def heavy_top():
    """A top on a spherical joint: not planar, a cut joint in joint coordinates."""
    model = pl.Model("top", gravity=(0.0, 0.0, -9.81))
    top = model.add_part("top", mass=1.0, inertia=(0.004, 0.004, 0.008), position=(0.1 * math.sin(0.3), 0.0, 0.1 * math.cos(0.3)))
    model.add_joint(pl.Spherical("tip", top, model.ground, at=(0.0, 0.0, 0.0)))
    return model


@pytest.mark.filterwarnings("ignore:.*redundant")
@pytest.mark.parametrize(
    "build, expected", [(lambda: chain(3), "planar"), (four_bar, "planar"), (floating_chain, "absolute"), (heavy_top, "absolute")],
    ids=["chain3", "four_bar", "floating_chain", "heavy_top"],
)
def test_auto_picks_what_the_rule_says(build, expected):
    system = pl.assemble(build())
    kind, why = auto_coordinates(system)
    assert kind == expected and why
    assert coordinate_set(system, system.params["q_init"], "auto").kind == expected

