"""proleg's cache as a crash-safe store (proleg/cache_store.py, issue 34 item 2).

The promises (compile_cache's module docstring) are checked on real files and real processes:
an entry is verified on read, so every truncation and bit flip is caught and the entry rebuilt
with one warning; writes are atomic, so readers racing writers of the same key never see a part,
and a process SIGKILLed at any point of a write leaves nothing the next run trips on; a full,
read-only or uncreatable folder turns writing off with one warning and the run goes on; the size
cap evicts the least recently used entries. The child processes (tests/cache_faults.py) each get
their own PROLEG_CACHE_DIR in tmp, never the user's ~/.cache/proleg.
"""

import json
import os
import subprocess
import sys
import time
import warnings

import numpy as np
import pytest

import proleg as pl
import proleg.cache_store as cs
import proleg.compile_cache as cc

sys.path.insert(0, os.path.dirname(__file__))
import cache_faults as cf  # noqa: E402


@pytest.fixture
def store(tmp_path, monkeypatch):
    monkeypatch.setenv("PROLEG_CACHE_DIR", str(tmp_path))
    monkeypatch.delenv("PROLEG_CACHE_MAX_BYTES", raising=False)
    return cs.Store(str(tmp_path))


# -- the entry format ----------------------------------------------------------------------------
def test_every_truncation_and_bit_flip_is_caught():
    """sha256 over the payload and an exact length in the header: no truncation (every length)
    and no bit flip (every bit of a small entry) decodes; a foreign file and another key's
    entry are refused too."""
    key = "k" * 64
    payload = bytes(range(256)) * 3
    blob = cs.encode(key, payload)
    assert cs.decode(key, blob) == payload
    for n in range(len(blob)):
        with pytest.raises(cs.CorruptEntry):
            cs.decode(key, blob[:n])
    for i in range(len(blob)):
        for bit in range(8):
            b = bytearray(blob)
            b[i] ^= 1 << bit
            with pytest.raises(cs.CorruptEntry):
                cs.decode(key, bytes(b))
    with pytest.raises(cs.CorruptEntry, match="another key"):
        cs.decode("j" * 64, blob)
    with pytest.raises(cs.CorruptEntry, match="magic"):
        cs.decode(key, b"\x80\x04\x95" + payload)  # a pickle, as the cache held before


def test_damaged_entry_is_deleted_rebuilt_with_one_warning(store):
    path = store.path("export", "f-key1")
    assert store.write("export", "f-key1", "key1", b"payload")
    assert cs.verify_file(path) is None and store.read("export", "f-key1", "key1") == b"payload"
    data = open(path, "rb").read()
    open(path, "wb").write(data[:-3])
    with pytest.warns(pl.ProlegWarning, match="deleted the damaged entry") as rec:
        assert store.read("export", "f-key1", "key1") is None
    assert len(rec) == 1 and not os.path.exists(path)
    assert store.read("export", "f-key1", "key1") is None  # a plain miss now: no second warning
    os.makedirs(os.path.dirname(store.path("xla", "x")), exist_ok=True)
    open(store.path("xla", "x"), "wb").write(data)  # another key's entry under this name
    assert "holds key" in cs.verify_file(store.path("xla", "x"))


def test_cached_function_with_damaged_entry_recomputes_the_same_answer(store, tmp_path):
    """Bit flips in the exported function: one warning, the same numbers (rebuilt, not the
    damaged program), and the rewritten entry serves the next process's wrapper silently."""
    import jax.numpy as jnp

    fn = lambda x: jnp.sin(x) * 3.0  # noqa: E731
    x = jnp.linspace(0.0, 1.0, 5)
    ref = cc.cached_jit(fn)(x)
    (entry,) = cf.entry_files(tmp_path)
    cf.damage([entry], np.random.default_rng(1))
    # bitwise: the rebuilt entry is the same program compiled again on this machine, and a
    # wrong executable is what the comparison is there to catch
    with pytest.warns(pl.ProlegWarning, match="damaged entry") as rec:
        np.testing.assert_array_equal(cc.cached_jit(fn)(x), ref)
    assert len([w for w in rec if "proleg cache" in str(w.message)]) == 1
    assert cf.invalid_entries(tmp_path) == {}
    with warnings.catch_warnings():
        warnings.simplefilter("error", pl.ProlegWarning)
        np.testing.assert_array_equal(cc.cached_jit(fn)(x), ref)


# -- the size cap --------------------------------------------------------------------------------
def test_size_cap_evicts_least_recently_used_and_a_read_refreshes(store, monkeypatch):
    """Ten 1 kB entries with a 6 kB cap: writing evicts the oldest down to 90 % of the cap; an
    old entry read just before survives (a read refreshes its mtime, which noatime mounts
    cannot spoil); files the store does not own are never touched."""
    size = len(cs.encode("k0", bytes(1000)))
    monkeypatch.setenv("PROLEG_CACHE_MAX_BYTES", str(6 * size))
    foreign = os.path.join(store.root, "export", "notes.txt")
    os.makedirs(os.path.dirname(foreign))
    open(foreign, "w").write("mine")
    t0 = time.time() - 1000
    for i in range(5):
        assert store.write("export", f"e{i}", f"k{i}", bytes(1000))
        os.utime(store.path("export", f"e{i}"), (t0 + i, t0 + i))
    assert store.read("export", "e0", "k0") is not None  # the oldest, read now: most recent
    for i in range(5, 10):
        assert store.write("export", f"e{i}", f"k{i}", bytes(1000))
    left = {os.path.basename(p) for p in cf.entry_files(store.root)}
    info = store.info()
    assert info["total_bytes"] <= 6 * size and info["kinds"]["export"]["bytes"] == len(left) * size
    assert "e0.entry" in left and "e1.entry" not in left and "e9.entry" in left
    assert os.path.exists(foreign)
    monkeypatch.setenv("PROLEG_CACHE_MAX_BYTES", str(size - 1))  # larger than the cap: not stored
    assert not store.write("export", "big", "kb", bytes(1000))


def test_the_folder_is_scanned_only_when_the_cap_may_be_passed(store, monkeypatch):
    """Keeping the cap costs a scan (O(files)) on a process's first write and then only when the
    bytes written may pass it, not one per write."""
    scans = []
    files = cs.Store.files
    monkeypatch.setattr(cs.Store, "files", lambda self: scans.append(1) or files(self))
    size = len(cs.encode("k0", bytes(100)))
    monkeypatch.setenv("PROLEG_CACHE_MAX_BYTES", str(1000 * size))
    for i in range(40):
        store.write("export", f"e{i}", f"k{i}", bytes(100))
    assert len(scans) == 1
    monkeypatch.setenv("PROLEG_CACHE_MAX_BYTES", str(20 * size))
    for i in range(40, 60):
        store.write("export", f"e{i}", f"k{i}", bytes(100))
    assert len(cf.entry_files(store.root)) <= 20 and len(scans) < 20


def test_cap_setting():
    env = os.environ.get("PROLEG_CACHE_MAX_BYTES")
    try:
        for raw, want in [("", cs.DEFAULT_MAX_BYTES), ("12345", 12345), ("500M", 500 * 2**20), ("2GiB", 2 * 2**30),
                          ("1.5g", int(1.5 * 2**30)), ("0", 0)]:
            os.environ["PROLEG_CACHE_MAX_BYTES"] = raw
            assert cs.max_bytes() == want
        os.environ["PROLEG_CACHE_MAX_BYTES"] = "lots"
        with pytest.warns(pl.ProlegWarning, match="not a size"):
            assert cs.max_bytes() == cs.DEFAULT_MAX_BYTES
    finally:
        if env is None:
            os.environ.pop("PROLEG_CACHE_MAX_BYTES", None)
        else:
            os.environ["PROLEG_CACHE_MAX_BYTES"] = env


def test_jax_persistent_cache_goes_through_the_store():
    """A JAX release without the hook would silently fall back: this fails instead."""
    from jax._src import compilation_cache as jcc

    assert getattr(jcc.get_file_cache, "_proleg", False)
    cache, _ = jcc.get_file_cache("/nonexistent/proleg-test")
    assert cache.get("jit_f-" + "0" * 64) is None  # a miss, no folder created
    assert not os.path.exists("/nonexistent/proleg-test")


# -- real processes ------------------------------------------------------------------------------
_RACE = r"""
import os, sys, time
import proleg.cache_store as cs
st = cs.Store(sys.argv[1]); role = sys.argv[2]; payload = bytes(range(256)) * 4000  # 1 MB
t_end = time.time() + float(sys.argv[3]); n = bad = 0
while time.time() < t_end:
    if role == "w":
        n += st.write("xla", cs.entry_name("jit_same"), "jit_same", payload)
    else:
        got = st.read("xla", cs.entry_name("jit_same"), "jit_same"); n += got is not None; bad += got not in (None, payload)
print(n, bad, cs.stats["corrupt"])
"""


def test_concurrent_writers_and_readers_of_one_key(tmp_path):
    """Three processes rewrite the same 1 MB entry while two read it: every read is the whole
    entry or a miss (never a part: stats corrupt 0), the last writer wins, no temp file stays."""
    env = cf.child_env(tmp_path)
    procs = [subprocess.Popen([sys.executable, "-c", _RACE, str(tmp_path), r, "3"], stdout=subprocess.PIPE, text=True, env=env)
             for r in "wwwrr"]
    outs = [p.communicate(timeout=300)[0].split() for p in procs]
    assert all(p.returncode == 0 for p in procs)
    writes = sum(int(o[0]) for o in outs[:3])
    reads, bad, corrupt = (sum(int(o[i]) for o in outs[3:]) for i in range(3))
    assert writes > 3 and reads > 0 and bad == 0 and corrupt == 0
    assert cf.invalid_entries(tmp_path) == {} and cf.temp_files(tmp_path) == []


def _reference(tmp_path, workload="fn", links="1"):
    ref_dir = tmp_path / "reference"
    rc, got, err = cf.run(ref_dir, "--workload", workload, "--links", links)
    assert rc == 0, err
    return got["RESULT"], ref_dir


def _same_model_at_once(tmp_path, n, workload, links):
    ref, ref_dir = _reference(tmp_path, workload, links)
    cache = tmp_path / "shared"
    procs = [cf.start(cache, "--workload", workload, "--links", links) for _ in range(n)]
    outs = [p.communicate(timeout=1800) for p in procs]
    assert all(p.returncode == 0 for p in procs), [o[1][-2000:] for o in outs]
    results = [cf.parse(o[0])["RESULT"] for o in outs]
    assert {r["q"] for r in results} == {ref["q"]}  # bitwise identical, and equal to one process alone
    assert all(r["warnings"] == [] for r in results)
    # one entry per key: proleg's keys are the reference's; JAX's XLA keys include the cache folder
    # (its compile options name it), so those are counted
    names = lambda d: sorted(os.path.relpath(p, d) for p in cf.entry_files(d) if "xla" not in os.path.relpath(p, d))  # noqa: E731
    assert names(cache) == names(ref_dir)
    assert len(cf.entry_files(cache)) == len(cf.entry_files(ref_dir))
    assert cf.invalid_entries(cache) == {} and cf.temp_files(cache) == []


def test_processes_compiling_the_same_new_function_at_once(tmp_path):
    _same_model_at_once(tmp_path, 4, "fn", "1")


@pytest.mark.slow
def test_eight_processes_simulating_the_same_new_model_at_once(tmp_path):
    _same_model_at_once(tmp_path, 8, "pendulum", "1,2")


def _killed_at_random_points_of_writes(tmp_path, n, workload, links, seed=34):
    """Each child first runs the workload on what the previous one left (it must succeed with
    at most one cache warning and the reference's bits), then deletes random entries, drops its
    executables, reruns, and SIGKILLs itself at a random phase of a random one of the writes."""
    ref, _ = _reference(tmp_path, workload, links)
    cache = tmp_path / "killed"
    rng = np.random.default_rng(seed)
    killed = []
    for i in range(n + 1):
        k = int(rng.integers(1, 4))
        args = ["--workload", workload, "--links", links]
        if i < n:
            args += ["--delete", k, "--kill-write", int(rng.integers(0, k)), "--kill-phase", cf.PHASES[i % len(cf.PHASES)],
                     "--seed", int(rng.integers(1 << 30))]
        rc, got, err = cf.run(cache, *args)
        assert "RESULT" in got, err
        assert got["RESULT"]["q"] == ref["q"] and len(got["RESULT"]["warnings"]) <= 1, (i, got["RESULT"]["warnings"])
        killed.append(rc == -9)
        if i == n:
            assert rc == 0, err
    assert sum(killed) >= 0.9 * n  # the kill landed in a write (not after the last one)
    assert cf.invalid_entries(cache) == {}


def test_process_killed_during_cache_writes(tmp_path):
    _killed_at_random_points_of_writes(tmp_path, 5, "fn", "1")


@pytest.mark.slow
def test_process_killed_during_cache_writes_fifty_times(tmp_path):
    _killed_at_random_points_of_writes(tmp_path, 50, "pendulum", "1,2")


def _damaged_files_are_rebuilt(tmp_path, n_files, workload, links, seed=20):
    """Truncate or bit-flip ``n_files`` entries (exported functions, trails and JAX's executables
    alike): the next run warns once per damaged entry, gives the reference's bits and rebuilds
    them all; the run after warns about nothing."""
    ref, _ = _reference(tmp_path, workload, links)
    cache = tmp_path / "damaged"
    rc, got, err = cf.run(cache, "--workload", workload, "--links", links)
    assert rc == 0, err
    files = cf.entry_files(cache)
    assert len(files) >= n_files
    rng = np.random.default_rng(seed)
    hit = cf.damage([files[i] for i in rng.permutation(len(files))[:n_files]], rng)
    assert len(cf.invalid_entries(cache)) == n_files
    rc, got, err = cf.run(cache, "--workload", workload, "--links", links)
    assert rc == 0, err
    assert got["RESULT"]["q"] == ref["q"]
    assert len(got["RESULT"]["warnings"]) == n_files, (hit, got["RESULT"]["warnings"])  # one per damaged entry
    assert cf.invalid_entries(cache) == {} and {f for f, _ in hit} <= set(cf.entry_files(cache))  # all rebuilt
    rc, got, err = cf.run(cache, "--workload", workload, "--links", links)
    assert rc == 0 and got["RESULT"]["q"] == ref["q"] and got["RESULT"]["warnings"] == []


def test_damaged_cache_files_are_rebuilt(tmp_path):
    _damaged_files_are_rebuilt(tmp_path, 3, "fn", "1")


@pytest.mark.slow
def test_twenty_damaged_cache_files_are_rebuilt(tmp_path):
    _damaged_files_are_rebuilt(tmp_path, 20, "pendulum", "1,2")


def test_full_read_only_or_uncreatable_folder_turns_writing_off(tmp_path):
    """A real full disk (an 8 kB tmpfs, or a file-size limit where mounting is not allowed), a
    read-only folder holding part of the entries (a read-only bind mount, or chmod), and a folder
    that cannot be created (a file in its path): each run gives the right answer with exactly
    one cache warning; the read-only one still loads the entries it has."""
    ref, partial = _reference(tmp_path)  # then read-only, one entry short
    args = ("--workload", "fn", "--links", "1")
    os.unlink(cf.entry_files(partial)[-1])
    blocker = tmp_path / "a-file"
    blocker.write_text("")
    runs = {"uncreatable": cf.start(blocker / "cache", *args)}
    if cf.can_mount():
        (tmp_path / "full").mkdir()
        runs["full"] = cf.start(tmp_path / "full", *args, prefix=cf.tmpfs_prefix(tmp_path / "full", size="8k"))
        runs["read_only"] = cf.start(partial, *args, prefix=cf.tmpfs_prefix(partial, read_only=True))
    else:
        runs["full"] = cf.start(tmp_path / "full", *args, "--fsize", 4000)  # the first two of three entries fit
        for root, dirs, files in os.walk(partial):
            for d in dirs:
                os.chmod(os.path.join(root, d), 0o555)
        runs["read_only"] = cf.start(partial, *args)
    for name, p in runs.items():
        out, err = p.communicate(timeout=900)
        assert p.returncode == 0, (name, err[-3000:])
        got = cf.parse(out)["RESULT"]
        assert got["q"] == ref["q"], name
        assert len(got["warnings"]) == 1 and "cannot write" in got["warnings"][0], (name, got["warnings"])
        if name == "read_only":
            assert got["stats"]["read"] == len(cf.entry_files(partial))  # the entries it has are loaded
        if name == "full":
            assert got["stats"]["written"] >= 1 and got["stats"]["write_failed"] == 1


# -- the command line ----------------------------------------------------------------------------
def test_cli_cache_info_and_clear(store, tmp_path):
    from typer.testing import CliRunner

    from proleg.cli.main import app

    store.write("export", "f-1", "k1", bytes(100))
    store.write("xla", "jit_f-1", "k2", bytes(300))
    store.write("trail", "t1", "k3", bytes(10))
    open(os.path.join(store.root, "export", ".f-1.1.2.x.tmp"), "wb").write(bytes(7))
    open(tmp_path / "README-mine.txt", "w").write("not the cache's")
    runner = CliRunner()
    res = runner.invoke(app, ["cache", "info", "--json"])
    assert res.exit_code == 0, res.output
    info = json.loads(res.stdout)
    assert info["dir"] == str(tmp_path) and info["max_bytes"] == cs.DEFAULT_MAX_BYTES
    assert {k: v["entries"] for k, v in info["kinds"].items() if v["entries"]} == {"export": 1, "xla": 1, "trail": 1, "tmp": 1}
    assert info["total_bytes"] == sum(os.path.getsize(p) for p in [*cf.entry_files(tmp_path), *cf.temp_files(tmp_path)])
    res = runner.invoke(app, ["cache", "info"])
    assert res.exit_code == 0 and "xla" in res.output
    res = runner.invoke(app, ["cache", "clear"])
    assert res.exit_code == 0 and "4 files" in res.output
    assert cf.entry_files(tmp_path) == [] and cf.temp_files(tmp_path) == []
    assert (tmp_path / "README-mine.txt").exists()
