"""Issue 32's friction list, as a new user met it on e754ddf: each case fails on that behaviour.

URDF placement, fixed-base contacts, the initial-penetration warning, the CLI's text and errors,
``proleg.io``/``proleg.report`` as attributes, joint columns in ``to_frame``, the viewer without
``--model``, the "compiling" progress label, "did you mean" over public names, roll-pitch-yaw in
YAML and the JAX-settings opt-out.
"""

import math
import warnings
from pathlib import Path

import numpy as np
import pytest

import proleg as pl
from proleg.errors import ModelError, ProlegWarning
from proleg.io.urdf import UrdfWarning, load_urdf

DATA = Path(__file__).parent / "data" / "two_link.urdf"
ROOT = Path(__file__).resolve().parents[1]


def _hyq():
    try:
        from proleg.robots.hyq import hyq_urdf_path

        return hyq_urdf_path()
    except ModelError:
        pytest.skip("example-robot-data is not installed: pip install -e .[test]")


def _quiet_urdf(*a, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UrdfWarning)
        return load_urdf(*a, **kw)


# ---------------------------------------------------------------------------------------------
# 1. load_urdf places a floating base on its feet; a fixed base gets no floor
# ---------------------------------------------------------------------------------------------
def _sphere_bottoms(model):
    return np.array([c.marker.position[2] - c.radius for c in model.contacts])


def test_load_urdf_puts_the_lowest_foot_on_the_ground():
    """HyQ's trunk frame is its centre: at the old default base (0, 0, 0) the four foot spheres
    started 0.8 m below z = 0. Now the lowest foot-sphere bottom is at z = 0 (the ground plane of
    SphereContact) to round-off, and the base is lifted by exactly that depth."""
    path = _hyq()
    m = _quiet_urdf(path)
    bottoms = _sphere_bottoms(m)
    assert len(bottoms) == 4
    assert bottoms.min() == pytest.approx(0.0, abs=1e-12)
    old = _quiet_urdf(path, base_position=(0.0, 0.0, 0.0))  # explicit position: placed where asked
    depth = -_sphere_bottoms(old).min()
    assert depth > 0.7  # the buried robot of e754ddf
    np.testing.assert_allclose(m.urdf.base_pose[:3, 3], [0.0, 0.0, depth], atol=1e-12)
    # base_height overrides the automatic placement: the root-link origin's z
    m2 = _quiet_urdf(path, base_height=1.2)
    assert m2.urdf.base_pose[2, 3] == 1.2
    assert _sphere_bottoms(m2).min() == pytest.approx(1.2 - depth, abs=1e-12)
    # bent knees: still the lowest foot on the ground, the others above it
    q = {"lf_kfe_joint": -1.2, "rf_kfe_joint": -0.6}
    m3 = _quiet_urdf(path, initial_positions=q)
    b3 = _sphere_bottoms(m3)
    assert b3.min() == pytest.approx(0.0, abs=1e-12) and b3.max() > 0.01


def test_fixed_base_import_has_no_ground_contacts():
    """A welded root (an arm or a leg on a bench) has no floor unless asked for: e754ddf gave the
    two-link URDF's 'tip' a ground contact that its swing then kicked."""
    m = _quiet_urdf(DATA, floating_base=False)
    assert m.contacts == [] and m.urdf.feet == []
    asked = _quiet_urdf(DATA, floating_base=False, feet="spheres")
    assert [c.name for c in asked.contacts] == ["tip.contact"]
    with pytest.raises(ModelError, match="feet='sole'"):
        _quiet_urdf(DATA, floating_base=False, feet="sole")


# ---------------------------------------------------------------------------------------------
# 2. a contact that starts deeper than its penetration depth warns, on any model
# ---------------------------------------------------------------------------------------------
def _ball(z, angle=0.0, penetration=1e-4):
    """A 1 kg body at height ``z`` carrying a 5 cm sphere 0.1 m along its x axis, rotated by
    ``angle`` about y: the sphere centre is at height z − 0.1 sin(angle)."""
    m = pl.Model("ball")
    c, s = math.cos(angle), math.sin(angle)
    R = np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])
    body = m.add_part("body", 1.0, [1e-3, 1e-3, 1e-3], [0.0, 0.0, z], R)
    mk = m.add_marker(body, "foot", np.array([0.0, 0.0, z]) + R @ [0.1, 0.0, 0.0])
    m.add_contact(pl.SphereContact("foot", mk, radius=0.05, stiffness=1e5, exponent=1.5, penetration=penetration))
    return m


def test_initial_penetration_warns_naming_contact_and_depth():
    from proleg.analyses.checks import initial_penetrations

    # rotated part: sphere centre at z - 0.1 sin(angle), depth = radius - that
    angle = 0.3
    z = 0.06
    depth = 0.05 - (z - 0.1 * math.sin(angle))
    system = pl.assemble(_ball(z, angle))
    (what, d, pen, force), = initial_penetrations(system)
    assert "'foot'" in what and d == pytest.approx(depth, rel=1e-12) and pen == 1e-4
    assert force == pytest.approx(1e5 * depth**1.5, rel=1e-12)
    with pytest.warns(ProlegWarning, match=r"SphereContact 'foot' starts 0\.01955 m inside its plane"):
        pl.simulate(system, t_end=1e-3)
    # within the penetration depth: no warning (a foot resting at its static sag)
    with warnings.catch_warnings():
        warnings.simplefilter("error", ProlegWarning)
        s2 = pl.assemble(_ball(z, angle, penetration=0.03))
        pl.simulate(s2, t_end=1e-3)
    # q0 given to simulate is the state that is checked: the same body lifted clear
    q0 = np.asarray(system.params["q_init"]).copy()
    q0[2] += 0.1
    assert initial_penetrations(system, q0) == []


def test_buried_urdf_depth_is_reported():
    """HyQ at the old default base: each foot 0.8 m deep, named."""
    from proleg.analyses.checks import initial_penetrations

    m = _quiet_urdf(_hyq(), base_position=(0.0, 0.0, 0.0))
    found = {w.split("'")[1]: d for w, d, *_ in initial_penetrations(pl.assemble(m))}
    assert set(found) == {f"{leg}_foot.contact" for leg in ("lf", "rf", "lh", "rh")}
    for c in m.contacts:
        assert found[c.name] == pytest.approx(c.radius - c.marker.position[2], rel=1e-12)
