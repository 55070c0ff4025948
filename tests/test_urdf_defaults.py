"""URDF defaults a robot designer expects (issue 43, item 4): feet found on collision meshes,
foot friction by default, the servo helper, initial joint rates and base twist, messy inertias
repaired as MuJoCo's compiler can (strict mode keeps the errors), and errors that name what a
malformed file is missing."""

import math
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

import proleg as pl
from proleg.errors import ModelError
from proleg.io.urdf import FOOT_CONTACT, UrdfWarning, load_urdf
from proleg.io.urdf_inertia import BOUND_MASS_FRACTION, sphere_moment
from proleg.io.urdf_kin import set_initial_velocity
from proleg.io.urdf_servos import add_servos

DATA = Path(__file__).parent / "data" / "two_link.urdf"
ROOT = Path(__file__).resolve().parents[1]


def erd(rel=""):
    """A file (or the robots folder) of the installed example-robot-data package."""
    for base in sys.path:
        p = Path(base) / "cmeel.prefix" / "share" / "example-robot-data" / "robots" / rel
        if p.exists():
            return p
    pytest.skip(f"example-robot-data is not installed (no {rel}): pip install -e .[test]")


def quiet(*a, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UrdfWarning)
        return load_urdf(*a, **kw)


def write(tmp_path, text, name="r.urdf"):
    p = tmp_path / name
    p.write_text(text)
    return p


INERT = '<inertial><origin xyz="{c}"/><mass value="{m}"/><inertia ixx="{ixx}" iyy="{iyy}" izz="{izz}" ixy="0" ixz="0" iyz="0"/></inertial>'


def link(name, m=1.0, i=(0.01, 0.01, 0.01), c="0 0 0", extra=""):
    body = INERT.format(m=m, ixx=i[0], iyy=i[1], izz=i[2], c=c) if m is not None else ""
    return f'<link name="{name}">{body}{extra}</link>'


def joint(name, kind, parent, child, xyz="0 0 0", axis="0 1 0"):
    lim = '<limit lower="-3" upper="3" effort="100" velocity="10"/>' if kind in ("revolute", "prismatic") else ""
    return (f'<joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/>'
            f'<origin xyz="{xyz}"/><axis xyz="{axis}"/>{lim}</joint>')


def robot(*parts, name="r"):
    return f'<robot name="{name}">' + "".join(parts) + "</robot>"


# ---------------------------------------------------------------------------------------------
# 1. feet on collision meshes
# ---------------------------------------------------------------------------------------------
def test_foot_sphere_fitted_to_a_mesh(tmp_path):
    """A leg whose foot collision is a mesh of a 20 mm sphere (an icosphere, so its vertices lie on
    the sphere): found as the foot without being named, its contact sphere fitted to the mesh's
    lowest region has r = 20 mm (to the icosphere's facets: 1 %), centre above the lowest vertex,
    and the base is placed so that the sphere touches the ground."""
    trimesh = pytest.importorskip("trimesh")
    trimesh.creation.icosphere(subdivisions=4, radius=0.02).export(tmp_path / "ball.stl")
    mesh = '<collision><origin xyz="0.01 0 0"/><geometry><mesh filename="ball.stl"/></geometry></collision>'
    text = robot(link("base", 2.0), link("leg", 0.5, c="0 0 -0.1"), link("foot", 0.05, (1e-5, 1e-5, 1e-5), extra=mesh),
                 joint("hip", "revolute", "base", "leg"), joint("ankle", "fixed", "leg", "foot", xyz="0 0 -0.3"))
    with pytest.warns(UrdfWarning, match=r"foot 'foot': collision mesh → contact sphere r = 20\.\d mm fitted"):
        m = load_urdf(write(tmp_path, text))
    assert m.urdf.feet == ["foot"]
    (c,) = m.contacts
    assert c.radius == pytest.approx(0.02, rel=0.01)
    # sphere centre: at the mesh's centre (the collision origin, 10 mm ahead of the foot frame)
    np.testing.assert_allclose(c.marker.position[:2], m.marker("foot").position[:2] + [0.01, 0.0], atol=2e-4)
    assert c.marker.position[2] - c.radius == pytest.approx(0.0, abs=1e-12)  # on the ground


@pytest.mark.parametrize("rel", ["go2_description/urdf/go2.urdf", "solo_description/robots/solo12.urdf"])
def test_mesh_feet_of_go2_and_solo12(rel):
    """Go2's and Solo12's feet are collision meshes: the four foot links get contacts at the
    defaults, with a note each, and the robot stands on them (lowest sphere bottom at z = 0)."""
    m = quiet(erd(rel))
    assert len(m.urdf.feet) == 4 and all("foot" in f.lower() for f in m.urdf.feet)
    assert len(m.contacts) == 4
    radii = np.array([c.radius for c in m.contacts])
    assert np.all((radii > 0.01) & (radii < 0.03))  # foot-sized: Solo12 12 mm, Go2 24 mm
    assert sum("fitted to its lowest region" in n for n in m.urdf.notes) == 4
    bottoms = np.array([c.marker.position[2] - c.radius for c in m.contacts])
    np.testing.assert_allclose(bottoms, 0.0, atol=1e-9)  # a symmetric zero pose: all four touch


# ---------------------------------------------------------------------------------------------
# 2. foot friction by default
# ---------------------------------------------------------------------------------------------
BOX = robot(
    link("box", 4.0, (0.03, 0.03, 0.03)),
    *[link(f"foot{k}", None, extra='<collision><geometry><sphere radius="0.01"/></geometry></collision>') for k in range(4)],
    *[joint(f"f{k}", "fixed", "box", f"foot{k}", xyz=f"{x} {y} -0.05") for k, (x, y) in enumerate([(0.15, 0.1), (0.15, -0.1), (-0.15, 0.1), (-0.15, -0.1)])],
    name="box",
)


def test_default_friction_is_documented():
    """μ = 0.8 on every URDF foot, stated in load_urdf's docstring and in the contacts guide."""
    assert FOOT_CONTACT["mu_static"] == FOOT_CONTACT["mu_dynamic"] == 0.8
    doc = " ".join(load_urdf.__doc__.split())
    assert "feet have friction by default" in doc and "μ_static = μ_dynamic = 0.8" in doc
    assert f"v_stiction = {FOOT_CONTACT['v_stiction']:g} m/s" in doc and f"v_friction = {FOOT_CONTACT['v_friction']:g} m/s" in doc
    guide = " ".join((ROOT / "docs" / "guide" / "contacts-drives.md").read_text().split())
    assert "load_urdf" in guide and "μ = 0.8" in guide and "bench/urdf_friction.py" in guide


def test_robot_on_a_10_degree_slope_does_not_slide(tmp_path):
    """A 4 kg box on four URDF foot spheres at the default friction, released on a 10° slope
    (gravity tilted). Frictionless it would slide g sin θ t²/2 = 0.21 m in 0.5 s; with μ = 0.8 >
    tan 10° it sticks and only creeps, at the rate where the smoothed stiction law's slope
    1.5 μ / v_stiction (proleg.contact_law) carries the downhill load: v = v_s tan θ / (1.5 μ)
    (1.5 mm/s). Tolerance 10 %: the creep starts after the landing transient."""
    th = math.radians(10.0)
    g = (-9.81 * math.sin(th), 0.0, -9.81 * math.cos(th))
    m = quiet(write(tmp_path, BOX), gravity=g)
    assert [c.mu_static for c in m.contacts] == [0.8] * 4
    r = pl.simulate(pl.assemble(m), 0.5, 0.01, progress=False)
    x = r.part("box").position[:, 0]
    slide = x[0] - x[-1]
    assert 0 < slide < 1e-3  # < 1 mm against 0.21 m frictionless
    k = len(x) // 2
    creep = (x[k] - x[-1]) / (r.t[-1] - r.t[k])
    assert creep == pytest.approx(FOOT_CONTACT["v_stiction"] * math.tan(th) / (1.5 * 0.8), rel=0.1)


# ---------------------------------------------------------------------------------------------
# 3. servo helper
# ---------------------------------------------------------------------------------------------
def _rail_leg(tmp_path):
    """A two-link leg (thigh 0.5 kg, shank 0.3 kg, 0.2 m each) below a 2 kg hip on a vertical
    rail, foot sphere r = 0.02 m under the hip (thigh 30° forward, knee −60°), standing."""
    sph = '<collision><geometry><sphere radius="0.02"/></geometry></collision>'
    text = robot(
        link("rail", 1.0), link("hip", 2.0), link("thigh", 0.5, (0.5 * 0.04 / 12,) * 3, c="0 0 -0.1"),
        link("shank", 0.3, (0.3 * 0.04 / 12,) * 3, c="0 0 -0.1"), link("foot", None, extra=sph),
        joint("slide", "prismatic", "rail", "hip", axis="0 0 1"), joint("hip_joint", "revolute", "hip", "thigh"),
        joint("knee", "revolute", "thigh", "shank", xyz="0 0 -0.2"), joint("ankle", "fixed", "shank", "foot", xyz="0 0 -0.2"),
        name="rail_leg",
    )
    a = math.radians(30.0)
    q0 = {"hip_joint": a, "knee": -2 * a}
    h = 0.02 + 0.4 * math.cos(a)
    return quiet(write(tmp_path, text), floating_base=False, feet=["foot"], initial_positions=q0, base_position=(0, 0, h), joint_stops=False)


def test_servo_gains_and_gravity_compensation_hold_a_leg(tmp_path):
    """Default gains: the weight on the leg is a critically damped oscillator at 4 Hz. With the
    foot held by friction, lowering the hip by δ turns the hip by δ/l and the knee by −2δ/l (the
    foot stays under the hip), storing kp (1 + 4) δ²/(2 l²): the leg's stiffness is 5 kp / l²,
    S = l²/5, so kp = M ω² l²/5 = 2.8 kg (2π 4)² (0.2 m)²/5 = 14.1 N m/rad, kd = 2 kp / ω.
    Without gravity compensation the stand sags by g/ω² = 15.5 mm; with it the servos carry the
    weight at the stance. The contact force is the weight to 2 % after 0.3 s either way."""
    sag = {}
    for comp in (False, True):
        m = _rail_leg(tmp_path)
        gains = add_servos(m, joints=["hip_joint", "knee"], gravity_compensation=comp)
        M = 2.0 + 0.5 + 0.3
        w = 2 * math.pi * 4.0
        assert gains.mass == pytest.approx(M) and gains.levers["foot"] == pytest.approx(0.2 / math.sqrt(5), rel=1e-6)
        assert gains.kp == pytest.approx(M * w**2 * 0.2**2 / 5, rel=1e-6) and gains.kd == pytest.approx(2 * gains.kp / w, rel=1e-9)
        r = pl.simulate(pl.assemble(m), 0.3, 0.01, progress=False)
        fz = r.contact("foot.contact").normal_force
        assert fz[-1] == pytest.approx(M * 9.81, rel=0.02)
        sag[comp] = r.part("hip").position[0, 2] - r.part("hip").position[-1, 2]
    pen = (M * 9.81 / 1e6) ** (2 / 3)  # Hertz contact penetration under the weight (k = 1e6 N/m^1.5)
    # 10 %: the thigh and shank are part of M but move less than the hip
    assert sag[False] - pen == pytest.approx(9.81 / (2 * math.pi * 4.0) ** 2, rel=0.1)
    assert abs(sag[True] - pen) < 1e-3  # the stance itself, to 1 mm (5 % of the uncompensated sag)


@pytest.mark.slow
def test_servo_helper_holds_go1_stand():
    """Go1 on its feet at its SRDF stance, the servo helper's defaults: 0.2 s after being put down
    the ground carries the weight to 2 % (measured: to 0.01 %)."""
    import re

    urdf, srdf = erd("go1_description/urdf/go1.urdf"), erd("go1_description/srdf/go1.srdf")
    blocks = dict(re.findall(r'<group_state name="([^"]+)"[^>]*>(.*?)</group_state>', srdf.read_text(), re.S))
    stance = {n: float(v) for n, v in re.findall(r'<joint name="([^"]+)" value="([^" ]+)"\s*/>', blocks["standing"])}
    probe = quiet(urdf, feet=())
    m = quiet(urdf, initial_positions={j: v for j, v in stance.items() if j in probe.urdf.joint_names()})
    gains = add_servos(m)
    assert len(m.controllers) == 12 and gains.kp > 0
    r = pl.simulate(pl.assemble(m), 0.2, 0.01, progress=False)
    fz = sum(r.contact(c.name).normal_force for c in m.contacts)
    assert fz[-1] == pytest.approx(gains.mass * 9.81, rel=0.02)


def test_servo_helper_errors(tmp_path):
    m = quiet(DATA, floating_base=False)  # no feet: no default gains
    with pytest.raises(ModelError, match="no feet, so no default gains"):
        add_servos(m)
    add_servos(m, kp=10.0, kd=1.0)
    assert sorted(c.name for c in m.controllers) == ["hip.servo", "knee.servo"]
    with pytest.raises(ModelError, match="'elbow' is not a moving joint"):
        add_servos(quiet(DATA, floating_base=False), kp=1.0, kd=0.1, stance={"elbow": 0.1})


# ---------------------------------------------------------------------------------------------
# 4. initial joint rates and base twist
# ---------------------------------------------------------------------------------------------
def test_initial_joint_rates_read_back(tmp_path):
    """Hip rate 2 rad/s, knee −1 rad/s: the thigh turns at 2 rad/s about y, the shank at 1 rad/s,
    and a run starts with the joints reading these rates."""
    m = quiet(DATA, floating_base=False, initial_positions={"hip": 0.3}, initial_velocities={"hip": 2.0, "knee": -1.0})
    np.testing.assert_allclose(m.part("thigh").angular_velocity, [0, 2.0, 0], atol=1e-12)
    np.testing.assert_allclose(m.part("shank").angular_velocity, [0, 1.0, 0], atol=1e-12)
    hip = m.marker("hip.J").position
    np.testing.assert_allclose(m.part("thigh").velocity, np.cross([0, 2.0, 0], m.part("thigh").position - hip), atol=1e-12)
    r = pl.simulate(pl.assemble(m), 0.01, 0.005, progress=False)
    assert r.joint("hip").angular_velocity[0] == pytest.approx(2.0, abs=1e-9)
    assert r.joint("knee").angular_velocity[0] == pytest.approx(-1.0, abs=1e-9)


def test_base_twist_in_root_link_axes(tmp_path):
    """A floating robot with a base twist (v, ω) in root-link axes (Pinocchio's convention): the
    root part's angular velocity is R ω and its COM moves at R v + (R ω) × (c − o); a welded
    base refuses a twist."""
    from proleg.spatial.rotation import A_of_p

    text = robot(link("base", 2.0, c="0.05 0 0"), link("leg", 0.5, c="0 0 -0.1"), joint("hip", "revolute", "base", "leg"))
    q = np.array([0.9, 0.1, -0.2, 0.3])
    q /= np.linalg.norm(q)
    nu = np.array([0.3, -0.2, 0.1, 0.5, 1.0, -0.4])
    m = quiet(write(tmp_path, text), feet=(), base_orientation=q, base_velocity=nu, initial_velocities={"hip": 0.7})
    R = np.asarray(A_of_p(q))
    o = m.urdf.base_pose[:3, 3]
    base = m.part("base")
    np.testing.assert_allclose(base.angular_velocity, R @ nu[3:], atol=1e-12)
    np.testing.assert_allclose(base.velocity, R @ nu[:3] + np.cross(R @ nu[3:], base.position - o), atol=1e-12)
    np.testing.assert_allclose(m.part("leg").angular_velocity - base.angular_velocity, R @ [0, 0.7, 0], atol=1e-12)
    with pytest.raises(ModelError, match="welded base"):
        set_initial_velocity(quiet(DATA, floating_base=False), base_velocity=nu)
    with pytest.raises(ModelError, match="'elbow' is not a moving joint"):
        set_initial_velocity(m, joint_rates={"elbow": 1.0})


# ---------------------------------------------------------------------------------------------
# 5. messy inertias; malformed files
# ---------------------------------------------------------------------------------------------
def test_point_mass_and_triangle_violations_repaired(tmp_path):
    """A point mass (zero inertia) gets the moments of a solid water sphere of its mass; an inertia
    breaking the triangle inequality has its two smaller moments raised until the largest is
    their sum (principal axes kept); each repair noted; strict=True raises as before."""
    text = robot(link("base", 2.0), link("a", 0.5, (0, 0, 0)), link("b", 1.0, (0.001, 0.002, 0.01)),
                 joint("j1", "revolute", "base", "a"), joint("j2", "revolute", "a", "b", xyz="0 0 -0.2"))
    p = write(tmp_path, text)
    with pytest.warns(UrdfWarning, match=r"link 'a' \(0\.5 kg\): inertia repaired.*water sphere"):
        m = load_urdf(p, feet=())
    r = (3 * 0.5 / (4 * math.pi * 1000.0)) ** (1 / 3)
    np.testing.assert_allclose(np.linalg.eigvalsh(m.part("a").inertia), 0.4 * 0.5 * r * r, rtol=1e-12)
    assert sphere_moment(0.5) == pytest.approx(0.4 * 0.5 * r * r)
    w = np.linalg.eigvalsh(m.part("b").inertia)
    d = (0.01 - 0.003) / 2
    np.testing.assert_allclose(w, [0.001 + d, 0.002 + d, 0.01], rtol=1e-8)
    assert any("link 'b'" in n and "triangle inequality" in n for n in m.urdf.notes)
    with pytest.raises(ModelError, match=r"link 'a' inertia is not positive definite"):
        load_urdf(p, feet=(), strict=True)


def test_massless_links_welded_or_given_mass(tmp_path):
    """A massless link between two revolutes (a spherical hip written as revolutes, human.urdf)
    gets 1/1000 of the lightest part's mass; a massless subtree (romeo's fingers) is welded at its
    initial position, its joints dropped; strict=True keeps the error."""
    text = robot(
        link("base", 2.0), link("virtual", None), link("thigh", 0.5, c="0 0 -0.1"),
        link("finger1", 0.0, (0, 0, 0)), link("finger2", None),
        joint("hip_z", "revolute", "base", "virtual", axis="0 0 1"), joint("hip_y", "revolute", "virtual", "thigh"),
        joint("f1", "revolute", "thigh", "finger1", xyz="0 0 -0.3"), joint("f2", "revolute", "finger1", "finger2", xyz="0 0 -0.05"),
    )
    p = write(tmp_path, text)
    with pytest.warns(UrdfWarning, match=r"link 'virtual' has no mass but carries links") as rec:
        m = load_urdf(p, feet=(), initial_positions={"f1": 0.4})
    assert any("joints ['f1', 'f2'] dropped" in str(w.message) for w in rec)
    assert [pt.name for pt in m.parts] == ["base", "virtual", "thigh"]
    assert m.part("virtual").mass == pytest.approx(BOUND_MASS_FRACTION * 0.5)
    assert m.urdf.joint_names() == ["hip_z", "hip_y"] and m.urdf.link_part["finger2"] == "thigh"
    # the welded finger keeps its initial position: f1 = 0.4 rad about y
    d = m.marker("finger2").position - m.marker("finger1").position
    np.testing.assert_allclose(d, [-0.05 * math.sin(0.4), 0, -0.05 * math.cos(0.4)], atol=1e-12)
    pl.assemble(m)
    with pytest.raises(ModelError, match=r"link 'virtual' has zero mass.*strict=True"):
        load_urdf(p, feet=(), strict=True)


@pytest.mark.parametrize(
    ("old", "new", "match"),
    [
        ('name="r"', "", r"line 1: <robot> has no 'name' attribute.*robot name="),
        ('<sphere radius="0.02"/>', "<sphere/>", r"<sphere> of link 'foot' has no 'radius' attribute"),
        ('<mass value="2.0"/>', "<mass/>", r"<mass> of link 'base' has no 'value' attribute"),
        ('<joint name="hip" ', "<joint ", r"<joint> has no 'name' attribute"),
    ],
)
def test_malformed_file_names_the_missing_attribute(tmp_path, old, new, match):
    sph = '<collision><geometry><sphere radius="0.02"/></geometry></collision>'
    text = robot(link("base", 2.0), link("foot", 0.1, extra=sph), joint("hip", "revolute", "base", "foot"))
    assert old in text
    with pytest.raises(ModelError, match=match):
        load_urdf(write(tmp_path, text.replace(old, new, 1)))


def test_ur3_without_robot_name():
    """example-robot-data's ur3.urdf has no robot name (Pinocchio refuses it too)."""
    with pytest.raises(ModelError, match=r"ur3\.urdf, line \d+: <robot> has no 'name' attribute"):
        load_urdf(erd("ur_description/urdf/ur3.urdf"))


@pytest.mark.slow
def test_every_example_robot_data_urdf_that_pinocchio_builds_loads_and_assembles():
    """All 69 URDFs of example-robot-data: every one Pinocchio builds (68; not ur3.urdf, which has
    no robot name) loads at the defaults and assembles."""
    pin = pytest.importorskip("pinocchio")
    files = sorted(erd().rglob("*.urdf"))
    assert len(files) >= 60
    built, failed = 0, []
    for f in files:
        try:
            pin.buildModelFromUrdf(str(f), pin.JointModelFreeFlyer())
        except Exception:
            continue
        built += 1
        try:
            pl.assemble(quiet(f))
        except Exception as exc:  # collect every failure, then report them all
            failed.append(f"{f.name}: {type(exc).__name__}: {exc}")
    assert built >= 68 and not failed, failed
