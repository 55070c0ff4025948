"""The documentation cannot rot: every README code block and every docs example runs, and the
site builds with warnings as errors (``mkdocs build --strict``, as CI does).

The docs examples are the ``python`` blocks of docs/**/*.md. A python block that the build would
not execute (no ``exec="on"``) is refused: it could rot unseen. With the docs tools installed the
strict build runs them (markdown-exec; a failing block fails --strict); without them each page's
blocks run here, in order, one namespace per markdown-exec session, as the build would run them.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
FENCE = re.compile(r"^```(\w+)([^\n]*)\n(.*?)^```", re.M | re.S)


def blocks(path: Path, lang: str = "python"):
    """(options, code) of every fenced block in ``lang`` (the text after the language is its options)."""
    return [(m.group(2).strip(), m.group(3)) for m in FENCE.finditer(path.read_text()) if m.group(1) == lang]


def _run(code: str, cwd: Path, timeout: float = 600):
    env = dict(os.environ, PYTHONPATH=str(ROOT / "src") + os.pathsep + os.environ.get("PYTHONPATH", ""), MPLBACKEND="Agg")
    return subprocess.run([sys.executable, "-c", code], cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout)


def _sessions(path: Path) -> dict[str, str]:
    out: dict[str, str] = {}
    for k, (opts, code) in enumerate(blocks(path)):
        m = re.search(r'session="([^"]+)"', opts)
        out.setdefault(m.group(1) if m else f"block{k}", "")
        out[m.group(1) if m else f"block{k}"] += code + "\n"
    return out


DOC_PAGES = sorted(p for p in DOCS.rglob("*.md") if blocks(p))


def test_the_docs_have_examples_and_the_readme_has_code():
    assert len(DOC_PAGES) >= 8, [p.name for p in DOC_PAGES]
    assert blocks(ROOT / "README.md"), "README.md has no python block"


def test_every_docs_python_block_is_executed_by_the_build():
    for page in DOC_PAGES:
        for opts, code in blocks(page):
            assert 'exec="on"' in opts, f"{page.name}: a python block without exec=\"on\" is not run by the build:\n{code[:200]}"


def _docs_tools() -> str | None:
    """The first docs tool that is missing, or None."""
    return next((m for m in ("mkdocs", "material", "mkdocstrings_handlers.python", "markdown_exec") if not _has_module(m)), None)


@pytest.mark.parametrize("page", DOC_PAGES, ids=lambda p: str(p.relative_to(DOCS)))
def test_docs_examples_run(page):
    """Without the docs tools, the examples run here; with them, test_mkdocs_build_strict runs
    every one of them (markdown-exec executes the blocks, and a failing block fails --strict),
    so running them twice would only double the suite's compile time."""
    if _docs_tools() is None:
        pytest.skip("the docs examples run in test_mkdocs_build_strict (markdown-exec; a failing block fails --strict)")
    for name, code in _sessions(page).items():
        p = _run(code, ROOT)
        assert p.returncode == 0, f"{page.name} [{name}]:\n{p.stderr[-3000:]}"


def test_readme_code_blocks_run(tmp_path):
    """All python blocks of README.md, in order in one process, outside the source tree (the ten
    lines save their plot into the working folder)."""
    code = "\n".join(c for _, c in blocks(ROOT / "README.md"))
    p = _run(code, tmp_path)
    assert p.returncode == 0, p.stderr[-3000:]
    assert "lower link" in p.stdout
    assert (tmp_path / "double_pendulum.png").stat().st_size > 10_000


def test_mkdocs_build_strict(tmp_path):
    """``mkdocs build --strict`` into a temporary folder: broken links, missing pages, docstrings
    mkdocstrings cannot parse and failing examples are errors."""
    missing = _docs_tools()
    if missing:
        pytest.skip(f"{missing} is not installed: pip install 'proleg[docs]' to build the documentation")
    env = dict(os.environ, PYTHONPATH=str(ROOT / "src") + os.pathsep + os.environ.get("PYTHONPATH", ""), MPLBACKEND="Agg")
    p = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(tmp_path / "site")],
                       cwd=ROOT, env=env, capture_output=True, text=True, timeout=1800)
    assert p.returncode == 0, p.stderr[-5000:]
    site = tmp_path / "site"
    for page in ("index.html", "performance/index.html", "papers/seed-000/index.html", "reference/proleg/index.html",
                 "sources/formulation/index.html"):
        assert (site / page).exists(), page
    index = (site / "index.html").read_text()
    assert "lower link&#39;s centre at t = 2 s" in index or "lower link's centre at t = 2 s" in index  # the example ran
    assert "<svg" in index  # and drew its plot


def _has_module(name: str) -> bool:
    import importlib.util

    try:
        return importlib.util.find_spec(name) is not None
    except ModuleNotFoundError:
        return False


def test_every_bench_table_the_docs_show_is_committed():
    """A bench summary the docs include must be tracked by git, not just present here: CI builds
    the site from a fresh clone, where an ignored bench/results file does not exist."""
    try:
        tracked = subprocess.run(["git", "ls-files", "bench/results"], cwd=ROOT, capture_output=True,
                                 text=True, check=True).stdout.split()
    except (OSError, subprocess.CalledProcessError):
        pytest.skip("not a git checkout: nothing to compare the docs' bench tables with")
    placeholder = re.compile(r"<!-- bench: ([\w.\-]+) -->")
    wanted = {m.group(1) for p in DOCS.rglob("*.md") for m in placeholder.finditer(p.read_text())} - {"NAME"}
    wanted.add("accuracy.json")  # <!-- bench-plot: accuracy --> draws it
    missing = sorted(n for n in wanted if f"bench/results/{n}" not in tracked)
    assert not missing, f"docs include bench/results files that are not committed (git add -f): {missing}"


def test_every_table_the_docs_collect_is_written_by_its_reproduction():
    """docs/papers/collect.py reads named Parquet files from each scenario's results; a report
    that stops writing one (renamed or split, as the torso's calibrated/predicted tables were)
    would leave the docs showing a stale table or fail the collection. Each name must be written
    by proleg's reproduction code."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("_collect", DOCS / "papers" / "collect.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    src = "\n".join(p.read_text() for d in ("papers", "robots", "study") for p in (ROOT / "src" / "proleg" / d).glob("*.py"))
    def written(name):  # the file name, or its stem when the report builds the name (f"{name}.parquet")
        stem = name.rsplit(".", 1)[0]
        return any(f"{q}{n}{q}" in src for n in (name, stem) for q in "\"'")

    missing = sorted(f"{scenario}: {name}" for scenario, tables in mod.TABLES.items() for name, *_ in tables if not written(name))
    assert not missing, f"docs/papers/collect.py expects tables no reproduction writes: {missing}"
