"""Studies that cannot crash the host (issue 34): the memory guard and dying workers.

- :mod:`proleg.memguard` clears the compiled code of a process past its map or memory threshold,
  so a loop over new models stays bounded (measured in bench/memory_maps.py: ~750 maps and
  ~100 MB per new HyQ leg, maps plateau near 12,800, memory does not), and hands the freed heap
  back to the kernel; a study's worker that stays above its threshold is replaced;
- the "processes" executor: a worker killed mid-study (SIGKILL, as the OOM killer does) has its
  batches run again, every variant stored exactly once; a variant that kills its worker every
  time is stored once as "worker_died" with the reason, and the study goes on.

Function studies keep these fast (no compilation in the workers); the slow tests run the
issue's sizes: 200 variants with a kill (a function study and a model study), and 300 distinct
HyQ-leg geometries in a plain loop, in one process's builder study and on the processes executor
(PROLEG_TEST_HYQ_MODELS runs fewer).
"""

from __future__ import annotations

import os
import signal

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import proleg as pl
from proleg import memguard
from models import spring_pendulum


def test_memguard_clears_compiled_code_past_its_threshold(monkeypatch):
    """Past PROLEG_MAX_MAPS the guard drops JAX's executables (a jitted function compiles again)
    and then waits until the process has grown by half before clearing again."""
    f = jax.jit(lambda x: jnp.sin(x) * 2.0)
    f(jnp.ones(3))
    assert f._cache_size() == 1
    monkeypatch.setattr(memguard, "_state", {"next_maps": None, "next_rss": None, "clears": 0})
    # The resident-memory threshold out of reach: a test worker that ran many files before can be
    # past the 4 GiB default (the guard then rightly clears, and this test is of the maps one).
    monkeypatch.setenv("PROLEG_MAX_RSS_BYTES", str(2**62))
    monkeypatch.setenv("PROLEG_MAX_MAPS", str(10**9))
    assert not memguard.release_if_needed() and f._cache_size() == 1  # below: nothing happens
    monkeypatch.setenv("PROLEG_MAX_MAPS", "10")  # every process has more than 10 maps
    assert memguard.release_if_needed()
    assert f._cache_size() == 0 and memguard.clears() == 1
    assert not memguard.release_if_needed()  # still above 10, but not grown by half since the clear
    monkeypatch.setenv("PROLEG_MAX_MAPS", "nonsense")  # a bad setting falls back to the default
    assert memguard.limits()[0] == memguard.max_map_count() // 4
    assert memguard.memory_maps() > 10 and memguard.rss_bytes() > 0


_TRIM_PROBE = """
import ctypes, ctypes.util, json
from proleg import memguard
libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
if not hasattr(libc, "malloc_trim"):
    print(json.dumps(None)); raise SystemExit
libc.malloc.restype, libc.malloc.argtypes = ctypes.c_void_p, [ctypes.c_size_t]
libc.free.argtypes = [ctypes.c_void_p]
before = memguard.rss_bytes()
blocks = []
for _ in range(150 * 1024):
    b = libc.malloc(1024)
    ctypes.memset(b, 1, 1024)  # touched: resident
    blocks.append(b)
grown = memguard.rss_bytes() - before
for b in blocks[:-1]:
    libc.free(b)
held = memguard.rss_bytes()
trimmed = memguard._trim_heap()
print(json.dumps({"grown": grown, "freed": held - memguard.rss_bytes(), "trimmed": trimmed}))
"""


def test_release_returns_the_freed_heap_to_the_kernel():
    """After a clear the executables' pages are free but stay in glibc's heap, so the resident
    memory did not fall (bench/memory_maps.py: 1,485 → 1,440 MiB); memguard.release hands them
    back (→ 387 MiB). Here 150 MiB of 1 KiB blocks, freed below one block that stays allocated
    (so free() cannot trim them from the top of the heap): the trim must return at least two
    thirds of what they grew the process by.

    The probe runs in a fresh interpreter: in a test worker that has run other files, threads
    left by earlier tests allocate while it measures, and the heap's earlier holes change how
    much the blocks grow it (CI once measured 95 MiB returned of 150 that way)."""
    import json
    import subprocess
    import sys

    out = subprocess.run(
        [sys.executable, "-c", _TRIM_PROBE], capture_output=True, text=True, timeout=300
    )
    assert out.returncode == 0, out.stderr[-2000:]
    probe = json.loads(out.stdout.strip().splitlines()[-1])
    if probe is None:
        pytest.skip("not glibc: no malloc_trim (memguard skips the trim there too)")
    assert probe["trimmed"] and probe["grown"] > 100 * 2**20, probe
    assert probe["freed"] > 2 / 3 * probe["grown"], (
        f"the trim returned {probe['freed'] / 2**20:.0f} MiB of {probe['grown'] / 2**20:.0f}"
    )


def test_memguard_default_rss_threshold_and_worker_share(monkeypatch):
    """Default: a quarter of the memory, at most MAX_RSS_DEFAULT; a worker of a pool of W: at
    most 1/(2W) of the memory; PROLEG_MAX_RSS_BYTES wins over both."""
    monkeypatch.delenv("PROLEG_MAX_RSS_BYTES", raising=False)
    monkeypatch.setattr(memguard, "_total_memory", lambda: 64 * 2**30)
    monkeypatch.setattr(memguard, "_share", {"workers": 0})
    assert memguard.limits()[1] == memguard.MAX_RSS_DEFAULT == 4 * 2**30
    monkeypatch.setattr(memguard, "_total_memory", lambda: 8 * 2**30)
    assert memguard.limits()[1] == 2 * 2**30
    memguard.set_worker_share(4)
    assert memguard.limits()[1] == 2**30
    monkeypatch.setenv("PROLEG_MAX_RSS_BYTES", str(3 * 2**30))
    assert memguard.limits()[1] == 3 * 2**30


def _square(x):
    return {"y": x * x}


def _worker_pids(rows):
    return [w.rsplit(":", 1)[-1] for w in rows["worker"]]


def test_a_worker_above_its_memory_threshold_is_replaced(tmp_path, monkeypatch):
    """Real worker processes: with PROLEG_MAX_RSS_BYTES = 1 byte every worker stays above its
    threshold after clearing its compiled code, so each batch's worker asks to be replaced and
    the pool is started anew: 3 batches on 1 worker run in 3 processes, every variant once and
    right. The same study with the default threshold runs all 3 in one process."""
    from proleg.study import executors as ex

    st = pl.study.Study.function(_square, {"x": [2.0, 3.0, 5.0]}, ["y"])

    def run(name):
        ex.shutdown_pools()  # a fresh pool: its workers read the environment at spawn
        recycled = ex.recycled_pools()
        st.run(design="grid", executor="processes", workers=1, batch_size=1, store=tmp_path / name, progress=False)
        rows = pl.study.Store(tmp_path / name).read()
        assert len(rows) == 3 and rows["key"].is_unique and (rows["status"] == "success").all()
        np.testing.assert_array_equal(rows["y"], rows["x"] ** 2)
        return set(_worker_pids(rows)), ex.recycled_pools() - recycled

    try:
        monkeypatch.setenv("PROLEG_MAX_RSS_BYTES", "1")
        pids, recycled = run("tiny")
        assert len(pids) == 3 and recycled == 3
        monkeypatch.delenv("PROLEG_MAX_RSS_BYTES")
        pids, recycled = run("default")
        assert len(pids) == 1 and recycled == 0
    finally:
        ex.shutdown_pools()


_LOOP = """
import json, sys
import jax
jax.config.update("jax_enable_x64", True)
import numpy as np
import proleg as pl
from proleg import memguard
sys.path.insert(0, sys.argv[1])
from test_study_faults import _two_link
out = []
for length in (0.5, 0.6, 0.5):  # the first model again after the clears: compiled anew
    r = pl.simulate(pl.assemble(_two_link(length)), t_end=0.01, dt_output=0.005, progress=False)
    out.append(np.asarray(r.q).tolist())
print(json.dumps({"clears": memguard.clears(), "q": out}))
"""


@pytest.mark.slow  # two processes compile 2 models each, one a builder study's recycled workers (~1-2 min)
def test_a_tiny_rss_threshold_clears_and_recycles_with_the_same_results(tmp_path):
    """Real processes at a reduced size, PROLEG_MAX_RSS_BYTES = 1 byte: a script's loop over new
    models clears its compiled code (assemble calls the guard) and the model run again after the
    clears gives bitwise the same motion; a builder study on the processes executor replaces
    its worker after every batch and stores the same values as the study in this process."""
    import json
    import subprocess
    import sys

    env = {**os.environ, "PROLEG_MAX_RSS_BYTES": "1", "PYTHONPATH": os.pathsep.join(sys.path)}
    p = subprocess.run([sys.executable, "-c", _LOOP, os.path.dirname(__file__)], env=env, capture_output=True, text=True, timeout=600)
    assert p.returncode == 0, p.stderr[-3000:]
    got = json.loads(p.stdout.strip().splitlines()[-1])
    assert got["clears"] >= 1
    np.testing.assert_array_equal(got["q"][2], got["q"][0])
    assert np.max(np.abs(np.subtract(got["q"][1], got["q"][0]))) > 1e-6  # a different model

    from proleg.study import executors as ex

    st = pl.study.Study(lambda length: pl.assemble(_two_link(length)), {"length": [0.5, 0.6]},
                        {"z": lambda r: r.part("lower").position[-1, 2]}, dict(t_end=0.01, dt_output=0.005))
    local = st.run(design="grid", executor="local", batch_size=1, progress=False)
    ex.shutdown_pools()
    os.environ["PROLEG_MAX_RSS_BYTES"] = "1"
    try:
        recycled = ex.recycled_pools()
        st.run(design="grid", executor="processes", workers=1, batch_size=1, store=tmp_path / "s", progress=False)
        assert ex.recycled_pools() - recycled == 2
    finally:
        os.environ.pop("PROLEG_MAX_RSS_BYTES")
        ex.shutdown_pools()
    rows = pl.study.Store(tmp_path / "s").read().sort_values("length")
    assert (rows["status"] == "success").all() and len(set(_worker_pids(rows))) == 2
    np.testing.assert_array_equal(rows["z"], local.sort_values("length")["z"])


def _two_link(length):
    """A two-link pendulum whose lower link hangs at ``length`` [m]; its initial pose is a static
    constant of the start-up solve, so every length compiles anew (as a new geometry does)."""
    m = pl.Model(f"two_link_{length:.6f}".replace(".", "_"))
    up = m.add_part("upper", 1.0, (1e-3, 0.02, 0.02), (0.25, 0, 0))
    lo = m.add_part("lower", 0.5, (1e-3, 0.01, 0.01), (0.5 + 0.5 * length, 0, 0))
    m.add_joint(pl.Revolute("hip", m.ground, up, at=(0, 0, 0), axis=(0, 1, 0)))
    m.add_joint(pl.Revolute("knee", up, lo, at=(0.5, 0, 0), axis=(0, 1, 0)))
    return m


def test_a_loop_over_new_models_stays_below_the_guard(monkeypatch):
    """20 new models assembled and simulated in one loop, with the guard's map threshold set to
    3,000 above the start: the maps never pass the threshold plus one model's worth, and the
    guard cleared at least once (without it they would grow by ~10,000)."""
    from proleg import compile_cache

    jax.clear_caches()
    compile_cache.clear()
    start = memguard.memory_maps()
    monkeypatch.setenv("PROLEG_MAX_MAPS", str(start + 3000))
    monkeypatch.setattr(memguard, "_state", {"next_maps": None, "next_rss": None, "clears": 0})
    peak = 0
    for k in range(20):
        r = pl.simulate(pl.assemble(_two_link(0.5 + 0.01 * k)), t_end=0.01, dt_output=0.005, progress=False)
        assert np.all(np.isfinite(np.asarray(r.q)))
        peak = max(peak, memguard.memory_maps())
    per_model = 1500  # generous: a two-link model adds a few hundred maps
    assert memguard.clears() >= 1, f"no clear: peak {peak}, start {start}"
    assert peak < start + 3000 + per_model
    assert peak < memguard.max_map_count() // 2


def test_a_dead_workers_signal_is_named_even_while_it_is_being_reaped():
    """The pool's manager thread joins a dead worker while the driver reads its exit code; a
    read in between finds none. The slow 200-variant kill test failed so under load (reason
    '... alone (killed)' instead of SIGKILL, 2 runs of 2): the code is read again until known."""
    import types

    from proleg.study.executors import _exit_codes

    class Reaped:
        reads = 0

        @property
        def exitcode(self):  # unknown for the first reads, then the signal, as in the race
            Reaped.reads += 1
            return None if Reaped.reads < 4 else -signal.SIGKILL

    assert _exit_codes(types.SimpleNamespace(_processes={1: Reaped()})) == "SIGKILL"
    alive = types.SimpleNamespace(exitcode=None)
    assert _exit_codes(types.SimpleNamespace(_processes={1: alive}), wait_s=0.05) == "killed"
    assert _exit_codes(types.SimpleNamespace(_processes=None)) == "killed"


def _kill_study(tmp_path, n, kill_after_first=True):
    import multiprocessing as mp

    def _evaluate(x):  # nested: cloudpickle sends it by value to the workers
        if x == 13.0:  # a variant that kills its worker, as a segfault or the OOM killer would
            os.kill(os.getpid(), signal.SIGKILL)
        return {"y": x * x}

    st = pl.study.Study.function(_evaluate, {"x": [float(i) for i in range(n)]}, ["y"])
    killed = []

    def kill_a_worker(rows):
        kids = [p for p in mp.active_children() if p.is_alive()]
        if kill_after_first and kids and not killed:
            os.kill(kids[0].pid, signal.SIGKILL)  # a worker process of this study's pool
            killed.append(kids[0].pid)

    tab = st.run(design="grid", executor="processes", workers=2, batch_size=2, store=tmp_path / "s",
                 progress=False, on_batch=kill_a_worker)
    return tab, pl.study.Store(tmp_path / "s").read(), killed


def _check_exactly_once(tab, rows, n):
    assert len(rows) == n and rows["key"].is_unique, "a variant is missing or stored twice"
    died = rows[rows["status"] == "worker_died"]
    assert list(died["x"]) == [13.0]
    assert "died 2 times" in died["reason"].iloc[0] and "SIGKILL" in died["reason"].iloc[0]
    ok = rows[rows["status"] == "success"]
    assert len(ok) == n - 1
    np.testing.assert_array_equal(ok["y"], ok["x"] ** 2)  # x² of small integers is exact
    assert len(tab) == n and set(tab["key"]) == set(rows["key"])


@pytest.mark.slow  # under pytest-xdist it took its xdist worker down with it (gw1 crashed); run alone with -m slow
def test_killed_workers_requeue_and_a_killer_variant_fails_once(tmp_path):
    """20 variants on 2 workers: the test kills a worker after the first batch, and variant
    x = 13 kills its worker whenever it runs. Every variant ends in the store exactly once: 19
    successes, and x = 13 as "worker_died" after 2 deaths, with the signal named."""
    tab, rows, killed = _kill_study(tmp_path, 20)
    assert killed
    _check_exactly_once(tab, rows, 20)


@pytest.mark.slow
def test_a_200_variant_study_survives_a_killed_worker(tmp_path):
    tab, rows, killed = _kill_study(tmp_path, 200)
    assert killed
    _check_exactly_once(tab, rows, 200)


def _spring_pendulum():
    """A cheap model (one small compile)."""
    return spring_pendulum("kill_pendulum")


@pytest.mark.slow  # 200 simulations on 2 spawned workers plus the same 200 in this process (~2-4 min on 2 cores)
def test_a_200_variant_model_study_survives_a_worker_killed_mid_batch(tmp_path):
    """A model study (the spring pendulum over 200 stiffnesses, 20 batches of 10 on 2 worker
    processes): once 3 batches are stored, a thread SIGKILLs a worker while the batches are in
    flight, as the OOM killer would. Every variant ends in the store exactly once, all succeed
    (no variant died twice: the kill is not theirs), and each row equals the same variant run in
    this process (lanes=1: every variant at its own steps, so a re-run batch gives the same
    numbers; 1e-10 m leaves room for another summation order only)."""
    import multiprocessing as mp
    import random
    import threading

    n = 200
    ks = [float(k) for k in np.geomspace(10.0, 1000.0, n)]
    st = pl.study.Study(_spring_pendulum(), {"spring.stiffness": ks},
                        {"x_end": lambda r: r.part("lower").position[-1, 0]}, dict(t_end=0.1, dt_output=0.01))
    parts = tmp_path / "s" / "rows"
    killed, stop = [], threading.Event()

    def killer():
        rng = random.Random(0)
        while not stop.wait(0.05):
            if len(list(parts.glob("part-*.parquet"))) >= 3:
                kids = [p for p in mp.active_children() if p.is_alive()]
                if kids:
                    victim = rng.choice(kids)
                    os.kill(victim.pid, signal.SIGKILL)
                    killed.append(victim.pid)
                    return

    t = threading.Thread(target=killer, daemon=True)
    t.start()
    try:
        tab = st.run(design="grid", executor="processes", workers=2, batch_size=10, lanes=1, store=tmp_path / "s",
                     progress=False)
    finally:
        stop.set()
        t.join()
    assert killed, "the study ended before a worker could be killed"
    rows = pl.study.Store(tmp_path / "s").read()
    assert len(rows) == n and rows["key"].is_unique, "a variant is missing or stored twice"
    assert len(tab) == n and set(tab["key"]) == set(rows["key"])
    assert (rows["status"] == "success").all(), rows.loc[rows["status"] != "success", ["status", "reason"]]
    assert len(set(rows["worker"])) >= 3, set(rows["worker"])  # the broken pool's batches ran on new workers
    ref = st.run(design="grid", executor="vmap", workers=1, lanes=1, progress=False).set_index("key")
    got = rows.set_index("key").loc[ref.index]
    np.testing.assert_allclose(got["x_end"], ref["x_end"], rtol=0, atol=1e-10)
    np.testing.assert_array_equal(got["steps"], ref["steps"])


def hyq_builder(cylinder_length):
    return pl.assemble(pl.robots.hyq_leg(joints="bushings8", cylinder_length=float(cylinder_length)))


#: New HyQ legs in the 300-model tests (PROLEG_TEST_HYQ_MODELS: fewer to check the test itself;
#: 300 takes 2-5 h on 2 cores, ~25-60 s per model, compile dominated; bench/memory_maps.py
#: measures the same with a per-model trace).
HYQ_MODELS = int(os.environ.get("PROLEG_TEST_HYQ_MODELS", "300"))


class _PeakMaps:
    """Largest memory-map count of this process and its child processes, sampled every 0.5 s."""

    def __enter__(self):
        import threading

        self.peak, self._stop = 0, threading.Event()
        self._t = threading.Thread(target=self._run, daemon=True)
        self._t.start()
        return self

    def _run(self):
        import multiprocessing as mp

        while not self._stop.wait(0.5):
            for pid in ["self"] + [p.pid for p in mp.active_children()]:
                try:
                    with open(f"/proc/{pid}/maps", "rb") as f:
                        self.peak = max(self.peak, sum(1 for _ in f))
                except OSError:
                    pass

    def __exit__(self, *exc):
        self._stop.set()
        self._t.join()


@pytest.mark.slow
def test_a_script_loop_over_300_new_hyq_legs():
    """A plain script: ``simulate(assemble(hyq_leg(cylinder_length=L)))`` for 300 distinct L in
    one loop, each a new compiled model. It completes with finite motions, and the maps stay
    below half the kernel's limit with no user action (memguard clears in assemble())."""
    with _PeakMaps() as pk:
        for L in np.linspace(0.075, 0.095, HYQ_MODELS):
            r = pl.simulate(hyq_builder(L), t_end=0.02, dt_output=1e-3, progress=False)
            assert np.all(np.isfinite(np.asarray(r.q)))
            pk.peak = max(pk.peak, memguard.memory_maps())
    assert pk.peak < memguard.max_map_count() // 2


@pytest.mark.slow
@pytest.mark.parametrize("executor", ["local", "processes"])
def test_builder_study_over_300_hyq_geometries(executor, tmp_path):
    """300 distinct cylinder lengths of the HyQ leg, each a new compiled model, in one builder
    study: it completes, and this process (or each worker) stays below half the kernel's map
    limit with no user action (bench/memory_maps.py measures the same with a table)."""
    n = HYQ_MODELS
    with _PeakMaps() as pk:
        st = pl.study.Study(hyq_builder, {"cylinder_length": list(np.linspace(0.075, 0.095, n))},
                            {"z": lambda r: r.part("slider").position[-1, 2]}, dict(t_end=0.02, dt_output=1e-3))
        tab = st.run(design="grid", executor=executor, batch_size=1, workers=2 if executor == "processes" else 1,
                     store=tmp_path / "s", progress=False)
    assert len(tab) == n and (tab["status"] == "success").all()
    assert pk.peak < memguard.max_map_count() // 2
