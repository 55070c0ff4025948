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
    add_output_args(ap, "compile_cache")
    args = ap.parse_args(argv)

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
