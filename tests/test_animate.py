"""3D animation page: self-contained (no network), every part present, and in a real browser
(headless Chromium, software WebGL) the canvas is drawn, moves, and logs no error."""

import shutil
import subprocess
import warnings
from pathlib import Path

import numpy as np
import pytest

import proleg as pl
from proleg.io.urdf import UrdfWarning, load_urdf
from proleg.report.animate import animate, animation_iframe, page, scene_from_frame

DATA = Path(__file__).parent / "data" / "two_link.urdf"


@pytest.fixture(scope="module")
def swing():
    """The 2-link URDF pendulum released at hip 1.0 rad, 0.6 s."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UrdfWarning)
        m = load_urdf(DATA, floating_base=False, initial_positions={"hip": 1.0, "knee": -0.5}, feet="spheres")
    return pl.simulate(pl.assemble(m), t_end=0.6, dt_output=0.01)


def test_page_is_self_contained_and_has_every_part(swing, tmp_path):
    html = animate(swing, tmp_path / "a.html")
    assert (tmp_path / "a.html").read_text() == html
    import re

    assert not re.search(r"<(script|link|img)[^>]*\b(src|href)=", html)  # nothing loaded from elsewhere (no CDN)
    for part in ("thigh", "shank"):
        assert f'"name":"{part}"' in html
    assert '"tip.contact"' in html and '"kind":"box"' in html and '"kind":"cylinder"' in html
    frag = animation_iframe(swing, height=300)
    assert frag.startswith("<iframe") and "srcdoc=" in frag and "&lt;script&gt;" in frag
    # the same scene from the Parquet file, shapes from the URDF
    swing.to_parquet(tmp_path / "r.parquet")
    import pandas as pd

    sc = scene_from_frame(pd.read_parquet(tmp_path / "r.parquet"), model=swing.system.topo.model)
    assert [p["name"] for p in sc["parts"]] == ["thigh", "shank"] and [c["name"] for c in sc["contacts"]] == ["tip.contact"]
    assert "thigh" in page(sc)


def _chromium():
    for name in ("chromium", "chromium-browser", "google-chrome"):
        if shutil.which(name):
            return shutil.which(name)
    pytest.skip("headless Chromium is not installed (Debian: apt-get install -y chromium)")


FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--enable-unsafe-swiftshader", "--use-angle=swiftshader",
         "--window-size=640,480", "--virtual-time-budget=4000", "--enable-logging=stderr", "--v=0"]


def _run(args):
    p = subprocess.run(args, capture_output=True, text=True, timeout=120)
    # Chromium's software GL reports its own "GL Driver Message (... GPU stall due to ReadPixels)"
    # when the screenshot reads the canvas back: the browser's, not the page's; everything else counts.
    console = [ln for ln in p.stderr.splitlines() if "CONSOLE" in ln and "GL Driver Message" not in ln]
    return p, console


def test_in_headless_chromium(swing, tmp_path):
    exe = _chromium()
    from matplotlib.image import imread

    path = tmp_path / "swing.html"
    animate(swing, path)
    shots = []
    for t in (0.0, 0.5):
        png = tmp_path / f"t{t}.png"
        p, console = _run([exe, *FLAGS, f"--screenshot={png}", f"{path.as_uri()}#t={t}"])
        assert png.is_file(), p.stderr[-2000:]
        assert not console, console  # no console message at all (errors, warnings, logs)
        shots.append(imread(png)[:440, :, :3])  # the canvas (the player bar is the bottom 40 px)
    for img in shots:
        assert img.std() > 0.02  # something is drawn: grid, parts (a blank canvas has std 0)
    diff = np.abs(shots[0] - shots[1]).mean(axis=2)
    assert (diff > 0.1).sum() > 200  # the pendulum moved: >200 pixels changed clearly
    p, console = _run([exe, *FLAGS, "--dump-dom", f"{path.as_uri()}#t=0.2"])
    assert 'id="status" class="ok">ok: 2 parts' in p.stdout, p.stdout[-500:]
    assert not console, console


def test_combine_scenes_side_by_side():
    """Two scenes in one: parts renamed per scene, poses shifted along y by the spacing, the
    rest of the data (times, z, quaternions) unchanged; different frame times are an error."""
    from proleg.report.animate import _scene, _unb64, combine_scenes

    t = np.linspace(0.0, 1.0, 5)
    box = [{"kind": "box", "size": [0.1, 0.1, 0.1], "X": np.eye(4).ravel().tolist(), "color": None}]

    def one(z):
        pose = np.zeros((len(t), 1, 7))
        pose[:, 0, 2], pose[:, 0, 3] = z - t, 1.0
        cd = np.zeros((len(t), 6))
        cd[:, 5] = 10.0 * t
        return _scene(t, ["body"], {"body": box}, {}, pose, [], [], [{"name": "c", "radius": 0.0}], [cd], "s")

    sc = combine_scenes({"a": one(1.0), "b": one(2.0)}, spacing=0.5)
    assert [p["name"] for p in sc["parts"]] == ["a: body", "b: body"]
    assert [c["name"] for c in sc["contacts"]] == ["a: c", "b: c"]
    pose = _unb64(sc["pose"], (2, 7))
    np.testing.assert_allclose(pose[:, :, 1], [[-0.25, 0.25]] * len(t))
    np.testing.assert_allclose(pose[:, 0, 2], 1.0 - t, atol=1e-6)
    np.testing.assert_allclose(pose[:, 1, 2], 2.0 - t, atol=1e-6)
    cd = _unb64(sc["contact_data"], (2, 6))
    np.testing.assert_allclose(cd[:, :, 1], [[-0.25, 0.25]] * len(t))
    assert sc["force_max"] == pytest.approx(10.0)
    other = one(1.0)
    other["t"] = (t + 0.1).tolist()
    with pytest.raises(ValueError, match="other frame times"):
        combine_scenes({"a": one(1.0), "b": other})


def test_cli_view_writes_the_page(swing, tmp_path):
    """``proleg view result.parquet --model robot.urdf``: the page with the URDF's shapes and
    every part pose from the file; a missing file is a clear error (exit code 2)."""
    import json
    import re

    from typer.testing import CliRunner

    from proleg.cli.main import app

    swing.to_parquet(tmp_path / "r.parquet")
    out = CliRunner().invoke(app, ["view", str(tmp_path / "r.parquet"), "--model", str(DATA), "--fixed-base", "--no-open"])
    assert out.exit_code == 0, out.output
    html = (tmp_path / "r.html").read_text()
    scene = json.loads(re.search(r'<script type="application/json" id="scene-data">(.*?)</script>', html, re.S).group(1).replace("<\\/", "</"))
    assert [p["name"] for p in scene["parts"]] == ["thigh", "shank"]
    assert any(s["kind"] == "cylinder" for p in scene["parts"] for s in p["shapes"])  # from the URDF, not inertia boxes
    assert len(scene["t"]) == len(swing.t)
    bad = CliRunner().invoke(app, ["view", str(tmp_path / "nothere.parquet"), "--no-open"])
    assert bad.exit_code == 2 and "nothere.parquetnotfound" in "".join(bad.output.split())  # rich wraps lines, even mid-word
