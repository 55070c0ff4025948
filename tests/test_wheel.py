"""pip install works: the built wheel, installed into a fresh virtual environment, runs the
README's ten lines outside the source tree, and carries what the source tree has and an
editable install hides (package data, the proleg.papers scenarios, the ``proleg`` command).

Speed: the wheel is built from a copy of src/ (pip's isolated build: it fetches setuptools
from the package index the first time, then from pip's cache); the venv gets proleg with
``--no-deps`` and sees this interpreter's installed dependencies through a path file, so nothing
heavy is installed. The whole test takes ~30 s on a quiet 2-core machine, most of it the first
compile of the ten lines.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import sysconfig
import venv
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _ten_lines() -> str:
    readme = (ROOT / "README.md").read_text()
    m = re.search(r"## Ten lines\s+```python\n(.*?)```", readme, re.S)
    assert m, "README.md has no '## Ten lines' python block"
    return m.group(1)


@pytest.fixture(scope="module")
def wheel_venv(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("wheel")
    src = tmp / "proleg-src"
    shutil.copytree(ROOT / "src", src / "src", ignore=shutil.ignore_patterns("__pycache__", "*.pyc", "*.egg-info"))
    for f in ("pyproject.toml", "README.md"):
        shutil.copy(ROOT / f, src / f)
    p = subprocess.run([sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "-w", str(tmp / "dist"), str(src)],
                       capture_output=True, text=True, timeout=600)
    if p.returncode != 0 and re.search(r"No matching distribution|Could not find a version|connection|resolve", p.stderr, re.I):
        pytest.skip(f"the isolated wheel build needs setuptools from the package index, which is not reachable: {p.stderr[-300:]}")
    assert p.returncode == 0, p.stderr[-3000:]
    (whl,) = (tmp / "dist").glob("proleg-*.whl")

    env_dir = tmp / "venv"
    venv.EnvBuilder(with_pip=False).create(env_dir)
    py = env_dir / "bin" / "python"
    purelib = Path(subprocess.run([str(py), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                                  capture_output=True, text=True, check=True).stdout.strip())
    # the dependencies (jax, numpy, ...) from this interpreter's site-packages, appended after the
    # venv's own: a plain path line, so the editable install's finder there is not loaded
    (purelib / "_deps_from_test_env.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    p = subprocess.run([sys.executable, "-m", "pip", "--python", str(py), "install", "-q", "--no-deps", str(whl)],
                       capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr[-3000:]
    return env_dir, whl


def _env(tmp_path):
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")}
    env["MPLBACKEND"] = "Agg"
    env["PATH"] = os.pathsep.join(p for p in env.get("PATH", "").split(os.pathsep) if ".venv" not in p)
    return env


def test_the_wheel_runs_the_ten_lines_outside_the_source_tree(wheel_venv, tmp_path):
    env_dir, _ = wheel_venv
    code = "import proleg, sys\nprint('proleg from', proleg.__file__)\n" + _ten_lines()
    p = subprocess.run([str(env_dir / "bin" / "python"), "-c", code], cwd=tmp_path, env=_env(tmp_path),
                       capture_output=True, text=True, timeout=600)
    assert p.returncode == 0, p.stderr[-3000:]
    where = p.stdout.split("proleg from ", 1)[1].splitlines()[0]
    assert Path(where).is_relative_to(env_dir), f"proleg was imported from {where}, not from the installed wheel"
    line = next(ln for ln in p.stdout.splitlines() if ln.startswith("lower link's centre"))
    x, y, z = (float(v) for v in re.findall(r"[-+]?\d+\.\d*(?:e[-+]?\d+)?", line.split(":", 1)[1]))
    # the lower link's centre stays 1 m from the elbow and within 2 m of the shoulder (rigid links)
    assert abs(y) < 1e-9 and 0.0 < (x * x + z * z) ** 0.5 <= 1.5 + 1e-6
    assert (tmp_path / "double_pendulum.png").stat().st_size > 10_000


def test_the_wheel_carries_package_data_and_the_scenarios(wheel_venv, tmp_path):
    env_dir, whl = wheel_venv
    import zipfile

    names = zipfile.ZipFile(whl).namelist()
    for need in ("proleg/py.typed", "proleg/report/vendor/three.min.js", "proleg/papers/__init__.py", "proleg/papers/hyq_report.py"):
        assert need in names, need
    p = subprocess.run([str(env_dir / "bin" / "proleg"), "run", "list"], cwd=tmp_path, env=_env(tmp_path),
                       capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr[-2000:]
    assert "hyq-drop" in p.stdout + p.stderr and "scout2-bound" in p.stdout + p.stderr
