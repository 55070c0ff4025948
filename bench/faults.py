"""The compile cache under concurrency and faults (issue 34 item 2 targets): one row per target.

    python bench/faults.py                      # 8 processes, 50 kills, 20 damaged files
    python bench/faults.py --procs 4 --kills 10 --damage 12 --links 1

Every run is a real child process (tests/cache_faults.py) simulating a 1-link and a 2-link
pendulum with its own PROLEG_CACHE_DIR in a temporary folder (never ~/.cache/proleg):

- ``concurrent``: ``--procs`` processes start together on an empty cache; all must succeed with
  bitwise-identical results (equal to one process alone), and the cache end with one valid
  entry per key and no temporary file.
- ``sigkill``: ``--kills`` times, a process deletes 1-3 random entries, reruns and SIGKILLs
  itself at a random point (one of five phases, cycled) of a random one of the rewrites; the next
  process must succeed with the reference's bits and at most one cache warning.
- ``damage``: ``--damage`` random entry files are truncated or bit-flipped; the next run must
  succeed with the reference's bits and rebuild every damaged entry, and the one after warn
  about nothing.
- ``full disk`` / ``read-only`` / ``uncreatable``: an 8 kB tmpfs (root, private mount namespace)
  or a file-size limit, a read-only bind mount of a partial cache (or chmod), a folder under a
  file: the run succeeds with exactly one warning.

The table goes to stdout and bench/results/faults.md (and .json).
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

import cache_faults as cf  # noqa: E402
import numpy as np  # noqa: E402
from common import add_output_args, emit  # noqa: E402


def _args(a):
    return ("--workload", "pendulum", "--links", a.links)


def concurrent(a, tmp, ref, ref_dir):
    t = time.perf_counter()
    cache = tmp / "concurrent"
    procs = [cf.start(cache, *_args(a)) for _ in range(a.procs)]
    outs = [p.communicate(timeout=3600) for p in procs]
    ok = [p.returncode == 0 and "RESULT" in cf.parse(o[0]) for p, o in zip(procs, outs)]
    res = [cf.parse(o[0]).get("RESULT", {}) for o in outs]
    same = sum(r.get("q") == ref["q"] for r in res)
    n_ref, n = len(cf.entry_files(ref_dir)), len(cf.entry_files(cache))
    bad, tmpf = cf.invalid_entries(cache), cf.temp_files(cache)
    return dict(target=f"{a.procs} processes, same new model, empty cache", runs=a.procs, succeeded=sum(ok),
                identical=same, max_warnings=max(len(r.get("warnings", [])) for r in res),
                entries=f"{n} valid {n - len(bad)} (one process: {n_ref}); tmp left {len(tmpf)}",
                met=sum(ok) == a.procs and same == a.procs and n == n_ref and not bad and not tmpf,
                seconds=time.perf_counter() - t)


def sigkill(a, tmp, ref):
    t = time.perf_counter()
    cache = tmp / "killed"  # filled by the first run (JAX's executable keys name the folder: no copies)
    rng = np.random.default_rng(a.seed)
    killed = ok = same = 0
    warn_max = 0
    phases = dict.fromkeys(cf.PHASES, 0)
    for i in range(a.kills + 1):
        args = list(_args(a))
        if i < a.kills:
            k = int(rng.integers(1, 4))
            phase = cf.PHASES[i % len(cf.PHASES)]
            args += ["--delete", k, "--kill-write", int(rng.integers(0, k)), "--kill-phase", phase, "--seed", int(rng.integers(1 << 30))]
        rc, got, _err = cf.run(cache, *args)
        r = got.get("RESULT", {})
        if i > 0:  # the run after a kill
            ok += "RESULT" in got
            same += r.get("q") == ref["q"]
            warn_max = max(warn_max, len(r.get("warnings", [])))
        if i < a.kills and rc == -9:
            killed += 1
            phases[phase] += 1
    bad = cf.invalid_entries(cache)
    return dict(target=f"SIGKILL at random points of a cache write, {a.kills} times", runs=a.kills, succeeded=ok,
                identical=same, max_warnings=warn_max,
                entries=f"killed {killed} ({', '.join(f'{k} {v}' for k, v in phases.items())}); invalid after {len(bad)}",
                met=ok == a.kills and same == a.kills and warn_max <= 1 and killed >= 0.9 * a.kills and not bad,
                seconds=time.perf_counter() - t)


def damage(a, tmp, ref):
    t = time.perf_counter()
    cache = tmp / "damaged"
    cf.run(cache, *_args(a))
    files = cf.entry_files(cache)
    n = min(a.damage, len(files))
    rng = np.random.default_rng(a.seed + 1)
    hit = cf.damage([files[i] for i in rng.permutation(len(files))[:n]], rng)
    n_bad = len(cf.invalid_entries(cache))
    rc1, got1, _ = cf.run(cache, *_args(a))
    rebuilt = n - len(cf.invalid_entries(cache)) - sum(not os.path.exists(f) for f, _ in hit)
    rc2, got2, _ = cf.run(cache, *_args(a))
    r1, r2 = got1.get("RESULT", {}), got2.get("RESULT", {})
    kinds = sum("truncated" in how for _, how in hit)
    return dict(target=f"{n} damaged files ({kinds} truncated, {n - kinds} bit-flipped) of {len(files)}", runs=2,
                succeeded=(rc1 == 0) + (rc2 == 0), identical=(r1.get("q") == ref["q"]) + (r2.get("q") == ref["q"]),
                max_warnings=max(len(r1.get("warnings", [])), len(r2.get("warnings", []))),
                entries=f"invalid before {n_bad}, rebuilt {rebuilt}; warnings {len(r1.get('warnings', []))} then {len(r2.get('warnings', []))}",
                met=rc1 == rc2 == 0 and r1.get("q") == r2.get("q") == ref["q"] and rebuilt == n and not r2.get("warnings"),
                seconds=time.perf_counter() - t)


def folders(a, tmp, ref):
    rows = []
    partial = tmp / "partial"
    cf.run(partial, *_args(a))
    for f in cf.entry_files(partial)[::3]:
        os.unlink(f)
    blocker = tmp / "a-file"
    blocker.write_text("")
    mount = cf.can_mount()
    cases = {"uncreatable folder (under a file)": (blocker / "cache", (), ())}
    (tmp / "full").mkdir()
    if mount:
        cases["full disk (8 kB tmpfs)"] = (tmp / "full", cf.tmpfs_prefix(tmp / "full", size="8k"), ())
        cases["read-only folder, 2/3 of the entries (ro bind mount)"] = (partial, cf.tmpfs_prefix(partial, read_only=True), ())
    else:
        cases["full disk (file-size limit 8 kB)"] = (tmp / "full", (), ("--fsize", 8192))
        for root, dirs, _files in os.walk(partial):
            for d in dirs:
                os.chmod(os.path.join(root, d), 0o555)
        cases["read-only folder, 2/3 of the entries (chmod)"] = (partial, (), ())
    for target, (cache, prefix, extra) in cases.items():
        t = time.perf_counter()
        rc, got, _err = cf.run(cache, *_args(a), *extra, prefix=prefix)
        r = got.get("RESULT", {})
        w = r.get("warnings", [])
        st = r.get("stats", {})
        rows.append(dict(target=target, runs=1, succeeded=int(rc == 0), identical=int(r.get("q") == ref["q"]), max_warnings=len(w),
                         entries=f"written {st.get('written', 0)}, write failed {st.get('write_failed', 0)}, read {st.get('read', 0)}",
                         met=rc == 0 and r.get("q") == ref["q"] and len(w) == 1 and "cannot write" in w[0],
                         seconds=time.perf_counter() - t))
    return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--procs", type=int, default=8)
    ap.add_argument("--kills", type=int, default=50)
    ap.add_argument("--damage", type=int, default=20)
    ap.add_argument("--links", default="1,2", help="pendulums simulated by each run (1,2: about 24 cache files)")
    ap.add_argument("--seed", type=int, default=34)
    ap.add_argument("--only", default="", help="comma list of concurrent,sigkill,damage,folders")
    add_output_args(ap, "faults")
    a = ap.parse_args()
    only = set(filter(None, a.only.split(","))) or {"concurrent", "sigkill", "damage", "folders"}
    rows = []
    with tempfile.TemporaryDirectory(prefix="proleg-faults-") as d:
        tmp = Path(d)
        t = time.perf_counter()
        rc, got, err = cf.run(tmp / "reference", *_args(a))
        if rc != 0:
            sys.exit(f"the reference run failed:\n{err}")
        ref = got["RESULT"]
        print(f"reference run (cold): {time.perf_counter() - t:.1f} s, {len(cf.entry_files(tmp / 'reference'))} cache entries", file=sys.stderr)
        if "concurrent" in only:
            rows.append(concurrent(a, tmp, ref, tmp / "reference"))
        if "sigkill" in only:
            rows.append(sigkill(a, tmp, ref))
        if "damage" in only:
            rows.append(damage(a, tmp, ref))
        if "folders" in only:
            rows += folders(a, tmp, ref)
    cols = ["target", "runs", "succeeded", "identical", "max_warnings", "entries", "met", "seconds"]
    emit(a, "proleg compile cache under concurrency and faults", rows, cols,
         notes=["identical: runs whose final state equals a lone process's bit for bit; max_warnings: cache warnings in one run "
                "(the target is at most one after a kill, exactly one for a folder that cannot be written)"])


if __name__ == "__main__":
    main()
