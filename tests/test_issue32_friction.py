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

EPS = np.finfo(np.float64).eps
# Two routes to one rotation matrix (three sin/cos pairs and a product of three matrices, or
# SciPy's quaternions): each entry within a few ulp of 1 of the exact value, differently on
# another libm, BLAS or vector width. Measured ≤ 2 eps apart; asserted at 16 eps (3.6e-15),
# while a wrong axis order or sign is off by 0.1 or more at these angles.
ROT_ATOL = 16 * EPS
# An entry that is exactly 0 at 90°: cos(fl(π/2)) = 6.1e-17 is the closest any double gets, and
# a degree-to-radian product rounded the other way moves it by one ulp of π/2 (2.2e-16):
# ≤ 2.8e-16 < 2 eps whatever the libm (measured 0.28 eps).
RIGHT_ANGLE_ATOL = 2 * EPS

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
    with pytest.warns(ProlegWarning, match=r"SphereContact 'foot' starts 0\.01955 m inside its plane.*273 N \(27\.9× the model's weight\)"):
        pl.simulate(system, t_end=1e-3)
    # no warning within the penetration depth, nor at about the static sag (1 mm deep: 3.2 N,
    # a third of the 9.81 N weight, deeper than penetration = 0.1 mm: a model placed at rest)
    sag = 0.05 - 0.001 + 0.1 * math.sin(angle)
    with warnings.catch_warnings():
        warnings.simplefilter("error", ProlegWarning)
        for s2 in (pl.assemble(_ball(z, angle, penetration=0.03)), pl.assemble(_ball(sag, angle))):
            pl.simulate(s2, t_end=1e-3)
    assert initial_penetrations(pl.assemble(_ball(sag, angle)))[0][1] == pytest.approx(0.001, rel=1e-9)
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


# ---------------------------------------------------------------------------------------------
# 3. the CLI prints text as written, every option has help with its units, errors are one line
# ---------------------------------------------------------------------------------------------
def _commands(cmd, path=()):
    yield path, cmd
    if hasattr(cmd, "commands"):  # a group (typer vendors click: no isinstance on click.Group)
        for name, sub in cmd.commands.items():
            yield from _commands(sub, path + (name,))


def test_cli_help_keeps_brackets_and_every_option_has_help():
    """rich read lowercase [...] in help as markup: 'End time [s]' printed as 'End time '. Every
    bracketed piece of every help string is now in the command's --help, and every option (``--rtol``
    had none) says what it is."""
    import re

    import typer
    from typer.testing import CliRunner

    from proleg.cli.main import app

    runner = CliRunner()
    root = typer.main.get_command(app)
    checked = 0
    for path, cmd in _commands(root):
        out = runner.invoke(app, [*path, "--help"])
        assert out.exit_code == 0, (path, out.output)
        flat = " ".join(out.output.split())
        for p in cmd.params:
            if getattr(p, "hidden", False) or p.name in ("help", "version"):
                continue
            assert getattr(p, "help", None) or p.param_type_name == "argument", f"proleg {' '.join(path)} {p.opts[0]} has no help"
            for unit in re.findall(r"\[[^\]]*\]", getattr(p, "help", None) or ""):
                assert " ".join(unit.split()) in flat, (path, unit)
                checked += 1
    assert checked >= 14  # the issue counted 14 help strings that lost their units


def test_cli_errors_are_one_line(tmp_path):
    """``--dt-output 0`` and ``--t-end -1`` ended in 60-77-line tracebacks; now one ``error:`` line
    (and warnings one ``warning:`` line each), with the brackets of the message kept."""
    from typer.testing import CliRunner

    from proleg.cli.main import app

    runner = CliRunner()
    model = str(ROOT / "examples" / "four_bar.yaml")
    for args, expect in (
        (["--dt-output", "0"], "error: simulate: dt_output must be positive [s], got 0"),
        (["--t-end", "-1"], "error: simulate: t_end = -1 s must be greater than t0"),
    ):
        res = runner.invoke(app, ["simulate", model, *args, "--out", str(tmp_path / "r.parquet")])
        assert res.exit_code == 2 and res.exception is None or isinstance(res.exception, SystemExit), res.output
        lines = [ln for ln in res.output.splitlines() if ln.strip()]
        errors = [ln for ln in lines if ln.startswith("error:")]
        assert len(errors) == 1 and errors[0].startswith(expect), res.output
        assert all(ln.startswith(("error:", "warning:")) for ln in lines), res.output
        assert "Traceback" not in res.output
    # a message with brackets: the viewer on a file without the time column
    import pandas as pd

    pd.DataFrame({"x": [0.0]}).to_parquet(tmp_path / "x.parquet")
    res = runner.invoke(app, ["view", str(tmp_path / "x.parquet"), "--no-open"])
    assert res.exit_code == 2 and "has no 'time [s]' column" in res.output


def test_cli_unexpected_failure_is_one_line_with_a_way_to_the_traceback(monkeypatch, tmp_path):
    from typer.testing import CliRunner

    import proleg.cli.main as climain

    def boom(*a, **kw):
        raise KeyError("no such thing [x]")

    monkeypatch.setattr(climain, "_load", boom)
    res = CliRunner().invoke(climain.app, ["info", str(tmp_path / "m.yaml")])
    assert res.exit_code == 1
    assert res.output.strip().count("\n") == 0 and "error: KeyError: 'no such thing [x]'" in res.output
    assert "PROLEG_TRACEBACK=1" in res.output
    monkeypatch.setenv("PROLEG_TRACEBACK", "1")
    res = CliRunner().invoke(climain.app, ["info", str(tmp_path / "m.yaml")])
    assert isinstance(res.exception, KeyError)


# ---------------------------------------------------------------------------------------------
# 4. proleg.io and proleg.report as attributes of a bare `import proleg`
# ---------------------------------------------------------------------------------------------
def test_io_and_report_are_attributes_without_importing_them():
    """The README's ``pl.io.load_urdf`` and ``pl.report.animate`` raised AttributeError in a fresh
    process unless ``proleg.io``/``proleg.report`` had been imported; they load on first use (a
    bare ``import proleg`` still does not import them)."""
    import subprocess
    import sys

    code = (
        "import sys, proleg as pl\n"
        "print('proleg.io' in sys.modules, 'proleg.report' in sys.modules)\n"
        "print(pl.io.load_urdf.__module__, pl.report.animate.__module__)\n"
        "print(callable(pl.io.load_model_file), callable(pl.report.quicklook))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300,
                         env={**__import__("os").environ, "PROLEG_CACHE_DIR": ""})
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.split() == ["False", "False", "proleg.io.urdf", "proleg.report.animate", "True", "True"]


# ---------------------------------------------------------------------------------------------
# 5. joint coordinates and rates in to_frame
# ---------------------------------------------------------------------------------------------
def test_to_frame_has_joint_angle_and_rate_of_a_pendulum():
    """A rod pendulum (m = 1 kg, L = 0.5 m, pivot at its end, axis y) released 0.01 rad from
    hanging. Its joint angle is the rotation since the modelled pose: θ(t) − θ0 with
    θ(t) = θ0 cos(ω t), ω² = m g (L/2) / (m L²/3) (small-amplitude closed form: its period error
    θ0²/16 ≈ 6e-6 relative is a phase error of 3.4e-5 rad at ωt = 5.4, 3.4e-7 rad of angle; the
    tolerance is 1e-6 rad, with the integration error held far below by rtol 1e-9). The angle
    also equals the COM's angle about the pivot and the rate the part's ω_y to round-off (same
    state, two formulas)."""
    th0, m, L, g = 0.01, 1.0, 0.5, 9.81
    model = pl.Model("pendulum")
    # rotation by th0 about y (x → −z): the rod hangs along −z, tipped towards +x
    c, s = math.cos(th0), math.sin(th0)
    R = np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])
    com = R @ [0.0, 0.0, -L / 2]
    rod = model.add_part("rod", m, [m * L**2 / 12, m * L**2 / 12, 1e-4], com, R)
    model.add_joint(pl.Revolute("pivot", rod, model.ground, at=(0, 0, 0), axis=(0, 1, 0)))
    res = pl.simulate(pl.assemble(model), t_end=1.0, dt_output=0.01, integrator=pl.GeneralizedAlpha(rtol=1e-9, atol=1e-12))
    df = res.to_frame()
    ang, rate = df["pivot.angle [rad]"].to_numpy(), df["pivot.angular_velocity [rad/s]"].to_numpy()
    t = df["time [s]"].to_numpy()
    w = math.sqrt(m * g * (L / 2) / (m * L**2 / 3))
    # hanging angle φ = atan2(x, −z) of the COM (φ0 = −θ0 here); a rotation by +a about y turns
    # (sin φ, −cos φ) into (sin(φ − a), −cos(φ − a)): the joint angle is φ0 − φ, its rate ω_y
    phi = np.arctan2(df["rod.x [m]"], -df["rod.z [m]"]).to_numpy()
    np.testing.assert_allclose(ang, phi[0] - phi, atol=1e-12)
    np.testing.assert_allclose(rate, df["rod.wy [rad/s]"].to_numpy(), atol=1e-12)
    # φ(t) = φ0 cos ωt: angle φ0 (1 − cos ωt) = θ0 (cos ωt − 1), rate −θ0 ω sin ωt
    np.testing.assert_allclose(ang, th0 * (np.cos(w * t) - 1.0), atol=1e-6)
    np.testing.assert_allclose(rate, -th0 * w * np.sin(w * t), atol=1e-6 * w)
    assert np.ptp(ang) > 1.9 * th0  # it swung through


def test_to_frame_has_prismatic_translation_and_velocity():
    """A slider on a vertical prismatic joint falls freely: translation −g t²/2, velocity −g t
    (the step's error control holds a quadratic to round-off; 1e-9 m is far below any physics)."""
    model = pl.Model("slider")
    block = model.add_part("block", 2.0, [0.01, 0.01, 0.01], [0.0, 0.0, 0.0])
    model.add_joint(pl.Prismatic("rail", block, model.ground, at=(0, 0, 0), axis=(0, 0, 1)))
    df = pl.simulate(pl.assemble(model), t_end=0.3, dt_output=0.01).to_frame()
    t = df["time [s]"].to_numpy()
    np.testing.assert_allclose(df["rail.translation [m]"], -0.5 * 9.81 * t**2, atol=1e-9)
    np.testing.assert_allclose(df["rail.velocity [m/s]"], -9.81 * t, atol=1e-8)
    assert "rail.angle [rad]" not in df.columns


# ---------------------------------------------------------------------------------------------
# 6. the viewer draws links and springs from the Parquet file alone
# ---------------------------------------------------------------------------------------------
def test_viewer_draws_links_and_springs_without_the_model(tmp_path):
    """``proleg view r.parquet`` (no --model) drew the parts as two dots and no spring. The file now
    carries the joints' and springs' markers: each joint is two segments that meet at the joint
    (COM of I → marker I, COM of J → marker J), the spring a line between its markers, at every
    frame to float32 round-off (the scene stores float32)."""
    import pandas as pd
    from typer.testing import CliRunner

    from proleg.cli.main import app
    from proleg.report.animate import _unb64, scene_from_frame

    m = pl.Model("double")
    upper = m.add_part("upper", 1.0, [0.01, 0.09, 0.09], [0.5, 0, 0])
    lower = m.add_part("lower", 1.0, [0.01, 0.09, 0.09], [1.5, 0, 0])
    m.add_joint(pl.Revolute("shoulder", upper, m.ground, at=(0, 0, 0), axis=(0, 1, 0)))
    m.add_joint(pl.Revolute("elbow", lower, upper, at=(1, 0, 0), axis=(0, 1, 0)))
    tip = m.add_marker(lower, "tip", [2.0, 0, 0])
    anchor = m.add_marker(m.ground, "anchor", [2.0, 0, 1.0])
    m.add_force(pl.SpringDamper("spring", tip, anchor, stiffness=20.0, free_length=1.0))
    res = pl.simulate(pl.assemble(m), t_end=0.5, dt_output=0.05)
    res.to_parquet(tmp_path / "r.parquet")
    df = pd.read_parquet(tmp_path / "r.parquet")
    sc = scene_from_frame(df)  # no model
    names = [ln["name"] for ln in sc["lines"]]
    assert names == ["shoulder (upper)", "elbow (lower)", "elbow (upper)", "spring"]
    assert [ln["kind"] for ln in sc["lines"]] == ["link", "link", "link", "spring_damper"]
    pts = _unb64(sc["line_pts"], (len(names), 6)).reshape(len(sc["t"]), len(names), 6)
    elbow = res.marker("elbow.I").position
    k = np.searchsorted(res.t, sc["t"])
    np.testing.assert_allclose(pts[:, 0, 3:], 0.0, atol=1e-6)  # shoulder pivot at the origin
    np.testing.assert_allclose(pts[:, 1, 3:], elbow[k], atol=1e-6)
    np.testing.assert_allclose(pts[:, 2, 3:], elbow[k], atol=1e-6)  # the two halves meet
    np.testing.assert_allclose(pts[:, 1, :3], res.part("lower").position[k], atol=1e-6)
    np.testing.assert_allclose(pts[:, 3, :3], res.marker("tip").position[k], atol=1e-6)
    np.testing.assert_allclose(pts[:, 3, 3:], np.broadcast_to([2.0, 0, 1.0], pts[:, 3, 3:].shape), atol=1e-6)
    assert np.ptp(pts[:, 1, 3]) > 0.05  # the elbow moved
    out = CliRunner().invoke(app, ["view", str(tmp_path / "r.parquet"), "--no-open"])
    assert out.exit_code == 0, out.output
    assert '"kind":"link"' in (tmp_path / "r.html").read_text()


# ---------------------------------------------------------------------------------------------
# 7. the progress bar says "compiling" until the first chunk returns
# ---------------------------------------------------------------------------------------------
def test_progress_bar_says_compiling_until_the_first_chunk():
    """e754ddf's bar read 't = 0.0000 s' through a 49 s compile. analyses/progress.py RunProgress:
    'compiling…' until the first update, then the simulated time and the fraction done; the model
    name printed as written."""
    import io

    from rich.console import Console

    from proleg.analyses.progress import COMPILING, RunProgress

    def shown(bar):
        con = Console(file=io.StringIO(), width=120, record=True, color_system=None)
        con.print(bar.progress.get_renderable())
        return con.export_text()

    bar = RunProgress("leg[2]", 0.5, 2.5, console=Console(file=io.StringIO()))
    before = shown(bar)
    assert "leg[2]" in before and COMPILING in before and "t =" not in before
    bar.update(1.0)
    after = shown(bar)
    assert "t = 1.0000 s" in after and COMPILING not in after and not bar.compiling
    assert bar.progress.tasks[0].percentage == pytest.approx(25.0)  # (1.0 − 0.5) / (2.5 − 0.5)
    with RunProgress("m", 0.0, 1.0, console=Console(file=io.StringIO())) as b2:
        assert b2.progress.live.is_started
    assert not b2.progress.live.is_started


# ---------------------------------------------------------------------------------------------
# 8. "did you mean" over public names; read_store on a missing path
# ---------------------------------------------------------------------------------------------
def _spring_model():
    m = pl.Model("bob")
    bob = m.add_part("bob", 1.0, [0.01, 0.01, 0.01], [0.0, 0.0, -1.0])
    top = m.add_marker(m.ground, "top", [0.0, 0.0, 0.0])
    m.add_joint(pl.Prismatic("rail", bob, m.ground, at=(0, 0, -1.0), axis=(0, 0, 1)))
    m.add_force(pl.SpringDamper("spring", m.add_marker(bob, "hook", [0.0, 0.0, -1.0]), top, stiffness=100.0, free_length=0.9))
    return pl.assemble(m)


def test_sweep_misspelt_parameter_suggests_public_names():
    """e754ddf listed q_init, marker_C, ... and offered no suggestion."""
    system = _spring_model()
    with pytest.raises(ModelError, match=r"Unknown parameter 'spring.stifness' of model 'bob'\. Did you mean 'spring.stiffness'\?") as err:
        pl.sweep(system, {"spring.stifness": [1.0, 2.0]}, t_end=0.1)
    msg = str(err.value)
    for internal in ("q_init", "v_init", "marker_C", "marker_s", "body_mass", "spring_damper_stiffness"):
        assert internal not in msg
    assert "bob.mass" in msg and "spring.damping" in msg
    with pytest.raises(ModelError, match=r"Did you mean 'bob.mass'\?"):
        system.with_params({"bob.mas": 2.0})
    with pytest.raises(ModelError, match=r"Did you mean 'spring.stiffness'\?"):
        system.with_params({"stiffness": 2.0})
    assert "spring.stiffness" in system.public_param_names() and "q_init" not in system.public_param_names()


def test_read_store_on_a_missing_path_says_so(tmp_path):
    from proleg.errors import DataError

    system = _spring_model()
    with pytest.raises(DataError, match=r"there is no store at '.*nothere' \(no such file or folder\)\. Give the folder"):
        pl.read_store(system, tmp_path / "nothere")
    (tmp_path / "empty").mkdir()
    with pytest.raises(DataError, match="holds no Parquet part files"):
        pl.read_store(system, tmp_path / "empty")


# ---------------------------------------------------------------------------------------------
# 9. roll-pitch-yaw in degrees in YAML model files
# ---------------------------------------------------------------------------------------------
def test_rpy_deg_is_fixed_axis_xyz():
    """rpy_deg = [roll, pitch, yaw] about fixed x, y, z (URDF's rpy): against SciPy's extrinsic
    'xyz' Euler angles and against URDF's own composition Rz Ry Rx, over random angles (matrix
    products of three rotations: a few ulp)."""
    from scipy.spatial.transform import Rotation

    from proleg.spatial.rotation import euler_zyx_deg, matrix_from_rpy_deg, p_from_matrix

    rng = np.random.default_rng(32)
    for rpy in rng.uniform([-180, -89, -180], [180, 89, 180], (50, 3)):
        R = matrix_from_rpy_deg(rpy)
        np.testing.assert_allclose(R, Rotation.from_euler("xyz", rpy, degrees=True).as_matrix(), atol=ROT_ATOL)
        # euler_zyx_deg reads the same angles back (as yaw, pitch, roll)
        np.testing.assert_allclose(euler_zyx_deg(p_from_matrix(R))[::-1], rpy, atol=1e-9)
    np.testing.assert_allclose(matrix_from_rpy_deg([0, 0, 90]), [[0, -1, 0], [1, 0, 0], [0, 0, 1]], atol=RIGHT_ANGLE_ATOL)


def test_rpy_deg_in_a_model_file(tmp_path):
    from proleg.io import load_model

    text = """
name: tilted
parts:
  - {name: a, mass: 1.0, inertia: [0.01, 0.02, 0.03], position: [0, 0, 0], rpy_deg: [10, -20, 30]}
markers:
  - {name: m, part: a, position: [0.1, 0, 0], rpy_deg: [0, 90, 0]}
"""
    f = tmp_path / "m.yaml"
    f.write_text(text)
    from scipy.spatial.transform import Rotation

    model = load_model(f)
    np.testing.assert_allclose(model.part("a").orientation, Rotation.from_euler("xyz", [10, -20, 30], degrees=True).as_matrix(), atol=ROT_ATOL)
    np.testing.assert_allclose(model.marker("m").orientation, [[0, 0, 1], [0, 1, 0], [-1, 0, 0]], atol=RIGHT_ANGLE_ATOL)
    f.write_text(text.replace("rpy_deg: [0, 90, 0]", "rpy_deg: [0, 90, 0], orientation: [1, 0, 0, 0]"))
    with pytest.raises(ModelError, match="rpy_deg, not both"):
        load_model(f)
    f.write_text(text.replace("rpy_deg: [0, 90, 0]", "rpy_deg: [0, 90]"))
    with pytest.raises(ModelError, match="rpy_deg"):
        load_model(f)


def test_four_bar_example_in_rpy_deg_is_the_old_model():
    """examples/four_bar.yaml now gives each link's angle in degrees instead of 16-digit matrices:
    the same rotations to round-off (the old matrices below), and the loop still closes."""
    from proleg.io import load_model

    old = {
        "crank": [[0.0, 0.0, -1.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]],
        "coupler": [[0.8534911287233514, 0.0, -0.5211073720362623], [0.0, 1.0, 0.0], [0.5211073720362623, 0.0, 0.8534911287233514]],
        "rocker": [[-0.3375936831560904, 0.0, -0.9412919340423062], [0.0, 1.0, 0.0], [0.9412919340423062, 0.0, -0.3375936831560904]],
    }
    body = [ln for ln in (ROOT / "examples" / "four_bar.yaml").read_text().splitlines() if not ln.startswith("#")]
    assert not any("orientation:" in ln for ln in body) and sum("rpy_deg:" in ln for ln in body) == 3
    model = load_model(ROOT / "examples" / "four_bar.yaml")
    for name, R in old.items():
        # each entry within an ulp of the exact one (libm's sin/cos ≤ 1 ulp, the 16-digit
        # literals ≤ 0.5 ulp): measured ≤ 0.5 eps, asserted at 4 eps; a degree value off by
        # 1e-13 deg (1.7e-15 rad) would be off by 8 eps
        np.testing.assert_allclose(model.part(name).orientation, R, atol=4 * EPS)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ProlegWarning)  # the loop's 3 redundant equations
        system = pl.assemble(model)
    # Φ = r_i + A_i s_i − r_j − A_j s_j: four terms of ≤ 0.4 m with rotation entries within a few
    # eps and 16-digit coordinates, so the loop closes to a few eps × 0.4 m; 32 eps × 0.4 m
    # (2.8e-15 m) is round-off in any summation order, a pose off by 1 µm is 1e-6
    assert system.topo.dof["initial_residual"][0] < 32 * EPS * 0.4


# ---------------------------------------------------------------------------------------------
# 10. global JAX settings: documented, with the opt-outs that are safe
# ---------------------------------------------------------------------------------------------
def _fresh(code: str, **env) -> str:
    import os
    import subprocess
    import sys
    import textwrap

    e = {k: v for k, v in os.environ.items() if k not in ("PROLEG_CACHE_DIR", "PROLEG_JAX_CACHE")}
    out = subprocess.run([sys.executable, "-c", textwrap.dedent(code)], capture_output=True, text=True, timeout=300, env={**e, **env})
    assert out.returncode == 0, out.stderr[-3000:]
    return out.stdout.strip()


def test_global_settings_page_names_every_switch():
    """docs/global-settings.md exists and names every PROLEG_* environment variable the package
    reads, and every JAX option `import proleg` sets (so a new one cannot go undocumented)."""
    import re

    page = (ROOT / "docs" / "global-settings.md").read_text()
    src = "".join(p.read_text() for p in (ROOT / "src" / "proleg").rglob("*.py"))
    env = set(re.findall(r"environ(?:\.get)?\(?\[?\s*\"(PROLEG_[A-Z_]+)\"", src))
    assert {"PROLEG_CACHE_DIR", "PROLEG_JAX_CACHE", "PROLEG_XLA_DEFAULTS", "PROLEG_PRELOAD_LAPACK"} <= env
    for name in env:
        assert name in page, name
    init = (ROOT / "src" / "proleg" / "__init__.py").read_text()
    for opt in re.findall(r"config\.update\(\"(jax_[a-z0-9_]+)\"", init):
        assert opt in page, opt
    for flag in pl.XLA_CPU_DEFAULTS:
        assert flag in page, flag
    for name in pl.XLA_CPU_ENV_DEFAULTS:
        assert name in page, name


def test_xla_cpu_environment_defaults_and_their_opt_outs():
    """`import proleg` sets PJRT_NPROC=1 and its XLA flags in a clean environment, and leaves
    them alone where the user set PJRT_NPROC, NPROC or PROLEG_XLA_DEFAULTS=0 (docs/global-settings.md)."""
    import os
    import subprocess
    import sys

    code = "import os, proleg; print(os.environ.get('PJRT_NPROC'), os.environ.get('NPROC'), 'concurrency_optimized_scheduler=false' in os.environ.get('XLA_FLAGS', ''))"
    clean = {k: v for k, v in os.environ.items() if k not in ("PJRT_NPROC", "NPROC", "XLA_FLAGS", "PROLEG_XLA_DEFAULTS")}

    def run(**env):
        out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300, env={**clean, **env})
        assert out.returncode == 0, out.stderr[-3000:]
        return out.stdout.split()

    assert run() == ["1", "None", "True"]
    assert run(PJRT_NPROC="4") == ["4", "None", "True"]
    assert run(NPROC="3") == ["None", "3", "True"]
    assert run(PROLEG_XLA_DEFAULTS="0") == ["None", "None", "False"]


def test_jax_cache_opt_out_leaves_jax_config_alone(tmp_path):
    code = """
        import jax
        import proleg
        c = jax.config
        print(c.jax_enable_x64, c.jax_compilation_cache_dir, c.jax_persistent_cache_min_compile_time_secs)
    """
    on = _fresh(code, PROLEG_CACHE_DIR=str(tmp_path)).split()
    assert on == ["True", str(tmp_path), "0.0"]
    off = _fresh(code, PROLEG_CACHE_DIR=str(tmp_path), PROLEG_JAX_CACHE="0").split()
    assert off[0] == "True" and off[1] == "None" and off[2] != "0.0"  # JAX's defaults
    # a folder the user set first is kept, and so are JAX's thresholds
    mine = _fresh("""
        import jax
        jax.config.update("jax_compilation_cache_dir", %r)
        import proleg
        print(jax.config.jax_compilation_cache_dir, jax.config.jax_persistent_cache_min_compile_time_secs)
    """ % str(tmp_path / "mine"), PROLEG_CACHE_DIR=str(tmp_path)).split()
    assert mine[0] == str(tmp_path / "mine") and mine[1] != "0.0"


def test_float32_after_import_is_refused():
    """float64 has no opt-out; switching it off after import is a clear error, not float32 results."""
    out = _fresh("""
        import jax
        import proleg as pl
        m = pl.Model("m")
        p = m.add_part("p", 1.0, [1.0, 1.0, 1.0], [0.0, 0.0, 0.0])
        system = pl.assemble(m)
        jax.config.update("jax_enable_x64", False)
        try:
            pl.simulate(system, t_end=0.1)
        except pl.ModelError as exc:
            print("refused:", exc)
    """, PROLEG_CACHE_DIR="")
    assert out.startswith("refused: simulate: JAX's float64 mode (jax_enable_x64) was switched off")
