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
        m = load_urdf(DATA, floating_base=False, initial_positions={"hip": 1.0, "knee": -0.5})
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
