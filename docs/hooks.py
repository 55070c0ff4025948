"""mkdocs hooks: the generated parts of proleg's documentation.

- API reference: one page per entry under ``reference/`` in mkdocs.yml's nav, a mkdocstrings
  ``::: module`` block listing the names the module re-exports (its ``from .x import Name as Name``
  lines), so the reference follows the curated public API without a hand-kept list.
- Performance: ``<!-- bench: NAME -->`` in a page is replaced by the committed summary table
  ``bench/results/NAME`` (its title, settings and notes; the machine line is reduced to the date,
  commit and load, the machine being stated once on the page), ``<!-- bench-plot: accuracy -->``
  by a work-precision plot drawn from ``bench/results/accuracy.json``.
- Papers: ``<!-- scenario: NAME -->`` is replaced by the tables the scenario's report wrote,
  collected into ``docs/papers/tables/NAME/`` by ``docs/papers/collect.py`` (a scenario runs for
  minutes, too long for a docs build: the tables are committed with the date and commit of the run);
  ``<!-- sources: MODULE -->`` by the parameter-source table ``proleg.robots.MODULE.sources()``,
  computed at build (pure Python, no simulation).

Everything is read from the repository: no network, no simulation, so the build stays fast.
"""

from __future__ import annotations

import ast
import csv
import io
import json
import re
import sys
from pathlib import Path

from mkdocs.structure.files import File

ROOT = Path(__file__).resolve().parent.parent
SRC = ROOT / "src"
BENCH = ROOT / "bench" / "results"
TABLES = ROOT / "docs" / "papers" / "tables"

if str(SRC) not in sys.path:  # the pages' executed examples and the sources tables import proleg
    sys.path.insert(0, str(SRC))


# -- API reference ------------------------------------------------------------------------------
def _reference_pages(nav) -> list[str]:
    out = []
    for item in nav or []:
        if isinstance(item, dict):
            for v in item.values():
                out += _reference_pages(v if isinstance(v, list) else [v])
        elif isinstance(item, str) and item.startswith("reference/") and item != "reference/index.md":
            out.append(item)
    return out


def _reexports(module: str) -> list[str] | None:
    """Names ``module`` re-exports with ``from .x import Name as Name`` (None for a plain module)."""
    path = SRC / module.replace(".", "/")
    init = path / "__init__.py"
    if not init.exists():
        return None
    names = []
    for node in ast.parse(init.read_text()).body:
        if isinstance(node, ast.ImportFrom) and node.level:
            names += [a.asname for a in node.names if a.asname and a.asname == a.name and not a.name.startswith("_")]
    return names or None


def reference_markdown(module: str) -> str:
    names = _reexports(module)
    lines = [f"# `{module}`", "", f"::: {module}", "    options:", "      show_root_heading: false"]
    if names:
        lines += ["      members:"] + [f"        - {n}" for n in names]
    return "\n".join(lines) + "\n"


# -- bench tables -------------------------------------------------------------------------------
_HEADER = re.compile(r"^(\d{4}-\d\d-\d\d)[ \d:]*— (.*)$")


def bench_markdown(name: str) -> str:
    path = BENCH / name
    if not path.exists():
        raise FileNotFoundError(f"docs: bench/results/{name} is not in the repository; run its bench script and commit the summary")
    if path.suffix == ".csv":
        rows = list(csv.reader(path.open()))
        out = ["| " + " | ".join(rows[0]) + " |", "|" + "---:|" * len(rows[0])]
        out += ["| " + " | ".join(_fmt(c) for c in r) + " |" for r in rows[1:]]
        return "\n".join(out) + f"\n\n<small>bench/results/{name}</small>\n"
    out, note = [], ""
    for line in path.read_text().splitlines():
        if line.startswith("# "):
            out.append("### " + re.sub(r" \(issue \d+\)", "", line[2:]))
            continue
        m = _HEADER.match(line)
        if m:
            git = re.search(r"git ([0-9a-f]{7,})", m.group(2))
            load = re.search(r"load average \(1 min\) at the end ([\d.]+)", m.group(2))
            note = (f"<small>bench/results/{name}: measured {m.group(1)}"
                    + (f", commit {git.group(1)}" if git else "")
                    + (f", load average {float(load.group(1)):.1f} at the end" if load else "") + "</small>")
            continue
        out.append(line)
    return "\n".join(out).strip() + "\n\n" + note + "\n"


def _fmt(c: str) -> str:
    try:
        x = float(c)
    except ValueError:
        return c
    return c if x == int(x) and abs(x) < 1e7 and "." not in c else f"{x:.4g}"


def accuracy_plot() -> str:
    """Work-precision: global error against wall time, one panel per problem (SVG, inline)."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    rows = json.loads((BENCH / "accuracy.json").read_text())["rows"]
    problems = list(dict.fromkeys(r["problem"] for r in rows))
    fig = Figure(figsize=(3.2 * len(problems), 3.0), layout="constrained")
    axes = fig.subplots(1, len(problems))
    for ax, p in zip(axes, problems):
        for integ in dict.fromkeys(r["integrator"] for r in rows if r["problem"] == p):
            sel = sorted((r for r in rows if r["problem"] == p and r["integrator"] == integ), key=lambda r: r["rtol"])
            ax.loglog([r["wall [s]"] for r in sel], [r["error"] for r in sel], "o-", ms=3, label=integ)
        ax.set_title(p, fontsize=9)
        ax.set_xlabel("wall [s]", fontsize=8)
        ax.grid(alpha=0.3, which="both")
        ax.tick_params(labelsize=7)
        ax.legend(fontsize=6)
    axes[0].set_ylabel("global error", fontsize=8)
    buf = io.StringIO()
    fig.savefig(buf, format="svg")
    svg = buf.getvalue()
    return svg[svg.index("<svg"):] + "\n"


# -- papers -------------------------------------------------------------------------------------
def scenario_markdown(name: str) -> str:
    folder = TABLES / name
    if not folder.is_dir():
        return (f"!!! note \"No tables collected for `{name}` yet\"\n    Run `proleg run {name}` and then "
                f"`python docs/papers/collect.py {name}` to bring its report's tables here.\n")
    meta = json.loads((folder / "meta.json").read_text())
    out = []
    for t in meta["tables"]:
        out.append(f"**{t['title']}** (`results/{name}/{t['file']}`)\n")
        rows = list(csv.reader((folder / t["csv"]).open()))
        out.append("| " + " | ".join(rows[0]) + " |")
        out.append("|" + "---|" * len(rows[0]))
        out += ["| " + " | ".join(_fmt(c) for c in r) + " |" for r in rows[1:]]
        out.append("")
    wall = f", {meta['wall_s']:.0f} s wall with compilation" if meta.get("wall_s") else ""
    load = f" at load average {meta['load_1min']}" if meta.get("load_1min") is not None else ""
    out.append(f"<small>`proleg run {name}` at commit {meta['commit']}, {meta['date']}{wall}{load} "
               f"(the machine: [Performance](../performance.md))</small>\n")
    return "\n".join(out)


def sources_markdown(module: str) -> str:
    import importlib

    mod = importlib.import_module(f"proleg.robots.{module}")
    if hasattr(mod, "sources"):
        rows, origin = mod.sources(), f"proleg.robots.{module}.sources()"
    else:  # scout2: the parameter table its builder attaches to the model (Model I)
        rows, origin = mod.scout2("I").scout2.parameters, f'proleg.robots.{module}("I").scout2.parameters'
    out = ["| quantity | value | unit | source |", "|---|---:|---|---|"]
    for quantity, value, unit, source in rows:
        if isinstance(value, float):
            value = f"{value:.6g}"
        out.append("| " + " | ".join(str(c).replace("|", "\\|") for c in (quantity, value, unit, source)) + " |")
    return "\n".join(out) + f"\n\n<small>`{origin}`, computed when this page was built.</small>\n"


# -- hooks --------------------------------------------------------------------------------------
_PLACEHOLDER = re.compile(r"<!-- (bench|bench-plot|scenario|sources): ([\w.\-]+) -->")


def on_files(files, config):
    for page in _reference_pages(config["nav"]):
        module = Path(page).stem
        files.append(File.generated(config, page, content=reference_markdown(module)))
    if not (ROOT / "docs" / "global-settings.md").exists():
        # docs/global-settings.md comes with issue 32's friction fixes (another branch); until it
        # is merged the nav points at this stub.
        files.append(File.generated(config, "global-settings.md", content=(
            "# Global settings\n\n`import proleg` sets JAX's 64-bit mode (`jax_enable_x64`), XLA-CPU options in "
            "`XLA_FLAGS` (`proleg.XLA_CPU_DEFAULTS`; `PROLEG_XLA_DEFAULTS=0` leaves them alone) and a persistent "
            "compilation cache (`PROLEG_CACHE_DIR`, `\"\"` turns it off).\n")))
    return files


def on_page_markdown(markdown, page, config, files):
    def sub(m):
        kind, arg = m.groups()
        if kind == "bench":
            return bench_markdown(arg)
        if kind == "bench-plot":
            return accuracy_plot()
        if kind == "scenario":
            return scenario_markdown(arg)
        return sources_markdown(arg)

    return _PLACEHOLDER.sub(sub, markdown)
