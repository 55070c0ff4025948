"""URDF import: a hand-written 2-link URDF against the same model built by hand, joint read-back
in the URDF's sign and zero, fixed-link merging, stops, and the errors for bad files."""

import warnings
from pathlib import Path

import numpy as np
import pytest

import proleg as pl
from proleg.errors import ModelError
from proleg.io.urdf import UrdfWarning, load_urdf
from proleg.solvers.initial import mass_matrix

DATA = Path(__file__).parent / "data" / "two_link.urdf"
Q0 = {"hip": 0.3, "knee": -0.5}


def _ry(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def _by_hand(q0):
    """The double pendulum of tests/data/two_link.urdf written with the proleg API.

    Shank + tip merged by hand: m = 0.8 + 0.1 = 0.9 kg, COM c = (0.8·0.15 + 0.1·0.3)/0.9 below
    the knee, I_xx = I_yy = 0.007 + 0.8 (0.15 − c)² + 1e-5 + 0.1 (0.3 − c)² (parallel axes).
    """
    th1, th2 = q0["hip"], q0["knee"]
    m = pl.Model("hand")
    hip = np.array([0.0, 0.0, 1.0])
    R1, R2 = _ry(th1), _ry(th1 + th2)
    thigh = m.add_part("thigh", 1.5, np.diag([0.021, 0.021, 0.001]), hip + R1 @ [0, 0, -0.2], R1)
    c = (0.8 * 0.15 + 0.1 * 0.3) / 0.9
    Ixx = 0.007 + 0.8 * (0.15 - c) ** 2 + 1e-5 + 0.1 * (0.3 - c) ** 2
    knee = hip + R1 @ [0, 0, -0.4]
    shank = m.add_part("shank", 0.9, np.diag([Ixx, Ixx, 0.0005 + 1e-5]), knee + R2 @ [0, 0, -c], R2)
    j1 = m.add_joint(pl.Revolute("hip", thigh, m.ground, at=hip, axis=(0, 1, 0)))
    j2 = m.add_joint(pl.Revolute("knee", shank, thigh, at=knee, axis=(0, 1, 0)))
    m.add_force(pl.RotationalSpringDamper("knee.damping", joint=j2, damping=0.3))
    return m, (j1, j2)


def _load(**kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UrdfWarning)
        return load_urdf(DATA, floating_base=False, initial_positions=Q0, **kw)


def test_two_link_matches_hand_model():
    """Identical parts, mass matrix and motion (1 s swing from hip 0.3, knee −0.5 rad)."""
    mu = _load(joint_stops=False, feet=())
    mh, _ = _by_hand(Q0)
    assert [p.name for p in mu.parts] == ["thigh", "shank"]  # 'tip' merged into 'shank'
    # Identical to round-off: the URDF path merges links and turns rpy angles into matrices (sin,
    # cos, 3×3 products). 64 eps × the scale: the mass; 1 m for positions (the leg is < 1 m);
    # m × (1 m)² for inertias (parallel-axis terms of the merge); n × max |M| for the mass matrix.
    eps = np.finfo(float).eps
    for pu, ph in zip(mu.parts, mh.parts):
        assert pu.mass == pytest.approx(ph.mass, rel=64 * eps)
        np.testing.assert_allclose(pu.position, ph.position, atol=64 * eps * 1.0)
        np.testing.assert_allclose(pu.orientation @ pu.inertia @ pu.orientation.T, ph.orientation @ ph.inertia @ ph.orientation.T,
                                   atol=64 * eps * ph.mass * 1.0**2)
    su, sh = pl.assemble(mu), pl.assemble(mh)
    qu, qh = pl.assembly.system.initial_coordinates(mu)[0], pl.assembly.system.initial_coordinates(mh)[0]
    Mh = np.asarray(mass_matrix(sh, qh))
    np.testing.assert_allclose(np.asarray(mass_matrix(su, qu)), Mh, atol=64 * eps * Mh.shape[0] * np.abs(Mh).max())
    ru = pl.simulate(su, t_end=1.0, dt_output=0.05)
    rh = pl.simulate(sh, t_end=1.0, dt_output=0.05)
    for name in ("hip", "knee"):
        # URDF read-back: the URDF's joint position (sign and zero), the hand model's relative angle + q0
        assert ru.joint(name).angle[0] == pytest.approx(Q0[name], abs=1e-12)
        # both runs use the same error control on the same equations: agreement to ~the tolerance
        np.testing.assert_allclose(ru.joint(name).angle, rh.joint(name).angle + Q0[name], atol=2e-5)
    assert np.ptp(ru.joint("hip").angle) > 0.3  # it really swung
    # marker at every link frame: the 'tip' link frame is 0.3 m below the knee
    knee = ru.marker("knee.I").position[-1]
    tip = ru.marker("tip").position[-1]
    assert np.linalg.norm(tip - knee) == pytest.approx(0.3, abs=1e-9)


def test_limits_damping_feet_and_notes():
    mu = _load(feet="spheres")  # a welded base gets ground contacts only when asked for
    kinds = {f.name: f.kind for f in mu.forces}
    assert kinds == {"hip.stop": "rotational_backlash", "knee.stop": "rotational_backlash", "knee.damping": "rotational_spring_damper"}
    stop = mu.force("knee.stop")
    assert stop.free_angle == pytest.approx(-0.75) and stop.half_gap == pytest.approx(1.25)  # [-2, 0.5] rad
    assert mu.force("knee.damping").damping == 0.3
    assert [c.name for c in mu.contacts] == ["tip.contact"] and mu.contacts[0].radius == 0.02
    assert any("effort" in n for n in mu.urdf.notes) and any("welded" in n for n in mu.urdf.notes)
    assert [v.kind for v in mu.urdf.visuals] == ["box", "cylinder"]
    with pytest.warns(UrdfWarning, match="outside its URDF limits"):
        load_urdf(DATA, floating_base=False, initial_positions={"knee": 0.6})


def test_floating_base_needs_mass():
    # 'base' has no <inertial>: welded it is fine, floating it would be a massless free part.
    # strict=True keeps the error; the default gives it 1/1000 of the lightest part's mass
    # (shank + tip: 0.9 kg) and says so (proleg.io.urdf_inertia).
    with pytest.raises(ModelError, match="'base'.*zero mass"):
        load_urdf(DATA, floating_base=True, strict=True)
    with pytest.warns(UrdfWarning, match=r"link 'base' has no mass but carries links: given 0\.0009 kg"):
        m = load_urdf(DATA, floating_base=True)
    assert m.part("base").mass == pytest.approx(1e-3 * 0.9)


BAD_JOINT = """<robot name="r"><link name="a"><inertial><mass value="1"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>
<link name="b"><inertial><mass value="{m}"/><inertia ixx="{ixx}" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial>{vis}</link>
<joint name="j1" type="{jt}"><parent link="a"/><child link="b"/><axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>"""


def _write(tmp_path, text, name="r.urdf"):
    p = tmp_path / name
    p.write_text(text)
    return p


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("<robot name='r'><link name='a'></robot>", r"r\.urdf.*not well-formed XML"),
        (BAD_JOINT.format(m=1, ixx=1, vis="", jt="spherical"), r"joint 'j1' has type 'spherical'.*r\.urdf|r\.urdf.*joint 'j1' has type 'spherical'"),
        (BAD_JOINT.format(m=0, ixx=1, vis="", jt="revolute"), r"r\.urdf.*link 'b' has zero mass"),
        (BAD_JOINT.format(m=1, ixx=-1, vis="", jt="revolute"), r"r\.urdf.*link 'b' inertia is not positive definite"),
        (BAD_JOINT.format(m=1, ixx=5, vis="", jt="revolute"), r"link 'b' inertia violates the triangle inequality"),
        (BAD_JOINT.format(m=1, ixx=1, vis="", jt="revolute").replace('child link="b"', 'child link="c"'), r"joint 'j1' names child link 'c'"),
    ],
)
def test_bad_files_name_link_joint_and_file(tmp_path, text, match):
    # strict=True: the mass and inertia checks raise instead of repairing (test_urdf_defaults.py)
    with pytest.raises(ModelError, match=match):
        load_urdf(_write(tmp_path, text), strict=True)


def test_missing_file_and_missing_mesh(tmp_path):
    with pytest.raises(ModelError, match="nothere.urdf not found"):
        load_urdf(tmp_path / "nothere.urdf")
    vis = '<visual><geometry><mesh filename="package://r/meshes/b.stl"/></geometry></visual>'
    with pytest.warns(UrdfWarning, match=r"visual mesh 'package://r/meshes/b.stl' of link 'b' not found"):
        m = load_urdf(_write(tmp_path, BAD_JOINT.format(m=1, ixx=1, vis=vis, jt="revolute")))
    assert m.urdf.visuals == [] and any("b.stl" in n for n in m.urdf.notes)


def test_cli_info_on_urdf(tmp_path):
    import json

    from typer.testing import CliRunner

    from proleg.cli.main import app

    out = CliRunner().invoke(app, ["info", str(DATA), "--fixed-base", "--json"])
    assert out.exit_code == 0, out.output
    d = json.loads(out.stdout)
    assert d["parts"] == ["thigh", "shank"] and d["dof_rank"] == 2 and d["mass_kg"] == pytest.approx(2.4)
    assert any("welded" in n for n in d["urdf: dropped or approximated"])
    # floating: 'base' has no mass; it loads with a small mass and the note says so
    out = CliRunner().invoke(app, ["info", str(DATA), "--json"])
    assert out.exit_code == 0, out.output
    assert any("'base' has no mass" in n for n in json.loads(out.stdout)["urdf: dropped or approximated"])
    bad = CliRunner().invoke(app, ["info", str(_write(tmp_path, DATA.read_text().replace('name="two_link"', "", 1)))])
    assert bad.exit_code == 2 and "<robot> has no 'name' attribute" in " ".join(bad.output.split())
