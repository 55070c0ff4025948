"""The layers import downward only (model → assembly → solvers → analyses → robots/identify/
study → papers → cli): no import cycle between proleg's modules, counting imports inside functions too
(a function-level import that goes back up a layer is a cycle waiting for the next refactor).

Two checks: the import graph read from the sources (every ``import``/``from ... import`` of a
proleg module, at any depth) has no cycle; and every module imports on its own in a fresh
interpreter, deepest layer last (an order in which a module that needs a higher one first would
fail or leave a partly initialised module).
"""

import ast
import pathlib
import subprocess
import sys

import proleg

SRC = pathlib.Path(proleg.__file__).parent
ROOT = SRC.parent


def _module(path: pathlib.Path) -> str:
    mod = ".".join(path.with_suffix("").relative_to(ROOT).parts)
    return mod[: -len(".__init__")] if mod.endswith(".__init__") else mod


def import_graph() -> dict[str, set[str]]:
    """Edges module → proleg module it imports (the package root ``proleg`` left out: examples of
    robots do ``import proleg as pl`` inside functions by design; it re-exports, it is no layer)."""
    graph = {}
    for f in SRC.rglob("*.py"):
        if "vendor" in f.parts:
            continue
        mod = _module(f)
        pkg = mod if f.name == "__init__.py" else mod.rsplit(".", 1)[0]
        out = set()
        for node in ast.walk(ast.parse(f.read_text())):
            if isinstance(node, ast.ImportFrom):
                if node.level:
                    base = pkg.split(".")[: len(pkg.split(".")) - node.level + 1]
                    target = ".".join(base + ([node.module] if node.module else []))
                else:
                    target = node.module or ""
                for a in node.names:
                    cand = f"{target}.{a.name}"
                    out.add(cand if (ROOT / (cand.replace(".", "/") + ".py")).exists() else target)
            elif isinstance(node, ast.Import):
                out.update(a.name for a in node.names)
        graph[mod] = {m for m in out if m.startswith("proleg.") and m != mod}
    return graph


def find_cycle(graph):
    """A cycle as a list of modules, or None (iterative DFS, colours)."""
    colour, parent = {}, {}
    for start in graph:
        if colour.get(start):
            continue
        stack = [(start, iter(sorted(graph[start])))]
        colour[start] = 1
        while stack:
            node, it = stack[-1]
            nxt = next(it, None)
            if nxt is None:
                colour[node] = 2
                stack.pop()
                continue
            if nxt not in graph:
                continue
            if colour.get(nxt) == 1:
                cyc = [nxt] + [n for n, _ in stack[[n for n, _ in stack].index(nxt) + 1 :]]
                return cyc + [nxt]
            if not colour.get(nxt):
                colour[nxt] = 1
                parent[nxt] = node
                stack.append((nxt, iter(sorted(graph[nxt]))))
    return None


def test_no_import_cycles():
    graph = import_graph()
    assert "proleg.assembly.system" in graph and "proleg.analyses.simulate" in graph
    # the three cycles of issue 20, by name
    for a, b in [("proleg.analyses.simulate", "proleg.control.servo"), ("proleg.assembly.coordinates", "proleg.assembly.system"),
                 ("proleg.assembly.system", "proleg.assembly.extensions"), ("proleg.papers.hyq_report", "proleg.papers.hyq_tests")]:
        assert not (b in graph[a] and a in graph[b]), f"{a} and {b} import each other"
    cyc = find_cycle(graph)
    assert cyc is None, "import cycle: " + " → ".join(cyc)


def test_the_library_does_not_import_the_papers():
    """proleg.papers (the reproductions) builds on the library; no library module imports it back
    (the CLI reaches it only through the module names in its scenario table)."""
    graph = import_graph()
    assert "proleg.papers.hyq_report" in graph and "proleg.robots.hyq_leg" in graph["proleg.papers.hyq_tests"]
    users = sorted(m for m, deps in graph.items() if not m.startswith("proleg.papers") and any(d.startswith("proleg.papers") for d in deps))
    assert not users, f"library modules importing proleg.papers: {users}"


def test_the_cycle_finder_finds_a_cycle():
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) is not None
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": set()}) is None


def test_every_module_imports_in_a_fresh_interpreter_top_layer_first():
    """Top layers first (cli, robots, ... model last): a module whose import needs a module that
    is still being initialised above it fails here."""
    order = ["cli", "papers", "study", "identify", "robots", "report", "io", "analyses", "control", "flex", "fem", "drives", "solvers", "assembly", "spatial", "model"]
    mods = sorted(import_graph(), key=lambda m: (next((k for k, p in enumerate(order) if m.split(".")[1:2] == [p]), len(order)), m))
    code = "import importlib, sys\nfor m in sys.argv[1:]:\n    importlib.import_module(m)\nprint('ok', len(sys.argv) - 1)"
    p = subprocess.run([sys.executable, "-c", code, *mods], capture_output=True, text=True, timeout=600)
    assert p.returncode == 0, p.stderr[-2000:]
    assert p.stdout.strip() == f"ok {len(mods)}"


def test_every_scenario_of_the_cli_table_resolves():
    """The CLI's scenario table names a module and a function for each ``proleg run NAME``: each
    one imports and is callable (the table is the one link from the library to proleg.papers)."""
    import importlib

    from proleg.cli.main import SCENARIOS

    assert {"hyq-drop", "scout2-bound", "flegx-jump", "torso-modal"} <= set(SCENARIOS)
    for name, (module, function, _) in SCENARIOS.items():
        assert callable(getattr(importlib.import_module(module), function)), name


def test_a_scenario_runner_with_free_keywords_names_progress():
    """docs/papers/collect.py passes ``progress=False`` to every runner that takes it. A runner
    whose ``**kwargs`` are model parameters must name ``progress`` itself, or the keyword lands
    among the parameters (torso-modal once failed with "unknown parameter(s) ['progress']")."""
    import importlib
    import inspect

    from proleg.cli.main import SCENARIOS

    for name, (module, function, _) in SCENARIOS.items():
        ps = inspect.signature(getattr(importlib.import_module(module), function)).parameters
        if any(p.kind is p.VAR_KEYWORD for p in ps.values()):
            assert "progress" in ps, f"{name}: {function} takes **kwargs but not progress="
