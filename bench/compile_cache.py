"""Persistent compilation cache: the 7-part model simulated in two fresh processes, one after the other.

Each process (``python -c ...``) imports proleg, assembles the 7-link revolute chain (the
7-part target model of bushing_pendulum.py), runs ``simulate`` once (compile + run) and once
more (run only), and reports its timings plus JAX's own compile events (XLA backend compile
seconds, persistent-cache hits and misses). If the second process finds the first one's
compiled executables on disk, its first ``simulate`` costs about as much as its second.

Modes (``--modes``, default ``fresh none``); each runs its two processes back to back:

``fresh``    PROLEG_CACHE_DIR = a new empty temporary directory: proleg's own persistent-cache
             configuration, starting cold (process 1 compiles and fills it, process 2 loads)
``none``     PROLEG_CACHE_DIR = "" (proleg's switch to disable the cache): both processes compile
``default``  the environment as it is (e.g. ~/.cache/proleg/jax, which may already be warm from
             earlier runs, so process 1 may not be cold)
``jax-env``  JAX's own JAX_COMPILATION_CACHE_DIR = a new temporary directory with a minimum
             compile time of 0 (and PROLEG_CACHE_DIR = ""), to show what the cache gives
             independently of proleg's configuration

Targets: the first compile of a 7-part model under 15 s; a second run in a new process
without recompiling.

``--table`` (issue 20): time from ``import proleg`` to the DataFrame, as a new user meets it:
the README's ten-line double pendulum (2 s, outputs every 1 ms) and the 7-link chain, each in a
fresh process with an empty cache (cold) and again with that cache (warm); the time and the
compile events of each stage (import, assemble, simulate, to_frame: trace, lower, XLA seconds,
executables built) and the compilations ``to_frame`` triggered (target 0). Targets: README
example ≤ 3 s cold, ≤ 1 s warm; 7-link chain ≤ 6 s cold. ``hyq`` adds the whole HyQ
(``proleg.robots.hyq()``, 0.3 s of its drop) as a HyQ model's first run. ``--src DIR`` runs
the same children on another checkout's sources too (PYTHONPATH, interleaved with this one's
runs so both see the same load): issue 29's "time to first result must not regress" is this
table with ``--src`` a worktree of the commit before ``integrator="auto"`` (e754ddf).

``--startup`` (issue 42): what ``import proleg`` costs and which imports make it up, so that an
upstream release that slows start-up is named rather than found by bisection. ``--repeat``
fresh processes (default 5) run ``python -X importtime -c "import proleg"``; the per-module
self times are summed per top-level package (the installed distribution and its version beside
it) and the median over the processes is reported, slowest package first; the same number of
plain ``python -c "import proleg"`` processes give the wall and CPU time without importtime's
own overhead (the CPU time varies least with other jobs' load). ``--src DIR`` prepends DIR to PYTHONPATH for a second set of processes, interleaved
with this one's: a folder holding another version of one dependency (``pip install --no-deps
--target DIR ml_dtypes==0.7.0``) shows what that version costs. Writes
``bench/results/startup.md`` and ``.json``.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

# common.py turns proleg's cache off for this process's own imports; mode "default" restores
# the user's setting for the children.
_USER_CACHE_DIR = os.environ.get("PROLEG_CACHE_DIR")

from common import BENCH_DIR, add_output_args, emit, log  # noqa: E402

CHILD = r"""
import json, sys, time
t0 = time.perf_counter()
import jax
import proleg as pl
t_import = time.perf_counter() - t0
sys.path.insert(0, {bench!r})
from common import CompileEvents, build_chain, timed, timed_cpu
system, t_asm = timed(pl.assemble, build_chain(7))
with CompileEvents() as ev:
    r1, t_first, c_first = timed_cpu(pl.simulate, system, t_end={t_end!r}, dt_output=0.01, progress=False)
r2, t_second = timed(pl.simulate, system, t_end={t_end!r}, dt_output=0.01, progress=False)
out = dict(
    cache_dir=jax.config.jax_compilation_cache_dir,
    t_import=t_import, t_assemble=t_asm, t_first=t_first, c_first=c_first, t_second=t_second,
    steps=r2.stats["steps"], events=ev.summary(),
)
print("RESULT " + json.dumps(out))
"""

CHILD_TABLE = r"""
import json, sys, time
t0, c0 = time.perf_counter(), time.process_time()
import jax
import proleg as pl
t_import = time.perf_counter() - t0
sys.path.insert(0, {bench!r})
from common import CompileEvents, build_chain, readme_model
stages = {{}}

def stage(name, fn):
    with CompileEvents() as ev:
        t = time.perf_counter()
        out = fn()
        stages[name] = dict(wall=time.perf_counter() - t, **{{k: v for k, v in ev.summary().items() if k != "xla by function [s]"}})
    return out

if {model!r} == "hyq":
    from proleg.robots import hyq
    model, t_end, dt = hyq(), 0.3, 1e-3
else:
    model = readme_model() if {model!r} == "readme" else build_chain(7)
    t_end, dt = (2.0, 1e-3) if {model!r} == "readme" else (1.0, 1e-3)
system = stage("assemble", lambda: pl.assemble(model))
result = stage("simulate", lambda: pl.simulate(system, t_end=t_end, dt_output=dt))
df = stage("to_frame", lambda: result.to_frame())
total = time.perf_counter() - t0
cpu = time.process_time() - c0
try:
    import proleg.compile_cache as cc
    exports = {{k: cc.stats[k] for k in ("loaded", "exported", "unkeyed")}}
except ImportError:  # a proleg before the compile cache (for a before/after table)
    exports = {{"loaded": 0, "exported": 0, "unkeyed": 0}}
print("RESULT " + json.dumps(dict(t_import=t_import, total=total, cpu=cpu, stages=stages, rows=len(df), cols=len(df.columns), steps=result.stats["steps"],
                                  exports=exports, integrator=str(result.stats.get("integrator", "GeneralizedAlpha (default)")))))
"""

TABLE_COLUMNS = [
    "model", "cache", "import → table [s]", "CPU [s]", "import [s]", "assemble [s]", "simulate [s]", "to_frame [s]",
    "trace [s]", "lower [s]", "xla [s]", "executables", "to_frame executables", "cache hits", "traced fns loaded/written",
    "steps", "table", "runs", "integrator", "source",
]


def run_table(model: str, env: dict, cache: str, source: str = "this checkout") -> dict:
    code = CHILD_TABLE.format(bench=str(BENCH_DIR), model=model)
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=1800)
    line = next((ln for ln in p.stdout.splitlines() if ln.startswith("RESULT ")), None)
    if p.returncode != 0 or line is None:
        tail = (p.stderr or p.stdout).strip().splitlines()[-5:]
        return {"model": model, "cache": cache, "source": source, "status": f"child failed (rc {p.returncode}): " + " | ".join(tail)}
    r = json.loads(line[len("RESULT "):])
    st = r["stages"]
    tot = lambda k: sum(s.get(k, 0) for s in st.values())  # noqa: E731
    return {
        "model": model, "cache": cache, "import → table [s]": r["total"], "CPU [s]": r["cpu"], "import [s]": r["t_import"],
        "assemble [s]": st["assemble"]["wall"], "simulate [s]": st["simulate"]["wall"], "to_frame [s]": st["to_frame"]["wall"],
        "trace [s]": tot("trace [s]"), "lower [s]": tot("lower [s]"), "xla [s]": tot("xla [s]"),
        "executables": tot("xla compiles"), "to_frame executables": st["to_frame"]["xla compiles"],
        "cache hits": tot("cache hits"), "steps": r["steps"], "table": f"{r['rows']} × {r['cols']}",
        "traced fns loaded/written": f"{r['exports']['loaded']}/{r['exports']['exported']}" + (f" ({r['exports']['unkeyed']} unkeyed)" if r["exports"]["unkeyed"] else ""),
        "integrator": r.get("integrator"), "source": source,
    }


def main_table(args):
    if args.out.endswith("compile_cache.md"):
        args.out = args.out[: -len("compile_cache.md")] + "time_to_table.md"
    # A user's installed proleg has its bytecode compiled (pip, or the first import of an editable
    # install); PYTHONDONTWRITEBYTECODE (set in some sandboxes) would make every child compile
    # proleg's sources again (~0.08 s of a warm start). One import fills __pycache__ first.
    base = dict(os.environ)
    base.pop("PYTHONDONTWRITEBYTECODE", None)
    base.pop("JAX_COMPILATION_CACHE_DIR", None)
    subprocess.run([sys.executable, "-c", "import proleg"], env=dict(base, PROLEG_CACHE_DIR=""), check=True, capture_output=True)
    sources = [("this checkout", None)] + [(f"src {d}", d) for d in args.src]
    for _, d in sources[1:]:
        subprocess.run([sys.executable, "-c", "import proleg"], env=dict(base, PROLEG_CACHE_DIR="", PYTHONPATH=d), check=True, capture_output=True)
    rows = []
    for model in args.models:
        runs = {(s, c): [] for s, _ in sources for c in ("cold", "warm")}
        reps = args.repeat or (2 if model == "hyq" else 5)
        for i in range(reps):
            for source, src in sources:  # interleaved: the same load for every source
                tmp = tempfile.TemporaryDirectory(prefix="proleg-jax-cache-")
                env = dict(base, PROLEG_CACHE_DIR=tmp.name, **({"PYTHONPATH": src} if src else {}))
                try:
                    for cache in ("cold", "warm"):
                        log(f"{model} ({source}): {cache} ({i + 1}/{reps}) ...")
                        row = run_table(model, env, cache, source)
                        log(f"  {row}")
                        runs[(source, cache)].append(row)
                finally:
                    tmp.cleanup()
        for (_, cache), rs in runs.items():
            ok = sorted((r for r in rs if "import → table [s]" in r), key=lambda r: r["import → table [s]"])
            if not ok:
                rows.append(rs[-1])
                continue
            row = dict(ok[(len(ok) - 1) // 2])  # the median run (the lower one of an even count)
            row["runs"] = f"{len(ok)}: {ok[0]['import → table [s]']:.2f}–{ok[-1]['import → table [s]']:.2f}"
            rows.append(row)
    targets = {("readme", "cold"): 3.0, ("readme", "warm"): 1.0, ("chain7", "cold"): 6.0}
    notes = [
        "Each row is the median of `runs` fresh Python processes (its range after the colon; cold: an empty "
        "PROLEG_CACHE_DIR each time; warm: the cache the cold run before it filled), with proleg's bytecode compiled as "
        "in an installed package. "
        "trace/lower/xla = JAX's compile events summed over the stages (xla includes loading from the cache); "
        "executables = backend compilations or cache loads; to_frame executables = those to_frame triggered (target 0); "
        "traced fns loaded/written = functions whose trace and lowering proleg.compile_cache loaded from / wrote to disk; "
        "CPU = the process's CPU time (all threads), less sensitive to other jobs' load than the wall time.",
    ]
    for r in rows:
        tgt = targets.get((r["model"], r["cache"])) if r.get("source", "this checkout") == "this checkout" else None
        if tgt is not None and "import → table [s]" in r:
            notes.append(f"{r['model']} {r['cache']}: {r['import → table [s]']:.1f} s from import to the table, target ≤ {tgt:g} s: "
                         + ("met." if r["import → table [s]"] <= tgt else "not met."))
    cols = TABLE_COLUMNS + (["status"] if any("status" in r for r in rows) else [])
    emit(args, "Time from import to the table (issue 20)", rows, cols, {"models": args.models}, notes)


def parse_importtime(stderr: str) -> dict[str, tuple[float, float]]:
    """``-X importtime`` lines as {module: (self [s], cumulative [s])} (the last line for a module
    wins; a module is imported once per process)."""
    out = {}
    for line in stderr.splitlines():
        if not line.startswith("import time:") or "imported package" in line:
            continue
        try:
            _, self_us, cum_us, name = (part.strip() for part in line.replace("import time:", "|", 1).split("|", 3))
            out[name] = (int(self_us) / 1e6, int(cum_us) / 1e6)
        except ValueError:
            continue
    return out


def package_times(modules: dict[str, tuple[float, float]]) -> dict[str, dict[str, float]]:
    """Per top-level package: {module: self time [s]} of its modules."""
    out: dict[str, dict[str, float]] = {}
    for name, (self_s, _) in modules.items():
        out.setdefault(name.split(".", 1)[0], {})[name] = self_s
    return out


_VERSIONS = r"""
import importlib.metadata as md, json, sys
tops = json.loads(sys.argv[1])
dists = md.packages_distributions()
out = {}
for top in tops:
    names = dists.get(top)
    if not names:
        out[top] = "stdlib" if top in sys.stdlib_module_names or top.startswith("_") else ""
        continue
    try:
        out[top] = f"{names[0]} {md.version(names[0])}"
    except md.PackageNotFoundError:
        out[top] = names[0]
print(json.dumps(out))
"""


def distributions(tops, env) -> dict[str, str]:
    """The installed distribution and version behind each top-level package, as the children see
    them (``env``: their PYTHONPATH may put another version first)."""
    p = subprocess.run([sys.executable, "-c", _VERSIONS, json.dumps(sorted(tops))], env=env, capture_output=True, text=True, check=True)
    return json.loads(p.stdout)


def _children_cpu() -> float:
    """CPU seconds (user + system) of this process's waited-for children so far."""
    import resource

    ru = resource.getrusage(resource.RUSAGE_CHILDREN)
    return ru.ru_utime + ru.ru_stime


def main_startup(args):
    """``--startup``: the import of proleg split per package (see the module docstring)."""
    import statistics

    if args.out.endswith("compile_cache.md"):
        args.out = args.out[: -len("compile_cache.md")] + "startup.md"
    base = dict(os.environ)
    base.pop("PYTHONDONTWRITEBYTECODE", None)  # an installed package has its bytecode compiled
    sources = [("this checkout", None)] + [(f"PYTHONPATH {d}", d) for d in args.src]
    reps = args.repeat if args.repeat else 5
    for _, d in sources:  # one import first fills __pycache__
        subprocess.run([sys.executable, "-c", "import proleg"], env=dict(base, **({"PYTHONPATH": d} if d else {})), check=True, capture_output=True)
    runs = {s: {"wall": [], "cpu": [], "modules": []} for s, _ in sources}
    for i in range(reps):
        for source, d in sources:  # interleaved: the same load for every source
            env = dict(base, **({"PYTHONPATH": d} if d else {}))
            log(f"startup ({source}) {i + 1}/{reps} ...")
            t0, c0 = time.perf_counter(), _children_cpu()
            subprocess.run([sys.executable, "-c", "import proleg"], env=env, check=True, capture_output=True)
            runs[source]["wall"].append(time.perf_counter() - t0)
            runs[source]["cpu"].append(_children_cpu() - c0)
            p = subprocess.run([sys.executable, "-X", "importtime", "-c", "import proleg"], env=env, check=True, capture_output=True, text=True)
            runs[source]["modules"].append(parse_importtime(p.stderr))
    rows, notes = [], []
    for source, d in sources:
        r = runs[source]
        per_pkg = [package_times(m) for m in r["modules"]]
        total = statistics.median(m.get("proleg", (0.0, 0.0))[1] for m in r["modules"])
        wall = statistics.median(r["wall"])

        def pkg(k):  # median over the processes of the package's summed self time
            return statistics.median(sum(p.get(k, {}).values()) for p in per_pkg)

        def slowest(k):  # the package's module of largest median self time, and that time
            mods = {mod for p in per_pkg for mod in p.get(k, {})}
            med = {mod: statistics.median(p.get(k, {}).get(mod, 0.0) for p in per_pkg) for mod in mods}
            mod = max(med, key=med.get)
            return mod, med[mod]

        tops = sorted({k for p in per_pkg for k in p}, key=lambda k: -pkg(k))
        version = distributions(tops[: args.top], dict(base, **({"PYTHONPATH": d} if d else {})))
        rows.append({"source": source, "package": "python -c 'import proleg' (process wall)", "version": "",
                     "self [s]": wall, "share": "", "slowest module": "", "module self [s]": "",
                     "runs": f"{reps}: {min(r['wall']):.2f}–{max(r['wall']):.2f}"})
        rows.append({"source": source, "package": "python -c 'import proleg' (process CPU)", "version": "",
                     "self [s]": statistics.median(r["cpu"]), "share": "", "slowest module": "", "module self [s]": "",
                     "runs": f"{reps}: {min(r['cpu']):.2f}–{max(r['cpu']):.2f}"})
        rows.append({"source": source, "package": "import proleg (-X importtime, cumulative)", "version": "",
                     "self [s]": total, "share": "100 %", "slowest module": "", "module self [s]": "", "runs": str(reps)})
        for k in tops[: args.top]:
            mod, mod_s = slowest(k)
            rows.append({"source": source, "package": k, "version": version.get(k, ""), "self [s]": pkg(k),
                         "share": f"{100 * pkg(k) / total:.0f} %" if total else "", "slowest module": mod,
                         "module self [s]": mod_s, "runs": str(sum(k in p for p in per_pkg))})
        names = ", ".join(f"{k} {pkg(k):.2f} s" for k in tops[:3])
        notes.append(f"{source}: `import proleg` {total:.2f} s under -X importtime ({wall:.2f} s process wall, median of {reps}); "
                     f"slowest packages: {names}.")
    notes.insert(0, "self [s] = the median over the processes of the package's modules' own import times summed (-X importtime's "
                    "'self' column, children excluded), so the rows add up to the cumulative import; slowest module = the "
                    "package's module of largest median self time. The process wall adds the interpreter's start and exit and "
                    "has no importtime overhead. Process CPU = that process's user + system time (all threads): it varies least "
                    "with other jobs' load. The rest are wall times: on a loaded machine compare the rows of one run, not runs.")
    emit(args, "Start-up: the slowest imports of `import proleg`", rows,
         ["source", "package", "version", "self [s]", "share", "slowest module", "module self [s]", "runs"],
         {"processes": reps, "packages shown": args.top}, notes)


COLUMNS = [
    "mode", "process", "cache dir", "process [s]", "import [s]", "assemble [s]", "first simulate [s]",
    "second simulate [s]", "compile [s]", "first cpu [s]", "xla [s]", "executables", "cache hits", "cache misses",
]


def run_child(t_end: float, env: dict) -> dict:
    code = CHILD.format(bench=str(BENCH_DIR), t_end=t_end)
    t0 = time.perf_counter()
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=1800)
    wall = time.perf_counter() - t0
    line = next((ln for ln in p.stdout.splitlines() if ln.startswith("RESULT ")), None)
    if p.returncode != 0 or line is None:
        tail = (p.stderr or p.stdout).strip().splitlines()[-5:]
        return {"process [s]": wall, "status": f"child failed (rc {p.returncode}): " + " | ".join(tail)}
    r = json.loads(line[len("RESULT "):])
    ev = r["events"]
    return {
        "cache dir": r["cache_dir"] or "none",
        "process [s]": wall,
        "import [s]": r["t_import"],
        "assemble [s]": r["t_assemble"],
        "first simulate [s]": r["t_first"],
        "second simulate [s]": r["t_second"],
        "compile [s]": r["t_first"] - r["t_second"],
        "xla [s]": ev["xla [s]"],
        "first cpu [s]": r["c_first"],
        "executables": ev["xla compiles"],
        "cache hits": ev["cache hits"],
        "cache misses": ev["cache misses"],
        "steps": r["steps"],
    }


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--t-end", type=float, default=10.0, help="simulated time [s] (default 10)")
    ap.add_argument("--modes", nargs="+", choices=["fresh", "none", "default", "jax-env"], default=["fresh", "none"])
    ap.add_argument("--table", action="store_true", help="time from import to the DataFrame (issue 20) instead")
    ap.add_argument("--models", nargs="+", choices=["readme", "chain7", "hyq"], default=["readme", "chain7", "hyq"])
    ap.add_argument("--startup", action="store_true", help="the slowest imports of `import proleg` (-X importtime), to bench/results/startup.md")
    ap.add_argument("--top", type=int, default=12, help="--startup: packages listed per source (default 12)")
    ap.add_argument("--src", nargs="*", default=[], help="--table, --startup: also run the children with PYTHONPATH=DIR (another checkout's src/, "
                    "e.g. a worktree of an older commit), interleaved with this checkout's runs, for a before/after table")
    add_output_args(ap, "compile_cache")
    ap.set_defaults(repeat=None)  # --table: cold/warm pairs per model, the median reported (default 5)
    args = ap.parse_args(argv)
    if args.table:
        return main_table(args)
    if args.startup:
        return main_startup(args)

    rows = []
    for mode in args.modes:
        env = dict(os.environ)
        tmp = None
        if mode in ("fresh", "jax-env"):
            tmp = tempfile.TemporaryDirectory(prefix="proleg-jax-cache-")
        if mode == "fresh":
            env["PROLEG_CACHE_DIR"] = tmp.name
            env.pop("JAX_COMPILATION_CACHE_DIR", None)
        elif mode == "none":
            env["PROLEG_CACHE_DIR"] = ""
            env.pop("JAX_COMPILATION_CACHE_DIR", None)
        elif mode == "default":
            if _USER_CACHE_DIR is None:
                env.pop("PROLEG_CACHE_DIR", None)
            else:
                env["PROLEG_CACHE_DIR"] = _USER_CACHE_DIR
        elif mode == "jax-env":
            env["PROLEG_CACHE_DIR"] = ""
            env["JAX_COMPILATION_CACHE_DIR"] = tmp.name
            env["JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS"] = "0"
            env["JAX_PERSISTENT_CACHE_MIN_ENTRY_SIZE_BYTES"] = "0"
        try:
            for i in (1, 2):
                log(f"{mode}: process {i} ...")
                row = {"mode": mode, "process": i, **run_child(args.t_end, env)}
                log(f"  {row}")
                rows.append(row)
        finally:
            if tmp is not None:
                tmp.cleanup()

    notes = [
        "Each row is a fresh Python process; 'first simulate' = compile + run, 'second simulate' = run only, "
        "compile = their difference; first cpu = CPU seconds of the first simulate (all threads; less "
        "sensitive to other load than wall time); xla = seconds in the XLA backend compiler or loading "
        "from the cache; executables = jitted computations built (compiled or loaded).",
    ]
    for mode in args.modes:
        pr = [r for r in rows if r["mode"] == mode and "compile [s]" in r]
        if len(pr) == 2:
            a, b = pr
            if a["cache hits"]:
                notes.append(f"{mode}: process 1 already found {a['cache hits']} executables in the cache (not a cold start).")
            notes.append(
                f"{mode}: process 2 compile {b['compile [s]']:.1f} s vs process 1 {a['compile [s]']:.1f} s "
                f"({b['cache hits']} cache hits); first compile {'meets' if a['compile [s]'] < 15 else 'misses'} "
                f"the < 15 s target (assemble adds {a['assemble [s]']:.1f} s)."
            )
    cols = COLUMNS + (["status"] if any("status" in r for r in rows) else [])
    emit(args, f"Persistent compilation cache, 7-part chain, {args.t_end:g} s simulated", rows, cols, {"t_end [s]": args.t_end}, notes)


if __name__ == "__main__":
    sys.exit(main())
