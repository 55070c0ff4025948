"""Fault harness for proleg's cache store (issue 34 item 2): a child program and the helpers that
run it, shared by tests/test_cache_store.py and bench/faults.py.

As a program (``python tests/cache_faults.py --workload pendulum``) it imports proleg with the
``PROLEG_CACHE_DIR`` it is given, runs a workload and prints one line ``RESULT {json}``: the
final state's bytes (hex, for bitwise comparison), the cache warnings it saw and the store's
counters. With ``--kill-write J`` it then deletes ``--delete K`` random entries, drops its
in-memory executables, runs the workload again and SIGKILLs itself at ``--kill-phase`` of the
store's J-th write (before it, in the middle of the payload, before fsync, before the rename, or
after it): a real process killed at a chosen point of a write, not a mock.

Workloads: ``pendulum`` simulates a 1-link and a 2-link pendulum (``--links`` picks), the small
models the issue asks for; ``fn`` is one ``cached_jit`` function (a few entries, quick).
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
from pathlib import Path

HERE = Path(__file__).resolve()
SRC = HERE.parents[1] / "src"
PHASES = ("before", "partial", "unsynced", "synced", "published")


# -- the child -----------------------------------------------------------------------------------
def _pendulum(pl, n):
    m = pl.Model(f"pendulum{n}", gravity=(0, 0, -9.81))
    prev, length = m.ground, 0.5
    for i in range(n):
        link = m.add_part(f"link{i}", 1.0, (0.01, 0.02, 0.02), ((i + 0.5) * length, 0, 0))
        m.add_joint(pl.Revolute(f"pin{i}", prev, link, at=(i * length, 0, 0), axis=(0, 1, 0)))
        prev = link
    res = pl.simulate(pl.assemble(m), t_end=0.3, dt_output=0.01, progress=False)
    return res.q[-1]


def _workload(name, links):
    import numpy as np

    import proleg as pl

    if name == "pendulum":
        return np.concatenate([np.asarray(_pendulum(pl, n), dtype=np.float64) for n in links])
    import jax.numpy as jnp

    import proleg.compile_cache as cc

    f = cc.cached_jit(lambda x: jnp.cumsum(jnp.sin(x) * 3.0) / (1.0 + x * x))
    return np.asarray(f(jnp.linspace(0.0, 2.0, 17)), dtype=np.float64)


def _cache_warnings(caught):
    keys = ("proleg cache", "compilation cache")
    return [str(w.message)[:200] for w in caught if any(k in str(w.message) for k in keys)]


def _report(tag, q, caught):
    import proleg.cache_store as cs
    import proleg.compile_cache as cc

    counts = {**{k: v for k, v in cc.stats.items() if isinstance(v, int)}, **cs.stats}
    print(f"{tag} " + json.dumps({"q": q.tobytes().hex(), "warnings": _cache_warnings(caught), "stats": counts}), flush=True)


def _arm_kill(j, phase, rng):
    """SIGKILL this process at ``phase`` of the store's ``j``-th write from now."""
    import proleg.cache_store as cs

    state = {"n": -1}
    lock, tls = threading.Lock(), threading.local()
    kill = lambda: os.kill(os.getpid(), signal.SIGKILL)  # noqa: E731
    write, os_write, os_fsync, os_replace = cs.Store.write, os.write, os.fsync, os.replace

    def store_write(self, *a, **k):
        with lock:
            state["n"] += 1
            mine = state["n"] == j
        if mine and phase == "before":
            kill()
        tls.armed = mine
        try:
            return write(self, *a, **k)
        finally:
            tls.armed = False
            if mine and phase == "published":
                kill()

    def w(fd, data):
        if getattr(tls, "armed", False) and phase == "partial":
            os_write(fd, bytes(data)[: int(rng.integers(0, len(data)))])
            kill()
        return os_write(fd, data)

    def fs(fd):
        if getattr(tls, "armed", False) and phase == "unsynced":
            kill()
        return os_fsync(fd)

    def rp(a, b):
        if getattr(tls, "armed", False) and phase == "synced":
            kill()
        return os_replace(a, b)

    cs.Store.write, os.write, os.fsync, os.replace = store_write, w, fs, rp


def child(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--workload", default="pendulum", choices=("pendulum", "fn"))
    ap.add_argument("--links", default="1,2")
    ap.add_argument("--fsize", type=int, default=0, help="RLIMIT_FSIZE [bytes]: writes beyond fail (EFBIG)")
    ap.add_argument("--kill-write", type=int, default=-1)
    ap.add_argument("--kill-phase", default="partial", choices=PHASES)
    ap.add_argument("--delete", type=int, default=1)
    ap.add_argument("--seed", type=int, default=0)
    a = ap.parse_args(argv)
    if a.fsize:
        import resource

        resource.setrlimit(resource.RLIMIT_FSIZE, (a.fsize, a.fsize))
    import warnings

    links = [int(x) for x in a.links.split(",")]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        q = _workload(a.workload, links)
    _report("RESULT", q, caught)
    if a.kill_write < 0:
        return
    import jax
    import numpy as np

    import proleg.compile_cache as cc

    rng = np.random.default_rng(a.seed)
    files = entry_files(os.environ["PROLEG_CACHE_DIR"])
    for i in rng.permutation(len(files))[: a.delete]:
        os.unlink(files[i])
    jax.clear_caches()
    cc.clear()
    _arm_kill(a.kill_write, a.kill_phase, rng)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        q = _workload(a.workload, links)
    _report("SURVIVED", q, caught)


# -- the harness ---------------------------------------------------------------------------------
def entry_files(cache) -> list[str]:
    """The store's entry files under ``cache`` (every kind), sorted."""
    out = []
    for kind in ("export", "trail", "xla"):
        d = os.path.join(cache, kind)
        if os.path.isdir(d):
            out += sorted(os.path.join(d, f) for f in os.listdir(d) if f.endswith(".entry"))
    return out


def temp_files(cache) -> list[str]:
    return [os.path.join(r, f) for r, _d, fs in os.walk(cache) for f in fs if f.endswith(".tmp")]


def invalid_entries(cache) -> dict:
    """{path: reason} of the entries under ``cache`` that do not verify."""
    sys.path.insert(0, str(SRC))
    from proleg.cache_store import verify_file

    return {p: r for p in entry_files(cache) if (r := verify_file(p)) is not None}


def child_cmd(*args) -> list[str]:
    return [sys.executable, str(HERE), *map(str, args)]


def child_env(cache, **extra) -> dict:
    env = {**os.environ, "PROLEG_CACHE_DIR": str(cache), **{k: str(v) for k, v in extra.items()}}
    env["PYTHONPATH"] = os.pathsep.join([str(SRC), *filter(None, [os.environ.get("PYTHONPATH")])])
    return env


def parse(out: str) -> dict:
    """{"RESULT": {...}, "SURVIVED": {...}} from a child's stdout."""
    got = {}
    for line in out.splitlines():
        tag, _, rest = line.partition(" ")
        if tag in ("RESULT", "SURVIVED"):
            got[tag] = json.loads(rest)
    return got


def run(cache, *args, timeout=900, prefix=(), env=None) -> tuple[int, dict, str]:
    """Run the child on ``cache``; (return code, parsed results, stderr tail)."""
    p = subprocess.run([*prefix, *child_cmd(*args)], capture_output=True, text=True, timeout=timeout,
                       env=env or child_env(cache))
    return p.returncode, parse(p.stdout), p.stderr[-3000:]


def start(cache, *args, prefix=(), env=None) -> subprocess.Popen:
    return subprocess.Popen([*prefix, *child_cmd(*args)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env=env or child_env(cache))


def damage(files, rng) -> list[tuple[str, str]]:
    """Truncate (at a random length) or flip 1 to 8 random bits of each file; what was done."""
    done = []
    for f in files:
        data = bytearray(Path(f).read_bytes())
        if rng.random() < 0.5:
            n = int(rng.integers(0, len(data)))
            Path(f).write_bytes(bytes(data[:n]))
            done.append((f, f"truncated to {n} of {len(data)} bytes"))
        else:
            k = int(rng.integers(1, 9))
            for _ in range(k):
                i = int(rng.integers(0, len(data)))
                data[i] ^= 1 << int(rng.integers(0, 8))
            Path(f).write_bytes(bytes(data))
            done.append((f, f"{k} bit flips"))
    return done


_MOUNT: list = []


def can_mount() -> bool:
    """Whether this process may mount a tmpfs in a private mount namespace (root, ``unshare``)."""
    if not _MOUNT:
        ok = False
        if hasattr(os, "geteuid") and os.geteuid() == 0 and shutil.which("unshare") and shutil.which("mount"):
            with tempfile.TemporaryDirectory() as d:
                ok = subprocess.run(["unshare", "-m", "sh", "-c", f"mount -t tmpfs -o size=64k tmpfs {d}"],
                                    capture_output=True).returncode == 0
        _MOUNT.append(ok)
    return _MOUNT[0]


def tmpfs_prefix(folder, size: str | None = None, read_only: bool = False) -> list[str]:
    """A command prefix that runs the child in a private mount namespace with ``folder`` on a new
    tmpfs of ``size`` (a full disk once filled), or bound read-only onto itself (its entries
    stay at the same path: JAX's executable keys name the cache folder)."""
    if read_only:
        script = f'mount --bind "{folder}" "{folder}" && mount -o remount,ro,bind "{folder}" && exec "$@"'
    else:
        script = f'mount -t tmpfs -o size={size} tmpfs "{folder}" && exec "$@"'
    return ["unshare", "-m", "sh", "-c", script, "sh"]


if __name__ == "__main__":
    child()
