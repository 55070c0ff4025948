"""mkdocs hooks: the generated parts of proleg's documentation.

- API reference: one page per entry under ``reference/`` in mkdocs.yml's nav, a mkdocstrings
  ``::: module`` block listing the names the module re-exports (its ``from .x import Name as Name``
  lines), so the reference follows the curated public API without a hand-kept list.
- Performance: ``<!-- bench: NAME -->`` in a page is replaced by the committed summary table
  ``bench/results/NAME`` (.md, .csv or .json; several .json names with the same columns make one
  table): its title, settings, table and notes, and a line naming the file with the date and
  commit of the run. The machine is stated once on the page; a table measured on another one
  (the GPU host) names it in that line. Adding a table to a page is one such line.
  ``<!-- bench-plot: accuracy -->`` is a work-precision plot drawn from
  ``bench/results/accuracy.json``.
- Papers: ``<!-- scenario: NAME -->`` is replaced by the tables the scenario's report wrote,
  collected into ``docs/papers/tables/NAME/`` by ``docs/papers/collect.py`` (a scenario runs for
  minutes, too long for a docs build: the tables are committed with the date and commit of the run);
  ``<!-- scenario-walls: all -->`` by the wall time of each of those runs (Performance);
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


# -- bench tables ---------------------------------------------------------------------------------
_HEADER = re.compile(r"^(\d{4}-\d\d-\d\d)[ \d:]*— (.*)$")
#: the machine the Performance page states once; a table measured elsewhere names its own
PAGE_MACHINE = re.compile(r"\(2 cores(, [12] used)?\)")
OTHER_BACKEND = re.compile(r"JAX [\d.]+ \((?!cpu\))\w+\)")


def _provenance(name: str, date: str, header: str) -> str:
    """The line under a table: its file, the date and commit of the run, and the machine only when
    it is not the one the page states (a GPU host, another core count)."""
    git = re.search(r"git ([0-9a-f]{7,})", header)
    machine = ""
    if not PAGE_MACHINE.search(header) or OTHER_BACKEND.search(header):
        cpu = re.match(r"(.*?) \((\d+) cores(?:, (\d+) used)?\)", header)
        jax = re.search(r"JAX ([\d.]+)(?: \((\w+)\))?", header)
        parts = [f"{cpu.group(1)}, {cpu.group(3) or cpu.group(2)} of {cpu.group(2)} cores" if cpu else "",
                 (f"JAX {jax.group(1)}" + (f" ({jax.group(2)})" if jax.group(2) else "")) if jax else ""]
        machine = "".join(f", {x}" for x in parts if x)
    return f"<small>bench/results/{name}: {date}" + (f", commit {git.group(1)}" if git else "") + f"{machine}</small>"


def _json_header(doc: dict) -> str:
    """An emit() JSON's machine as the one-line header its .md carries."""
    m = doc.get("machine", {})
    return (f"{m.get('cpu')} ({m.get('cpu_count')} cores, {m.get('cores_used', m.get('cpu_count'))} used), "
            f"JAX {m.get('jax')} ({m.get('jax_backend')}), proleg (git {m.get('git')})")


def _cell(v) -> str:
    if isinstance(v, float):
        if v != v:
            return ""
        return f"{v:,.0f}" if abs(v) >= 1000 else f"{v:.4g}"
    if isinstance(v, int) and not isinstance(v, bool):
        return f"{v:,}"
    return "" if v is None else str(v).replace("|", "\\|")


def bench_json_markdown(names: list[str]) -> str:
    """One table from the rows of one or more bench JSON files (``common.emit``'s format; their
    columns are those of the first), the title and notes of the first, each file's provenance."""
    docs = []
    for name in names:
        path = BENCH / name
        if not path.exists():
            raise FileNotFoundError(f"docs: bench/results/{name} is not in the repository; run its bench script and commit the summary")
        docs.append((name, json.loads(path.read_text())))
    cols = docs[0][1]["columns"]
    out = ["### " + re.sub(r" \(issue \d+\)", "", docs[0][1]["title"]), "",
           "| " + " | ".join(cols) + " |", "|" + "|".join("---" if k == 0 else "---:" for k in range(len(cols))) + "|"]
    for _, doc in docs:
        out += ["| " + " | ".join(_cell(r.get(c)) for c in cols) + " |" for r in doc["rows"]]
    out.append("")
    if len(docs) == 1:
        out += [f"- {n}" for n in docs[0][1].get("notes", [])]
    out += ["", "<br>".join(_provenance(n, d.get("date", "")[:10], _json_header(d)) for n, d in docs)]
    return "\n".join(out) + "\n"


def bench_markdown(name: str) -> str:
    """``<!-- bench: NAME [NAME ...] -->``: a committed bench summary as a page section. NAME.md
    (``common.emit``'s markdown, or a hand-made summary in the same shape: a ``# title``, the
    run's line, tables and notes), NAME.csv (a plain table) or NAME.json (``emit``'s JSON; several
    JSON files with the same columns become one table)."""
    names = name.split()
    if len(names) > 1 or names[0].endswith(".json"):
        return bench_json_markdown(names)
    path = BENCH / name
    if not path.exists():
        raise FileNotFoundError(f"docs: bench/results/{name} is not in the repository; run its bench script and commit the summary")
    if path.suffix == ".csv":
        rows = list(csv.reader(path.open()))
        out = ["| " + " | ".join(rows[0]) + " |", "|" + "---:|" * len(rows[0])]
        out += ["| " + " | ".join(_fmt(c) for c in r) + " |" for r in rows[1:]]
        return "\n".join(out) + f"\n\n<small>bench/results/{name}</small>\n"
    out, note, fenced = [], f"<small>bench/results/{name}</small>", False
    for line in path.read_text().splitlines():
        if line.startswith("```"):
            fenced = not fenced
        h = None if fenced else re.match(r"^(#+) (.*)$", line)
        if h:  # the file's headings sit two levels below the page's sections
            out.append("#" * min(len(h.group(1)) + 2, 6) + " " + re.sub(r" \(issue \d+\)", "", h.group(2)))
            continue
        m = _HEADER.match(line)
        if m:
            note = _provenance(name, m.group(1), m.group(2))
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


def scenario_walls_markdown() -> str:
    """Wall time of each scenario run whose tables the papers' pages show (docs/papers/tables/*/
    meta.json, written by collect.py), with the load it ran under."""
    metas = [json.loads(p.read_text()) for p in sorted(TABLES.glob("*/meta.json"))]
    metas = [m for m in metas if m.get("wall_s")]
    out = ["| scenario | wall with compilation | load average (1 min) at the end |", "|---|---:|---:|"]
    for m in metas:
        w = m["wall_s"]
        wall = f"{w:.0f} s" if w < 90 else f"{int(w // 60)} min {w % 60:02.0f} s"
        load = m.get("load_1min")
        out.append(f"| `proleg run {m['scenario']}` | {wall} | {'' if load is None else f'{load:.1f}'} |")
    dates = sorted(m["date"] for m in metas)
    when = dates[0] if dates[0] == dates[-1] else f"{dates[0]} to {dates[-1]}"
    return ("\n".join(out) + f"\n\n<small>docs/papers/tables/*/meta.json: the runs the papers' pages show, {when}, each "
            f"with its commit there; a scenario's note in its meta.json says when a run was resumed</small>\n")


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
_PLACEHOLDER = re.compile(r"<!-- (bench|bench-plot|scenario-walls|scenario|sources): ([\w.\-]+(?: [\w.\-]+)*) -->")


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
        if kind == "scenario-walls":
            return scenario_walls_markdown()
        if kind == "scenario":
            return scenario_markdown(arg)
        return sources_markdown(arg)

    return _PLACEHOLDER.sub(sub, markdown)
