"""Shared helpers for the proleg benchmarks: models, timing, tables, JSON/markdown output.

Every script in ``bench/`` prints one table (rich if installed, else markdown) and writes it to
``bench/results/<name>.md`` and ``.json`` (``--out`` changes the path). With ``--json`` the
table goes to stdout as ONE JSON object and nothing else is printed there (progress and notes
go to stderr).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import subprocess
import sys
import time
from pathlib import Path


def _early_blas_threads(argv=None):
    """``--blas-threads N`` must reach OPENBLAS_NUM_THREADS before numpy/scipy load OpenBLAS."""
    argv = sys.argv if argv is None else argv
    if "--blas-threads" in argv:
        i = argv.index("--blas-threads")
        if i + 1 < len(argv):
            for k in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
                os.environ[k] = argv[i + 1]


def _busy_fractions(cores, interval=0.2):
    """Busy fraction of each core over ``interval`` seconds, from /proc/stat (None where the
    file is missing: not Linux)."""
    import time

    def sample():
        out = {}
        with open("/proc/stat") as f:
            for line in f:
                head, *vals = line.split()
                if head.startswith("cpu") and head != "cpu":
                    v = [int(x) for x in vals]
                    out[int(head[3:])] = (v[3] + (v[4] if len(v) > 4 else 0), sum(v))  # idle + iowait, total
        return out

    try:
        a = sample()
        time.sleep(interval)
        b = sample()
    except OSError:
        return None
    busy = {}
    for c in cores:
        if c in a and c in b and b[c][1] > a[c][1]:
            busy[c] = 1.0 - (b[c][0] - a[c][0]) / (b[c][1] - a[c][1])
        else:
            busy[c] = 0.0
    return busy


def pick_cores(n, allowed, busy=None):
    """The ``n`` cores of ``allowed`` to run on: the least busy ones (``busy``: core -> busy
    fraction, compared to one decimal so that sampling noise does not reorder idle cores), ties by
    core number, so that two benchmarks started with ``--cpus 1`` on an idle
    2-core machine do not both land on core 0; the first ``n`` where nothing is known."""
    allowed = sorted(allowed)
    n = max(1, min(int(n), len(allowed)))
    if not busy:
        return allowed[:n]
    return sorted(sorted(allowed, key=lambda c: (round(busy.get(c, 0.0), 1), c))[:n])


def _early_cpus(argv=None):
    """``--cpus N`` pins this process to N cores before JAX starts (XLA-CPU sizes its thread pool
    from the affinity mask): the N least busy of its allowed cores over 0.2 s, or exactly the
    cores listed by ``--cores 0,2``."""
    argv = sys.argv if argv is None else argv
    if not hasattr(os, "sched_setaffinity"):
        return
    allowed = os.sched_getaffinity(0)
    if "--cores" in argv:
        i = argv.index("--cores")
        if i + 1 < len(argv):
            want = {int(c) for c in argv[i + 1].split(",") if c.strip()}
            bad = want - allowed
            if bad:
                raise SystemExit(f"--cores {argv[i + 1]}: cores {sorted(bad)} are not available to this process (allowed: {sorted(allowed)}).")
            os.sched_setaffinity(0, want)
    elif "--cpus" in argv:
        i = argv.index("--cpus")
        if i + 1 < len(argv):
            n = int(argv[i + 1])
            busy = _busy_fractions(allowed) if n < len(allowed) else None
            os.sched_setaffinity(0, pick_cores(n, allowed, busy))


def _early_cache_setting(argv=None):
    """Cold compiles by default: proleg's persistent cache off (PROLEG_CACHE_DIR="") unless
    ``--warm-cache`` is given or PROLEG_CACHE_DIR is already set. Must run before ``import proleg``."""
    argv = sys.argv if argv is None else argv
    if "--warm-cache" not in argv:
        os.environ.setdefault("PROLEG_CACHE_DIR", "")


_early_blas_threads()
_early_cpus()
_early_cache_setting()

import numpy as np  # noqa: E402

BENCH_DIR = Path(__file__).resolve().parent
RESULTS_DIR = BENCH_DIR / "results"


# ---------------------------------------------------------------------------------------------
# Machine description
# ---------------------------------------------------------------------------------------------
def cpu_model() -> str:
    """CPU model name from ``lscpu`` (Linux), else ``platform.processor()``."""
    try:
        out = subprocess.run(["lscpu"], capture_output=True, text=True, timeout=10).stdout
        for line in out.splitlines():
            if line.strip().startswith("Model name:"):
                return line.split(":", 1)[1].strip()
    except (OSError, subprocess.SubprocessError):
        pass
    return platform.processor() or "unknown"


def machine() -> dict:
    """What the numbers were measured on: CPU, cores, OS, Python, JAX and its backend."""
    info = {
        "cpu": cpu_model(),
        "cpu_count": os.cpu_count(),
        "cores_used": len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count(),
        "platform": platform.platform(),
        "python": platform.python_version(),
        # Other processes share this machine: a load above the core count inflates timings.
        "loadavg_1min": os.getloadavg()[0] if hasattr(os, "getloadavg") else None,
        # BLAS threads matter: jax's CPU LU is LAPACK getrf from scipy's OpenBLAS.
        "env": {k: os.environ[k] for k in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS", "XLA_FLAGS") if k in os.environ},
    }
    try:
        import jax

        info["jax"] = jax.__version__
        info["jax_backend"] = jax.default_backend()
        info["jax_devices"] = [str(d) for d in jax.devices()]
        info["jax_compilation_cache_dir"] = jax.config.jax_compilation_cache_dir or "none (cold compiles)"
    except Exception as exc:  # machine info must never stop a benchmark
        info["jax"] = f"unavailable ({exc})"
    try:
        import proleg

        info["proleg"] = proleg.__version__
    except Exception:
        pass
    info["git"] = git_state()
    return info


def git_state() -> str:
    """Commit of the working tree, with '+dirty' when src/ has uncommitted edits (timings move with them)."""
    try:
        head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=BENCH_DIR, capture_output=True, text=True, timeout=10)
        dirty = subprocess.run(["git", "status", "--porcelain", "src"], cwd=BENCH_DIR, capture_output=True, text=True, timeout=10)
        return head.stdout.strip() + ("+dirty" if dirty.stdout.strip() else "")
    except (OSError, subprocess.SubprocessError):
        return "unknown"


def log(*args):
    """Progress notes go to stderr so that ``--json`` keeps stdout clean."""
    print(*args, file=sys.stderr, flush=True)


# ---------------------------------------------------------------------------------------------
# Timing
# ---------------------------------------------------------------------------------------------
def timed(fn, *args, **kwargs):
    """(result, wall seconds) of ``fn(*args, **kwargs)``, blocking on JAX arrays in the result."""
    out, wall, _ = timed_cpu(fn, *args, **kwargs)
    return out, wall


def timed_cpu(fn, *args, **kwargs):
    """(result, wall seconds, CPU seconds of this process, all threads).

    On a shared machine the wall time grows with other processes' load; the CPU time much
    less so, so both are reported.
    """
    c0, t0 = time.process_time(), time.perf_counter()
    out = fn(*args, **kwargs)
    try:
        import jax

        jax.block_until_ready(jax.tree_util.tree_leaves(getattr(out, "q", out)))
    except Exception:
        pass
    return out, time.perf_counter() - t0, time.process_time() - c0


class CompileEvents:
    """Collects JAX's own compile events while active (``with CompileEvents() as ev: ...``).

    ``ev.summary()`` gives seconds spent tracing (jaxpr), lowering (MLIR) and in the XLA backend
    compiler, the number of backend compilations, and persistent-cache hits and misses.
    """

    DURATIONS = {
        "/jax/core/compile/jaxpr_trace_duration": "trace [s]",
        "/jax/core/compile/jaxpr_to_mlir_module_duration": "lower [s]",
        "/jax/core/compile/backend_compile_duration": "xla [s]",
        "/jax/compilation_cache/compile_time_saved_sec": "cache saved [s]",
    }
    COUNTS = {
        "/jax/compilation_cache/cache_hits": "cache hits",
        "/jax/compilation_cache/cache_misses": "cache misses",
    }

    def __init__(self):
        self.totals = {v: 0.0 for v in self.DURATIONS.values()}
        self.counts = {v: 0 for v in self.COUNTS.values()}
        self.n_backend = 0
        self.by_fun: dict[str, float] = {}

    def _dur(self, event, duration_secs, **kw):
        key = self.DURATIONS.get(event)
        if key is None:
            return
        self.totals[key] += duration_secs
        if key == "xla [s]":
            self.n_backend += 1
            fun = str(kw.get("fun_name", "?"))
            self.by_fun[fun] = self.by_fun.get(fun, 0.0) + duration_secs

    def _ev(self, event, **kw):
        key = self.COUNTS.get(event)
        if key is not None:
            self.counts[key] += 1

    def __enter__(self):
        import jax.monitoring as mon

        mon.register_event_duration_secs_listener(self._dur)
        mon.register_event_listener(self._ev)
        return self

    def __exit__(self, *exc):
        import jax.monitoring as mon

        try:
            mon.unregister_event_duration_listener(self._dur)
            mon.unregister_event_listener(self._ev)
        except (AttributeError, ValueError):
            pass
        return False

    def summary(self) -> dict:
        out = {**self.totals, "xla compiles": self.n_backend, **self.counts}
        top = sorted(self.by_fun.items(), key=lambda kv: -kv[1])[:4]
        out["xla by function [s]"] = {k: round(v, 2) for k, v in top}
        return out


def bench_simulate(system, t_end: float, dt_output: float = 1e-2, profile_chunks: bool = False, repeat: int = 1, **kw) -> dict:
    """Time ``proleg.simulate`` twice (or 1 + ``repeat`` times) on the same System in this process.

    ``compile [s]`` is first call minus second call (tracing + XLA compilation of the initial
    condition solve and the stepping loop); ``wall [s]`` is the second call; ``us/step`` is the
    second call's wall time per accepted step (rejected steps and Newton iterations are inside
    that cost), ``us/newton`` per Newton iteration, ``cpu us/step`` the same with this process's
    CPU time instead of wall time (less sensitive to other load on a shared machine).
    With ``repeat`` > 1 the timed call is repeated: ``wall [s]`` is then the fastest run (the
    least disturbed by other load, as ``timeit`` reports) and ``median us/step`` the median.
    """
    import proleg as pl
    from proleg.analyses.simulate import simulate_kwargs

    kw = simulate_kwargs(kw)  # flat options (rtol=, dt_max=, ...) → integrator=/run=
    kw.setdefault("progress", False)
    with CompileEvents() as ev:
        res1, t_first = timed(pl.simulate, system, t_end=t_end, dt_output=dt_output, **kw)
    chunk_times = []
    if profile_chunks:
        marks = [time.perf_counter()]
        kw = dict(kw, on_chunk=lambda r: marks.append(time.perf_counter()))
        res2, t_second, c_second = timed_cpu(pl.simulate, system, t_end=t_end, dt_output=dt_output, **kw)
        chunk_times = list(np.diff(marks))
    else:
        res2, t_second, c_second = timed_cpu(pl.simulate, system, t_end=t_end, dt_output=dt_output, **kw)
    walls = [t_second]
    for _ in range(max(repeat, 1) - 1):
        _, t_k, c_k = timed_cpu(pl.simulate, system, t_end=t_end, dt_output=dt_output, **kw)
        walls.append(t_k)
        if t_k < t_second:
            t_second, c_second = t_k, c_k
    s = res2.stats
    n_newton = int(system.nq + system.nc)
    if getattr(res2, "coordinates", "absolute") == "planar":
        basis = system.topo.planar[0]
        n_newton = int(3 * system.topo.nbody + basis.P.shape[0])
    row = {
        "nq": int(system.nq),
        "nc": int(system.nc),
        "coordinates": getattr(res2, "coordinates", "absolute"),
        "newton n": n_newton,
        "first [s]": t_first,
        "compile [s]": t_first - walls[0],
        "wall [s]": t_second,
        "steps": s["steps"],
        "rejected": s["rejected"],
        "newton": s["newton_iterations"],
        "jacobians": s.get("jacobians", 0),
        "us/step": 1e6 * t_second / max(s["steps"], 1),
        "us/newton": 1e6 * t_second / max(s["newton_iterations"], 1),
        "cpu us/step": 1e6 * c_second / max(s["steps"], 1),
        "median us/step": 1e6 * float(np.median(walls)) / max(s["steps"], 1),
        "runs": len(walls),
        "status": res2.message,
    }
    ce = ev.summary()
    row.update({"trace [s]": ce["trace [s]"], "lower [s]": ce["lower [s]"], "xla [s]": ce["xla [s]"]})
    row["xla compiles"] = ce["xla compiles"]
    row["cache hits"] = ce["cache hits"]
    row["xla by function [s]"] = ce["xla by function [s]"]
    if res1.stats != res2.stats:
        row["status"] += f" (first run stats differ: {res1.stats})"
    if profile_chunks:
        # First mark is the call start; the first interval also holds the initial-condition solve.
        row["chunk [s]"] = [round(float(c), 4) for c in chunk_times]
    return row


# ---------------------------------------------------------------------------------------------
# Models
# ---------------------------------------------------------------------------------------------
# Hinge markers have z along ground y (the hinge axis): columns are the marker x, y, z axes.
R_HINGE = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])


def rod_inertia(mass: float, length: float, radius: float = 0.01) -> tuple:
    """Principal inertia (about the rod axis x, then y, z) [kg m^2] of a solid cylinder."""
    ia = 0.5 * mass * radius**2
    it = mass * (3 * radius**2 + length**2) / 12.0
    return (ia, it, it)


def readme_model():
    """The README's ten-line double pendulum (two 1 kg links on revolute joints about ground y,
    a spring-damper from the tip to a ground anchor): the model of issue 20's cold-start target."""
    import proleg as pl

    model = pl.Model("double_pendulum", gravity=(0.0, 0.0, -9.81))
    upper = model.add_part("upper", mass=1.0, inertia=(0.01, 0.09, 0.09), position=(0.5, 0, 0))
    lower = model.add_part("lower", mass=1.0, inertia=(0.01, 0.09, 0.09), position=(1.5, 0, 0))
    model.add_joint(pl.Revolute("shoulder", model.ground, upper, at=(0, 0, 0), axis=(0, 1, 0)))
    model.add_joint(pl.Revolute("elbow", upper, lower, at=(1, 0, 0), axis=(0, 1, 0)))
    tip, anchor = model.add_marker(lower, "tip", (2, 0, 0)), model.add_marker(model.ground, "anchor", (2, 0, -1))
    model.add_force(pl.SpringDamper("spring", tip, anchor, stiffness=50.0, damping=0.5, free_length=1.0))
    return model


def build_chain(
    n: int,
    *,
    length: float = 0.15,
    mass: float = 0.1,
    angle_deg: float = 30.0,
    joints: str = "revolute",
    k_trans: float = 1e8,
    k_tilt: float = 1e6,
    c_trans: float = 1e3,
    c_tilt: float = 10.0,
    spring: float | None = None,
    name: str | None = None,
):
    """A hanging chain of ``n`` rods (x axis along the rod) hinged about ground y.

    The chain starts straight, ``angle_deg`` below the horizontal, at rest, and falls under
    gravity (9.81 m/s^2 along -z). ``joints="revolute"`` uses Revolute joints (5 equations
    each); ``joints="bushing"`` uses Bushings instead: ``k_trans`` [N/m] on the three
    translations, ``k_tilt`` [N m/rad] on the two tilts, 0 about the hinge axis, damping
    ``c_trans`` [N s/m] and ``c_tilt`` [N m s/rad] (0 about the hinge axis).
    ``spring`` [N/m] adds a SpringDamper "spring" from a ground point 0.1 m above the pivot to
    the tip of the last link (a parameter to sweep; a stiffness of 0 leaves the chain free).

    Returns the Model; parts are ``link1`` .. ``link{n}``.
    """
    import proleg as pl

    th = math.radians(angle_deg)
    d = np.array([math.cos(th), 0.0, -math.sin(th)])  # rod direction in ground
    R = np.array([[math.cos(th), 0.0, math.sin(th)], [0.0, 1.0, 0.0], [-math.sin(th), 0.0, math.cos(th)]])
    model = pl.Model(name or f"chain{n}_{joints}", gravity=(0.0, 0.0, -9.81))
    prev, pin = model.ground, np.zeros(3)
    for i in range(1, n + 1):
        part = model.add_part(
            f"link{i}", mass=mass, inertia=rod_inertia(mass, length), position=tuple(pin + 0.5 * length * d), orientation=R
        )
        if joints == "revolute":
            model.add_joint(pl.Revolute(f"hinge{i}", part, prev, at=tuple(pin), axis=(0.0, 1.0, 0.0)))
        elif joints == "bushing":
            mi = model.add_marker(part, f"hinge{i}.I", tuple(pin), R_HINGE)
            mj = model.add_marker(prev, f"hinge{i}.J", tuple(pin), R_HINGE)
            model.add_force(
                pl.Bushing(
                    f"hinge{i}",
                    mi,
                    mj,
                    stiffness=(k_trans, k_trans, k_trans, k_tilt, k_tilt, 0.0),
                    damping=(c_trans, c_trans, c_trans, c_tilt, c_tilt, 0.0),
                )
            )
        else:
            raise ValueError(f"joints must be 'revolute' or 'bushing', got {joints!r}")
        prev, pin = part, pin + length * d
    if spring is not None:
        tip = model.add_marker(prev, "tip", tuple(pin))
        anchor = model.add_marker(model.ground, "anchor", (0.0, 0.0, 0.1))
        free = float(np.linalg.norm(pin - np.array([0.0, 0.0, 0.1])))
        model.add_force(pl.SpringDamper("spring", tip, anchor, stiffness=spring, damping=0.1, free_length=free))
    return model


# ---------------------------------------------------------------------------------------------
# Tables and output
# ---------------------------------------------------------------------------------------------
def _fmt(v) -> str:
    if isinstance(v, float):
        if v == 0:
            return "0"
        if abs(v) >= 1000:
            return f"{v:,.0f}"
        if abs(v) >= 10:
            return f"{v:.1f}"
        return f"{v:.3g}"
    if isinstance(v, list):
        return " ".join(_fmt(x) for x in v)
    return str(v)


def markdown_table(rows: list[dict], columns: list[str]) -> str:
    head = "| " + " | ".join(columns) + " |"
    sep = "|" + "|".join("---:" if c not in ("case", "mode", "cache dir", "status", "note") else ":---" for c in columns) + "|"
    body = ["| " + " | ".join(_fmt(r.get(c, "")) for c in columns) + " |" for r in rows]
    return "\n".join([head, sep, *body])


def print_table(title: str, rows: list[dict], columns: list[str], file=None):
    """A rich table when rich is installed, else markdown."""
    file = file or sys.stdout
    try:
        from rich.console import Console
        from rich.markup import escape
        from rich.table import Table

        t = Table(title=escape(title))
        for c in columns:
            t.add_column(escape(c), justify="left" if c in ("case", "mode", "cache dir", "status", "note") else "right")
        for r in rows:
            t.add_row(*[escape(_fmt(r.get(c, ""))) for c in columns])
        Console(file=file, width=200).print(t)
    except ImportError:
        print(f"## {title}\n\n{markdown_table(rows, columns)}\n", file=file)


def _jsonable(v):
    if isinstance(v, dict):
        return {k: _jsonable(x) for k, x in v.items()}
    if isinstance(v, list | tuple):
        return [_jsonable(x) for x in v]
    if isinstance(v, np.generic):
        return v.item()
    return v


def child_result(code: str, env: dict, what: str) -> dict:
    """Run ``python -c code`` in a fresh process with ``env`` and return the JSON object it
    printed on a line starting ``RESULT ``; its stderr's tail in the error if there is none."""
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=False)
    for line in out.stdout.splitlines():
        if line.startswith("RESULT "):
            return json.loads(line[7:])
    raise RuntimeError(f"child failed ({what}):\n{out.stderr[-2000:]}")


def add_output_args(parser: argparse.ArgumentParser, name: str):
    parser.add_argument(
        "--warm-cache", action="store_true",
        help="keep proleg's persistent compilation cache (default: off, so compile columns are cold compiles)",
    )
    parser.add_argument(
        "--blas-threads", type=int, default=None,
        help="set OPENBLAS_NUM_THREADS/OMP_NUM_THREADS (e.g. 1; default: the environment's)",
    )
    parser.add_argument(
        "--repeat", type=int, default=1,
        help="time the run this many times; wall and us/step are the fastest, 'median us/step' the median",
    )
    parser.add_argument(
        "--cpus", type=int, default=None,
        help="run on this many cores, the least busy ones (sched_setaffinity before JAX starts; XLA sizes its thread pool from it)",
    )
    parser.add_argument("--cores", default=None, help="run on exactly these cores, e.g. 1 or 0,2 (instead of --cpus)")
    parser.add_argument("--json", action="store_true", help="print the table as ONE JSON object on stdout, nothing else")
    parser.add_argument(
        "--out", default=str(RESULTS_DIR / f"{name}.md"), help="write the table here (.md) and beside it (.json); '' to skip"
    )


def emit(args, title: str, rows: list[dict], columns: list[str], meta: dict | None = None, notes: list[str] | None = None):
    """Print the table (or its JSON) and write ``--out`` (.md and .json)."""
    doc = {
        "title": title,
        "machine": machine(),
        "meta": meta or {},
        "columns": columns,
        "rows": rows,
        "notes": notes or [],
        "date": time.strftime("%Y-%m-%d %H:%M:%S"),
    }
    doc = _jsonable(doc)
    if args.json:
        print(json.dumps(doc))
    else:
        print_table(title, rows, columns)
        for n in notes or []:
            print(f"- {n}")
    if args.out:
        out = Path(args.out)
        stem = out.name[: -len(out.suffix)] if out.suffix in (".md", ".json") else out.name
        md_path, json_path = out.parent / (stem + ".md"), out.parent / (stem + ".json")
        out.parent.mkdir(parents=True, exist_ok=True)
        m = doc["machine"]
        md = [
            f"# {title}",
            "",
            f"{doc['date']} — {m.get('cpu')} ({m.get('cpu_count')} cores, {m.get('cores_used', m.get('cpu_count'))} used), {m.get('platform')}, "
            f"Python {m.get('python')}, JAX {m.get('jax')} ({m.get('jax_backend')}), proleg {m.get('proleg')} (git {m.get('git')}), "
            f"load average (1 min) at the end {m.get('loadavg_1min')}, env {m.get('env') or '{}'}",
            "",
        ]
        if meta:
            md += ["Settings: " + ", ".join(f"{k} = {v}" for k, v in meta.items()), ""]
        md += [markdown_table(rows, columns), ""]
        md += [f"- {n}" for n in notes or []]
        md_path.write_text("\n".join(md) + "\n")
        json_path.write_text(json.dumps(doc, indent=2) + "\n")
        log(f"wrote {md_path} and {json_path.name}")
    return doc
