"""Memory maps and resident memory of a process that compiles many different HyQ legs.

Each model is ``proleg.robots.hyq_leg(joints="bushings8", cylinder_length=L)`` with its own
hydraulic cylinder length L (7 bodies, 8 bushings, contact, servo): a new geometry whose
simulation compiles anew (4 XLA compilations per model in a loop). 20 ms simulated per model.

Modes (``--modes``):

``loop``        a plain script: ``simulate(assemble(hyq_leg(...)))`` for N lengths in one process
``builder``     ``proleg.study.Study`` over a builder of the cylinder length, in this process
                (executor "local"), one variant per batch
``processes``   the same study on the "processes" executor (2 spawned workers); the maps and RSS
                are those of the workers, sampled by the driver
``unguarded``   ``loop`` with proleg.memguard's thresholds raised out of reach: what the process
                would hold without it (use a small N: ~100 MB per model)

``--trace [FILE]`` appends one JSON line per model (mode, index, wall, maps, RSS, clears; for
``processes`` the largest worker's maps and RSS when its batch came back), flushed as it goes, so
a run stopped early still shows whether maps and RSS plateau. Traces are raw data, written only
when asked and by default outside the repository (``--trace`` alone: a new file under
``$TMPDIR/proleg-bench/``; its path is logged). What the docs read is a summary of them:
``--summarize FILE`` (per mode and clear cycle, every 5th model) and ``--compare BEFORE AFTER``
(resident memory at given models, two traces of the same modes side by side, e.g. before and
after a fix), both printed as markdown. ``--max-wall S`` ends a mode after S seconds and reports
the models it reached (a study stops after the batch in flight).

Columns: ``peak maps`` (sampled every 0.2 s by a thread, and after every model), ``limit / 2``
(half the kernel's vm.max_map_count, the target), ``peak RSS``, ``maps/model`` and
``RSS/model`` over the first models (before any clear), ``clears`` (memguard's cache clears;
the processes mode counts them from the workers' map drops), ``recycles`` (processes: worker
pools replaced because a worker stayed above its threshold after clearing), wall time. Run it
niced: it is CPU heavy. The thresholds are memguard's (``PROLEG_MAX_MAPS``,
``PROLEG_MAX_RSS_BYTES``; printed with the table); a lower RSS threshold shows the bound at a
smaller N:

    nice -n 10 python bench/memory_maps.py --n 300
    PROLEG_MAX_RSS_BYTES=1610612736 nice -n 10 python bench/memory_maps.py --n 45 --modes loop,processes
"""

from __future__ import annotations

import argparse
import os
import sys
import threading
import time

sys.path.insert(0, os.path.dirname(__file__))
from common import add_output_args, emit, log  # noqa: E402

T_END, DT_OUT = 0.02, 1e-3


class Budget(Exception):
    """A mode ran out of its ``--max-wall`` seconds."""


class Trace:
    """One JSON line per model, flushed at once (a run cut short keeps its trace)."""

    def __init__(self, path, mode, max_wall):
        self.f = open(path, "a") if path else None
        self.mode, self.max_wall, self.t0, self.n = mode, max_wall, time.perf_counter(), 0

    def add(self, maps, rss, clears, pid=None):
        import json

        self.n += 1
        rec = {"mode": self.mode, "i": self.n, "t": round(time.perf_counter() - self.t0, 2), "maps": maps,
               "rss_mib": round(rss / 2**20, 1), "clears": clears, "load": round(os.getloadavg()[0], 2)}
        if pid is not None:
            rec["pid"] = pid
        if self.f:
            self.f.write(json.dumps(rec) + "\n")
            self.f.flush()

    def over(self):
        return self.max_wall is not None and time.perf_counter() - self.t0 > self.max_wall


def lengths(n):
    import numpy as np

    return np.round(np.linspace(0.075, 0.095, n), 9)  # m; the default 0.08 m inside


def hyq_builder(cylinder_length):
    import proleg as pl

    return pl.assemble(pl.robots.hyq_leg(joints="bushings8", cylinder_length=float(cylinder_length)))


def _maps(pid="self"):
    try:
        with open(f"/proc/{pid}/maps", "rb") as f:
            return sum(1 for _ in f)
    except OSError:
        return 0


def _rss(pid="self"):
    try:
        with open(f"/proc/{pid}/statm") as f:
            return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, IndexError):
        return 0


class Sampler:
    """Peak maps and RSS of this process (or of its child processes) every ``dt`` seconds."""

    def __init__(self, children=False, dt=0.2):
        self.children, self.dt = children, dt
        self.peak_maps = self.peak_rss = 0
        self.drops = 0  # a worker's maps fell by more than half: its caches were cleared
        self._last = {}
        self._stop = threading.Event()
        self._t = threading.Thread(target=self._run, daemon=True)

    def pids(self):
        if not self.children:
            return ["self"]
        import multiprocessing as mp

        return [p.pid for p in mp.active_children()]

    def sample(self):
        for pid in self.pids():
            m, r = _maps(pid), _rss(pid)
            if m and self._last.get(pid, 0) > 2 * m + 1000:
                self.drops += 1
            self._last[pid] = m
            self.peak_maps, self.peak_rss = max(self.peak_maps, m), max(self.peak_rss, r)

    def _run(self):
        while not self._stop.wait(self.dt):
            self.sample()

    def __enter__(self):
        self._t.start()
        return self

    def __exit__(self, *exc):
        self._stop.set()
        self._t.join()


def run_loop(n, tr):
    import proleg as pl
    from proleg import memguard

    trace = []
    with Sampler() as s:
        for i, L in enumerate(lengths(n)):
            if tr.over():
                break
            pl.simulate(pl.assemble(pl.robots.hyq_leg(joints="bushings8", cylinder_length=float(L))), t_end=T_END,
                            dt_output=DT_OUT, progress=False)
            s.sample()
            trace.append((_maps(), _rss()))
            tr.add(*trace[-1], memguard.clears())
            if i % 10 == 0:
                log(f"loop {i}/{n}: maps {trace[-1][0]}, RSS {trace[-1][1] / 2**20:.0f} MiB, clears {memguard.clears()}")
    return s, trace, memguard.clears(), len(trace), 0


def run_study(n, executor, tr):
    import proleg as pl
    from proleg import memguard

    st = pl.study.Study(hyq_builder, {"cylinder_length": list(map(float, lengths(n)))},
                        {"z_slider": lambda r: r.part("slider").position[-1, 2]}, dict(t_end=T_END, dt_output=DT_OUT))
    trace, done = [], []

    def on_batch(rows):
        done.extend(r["status"] == "success" for r in rows)
        if executor == "processes":  # the worker that ran this batch, sampled as it returns
            w = str(rows[0].get("worker", "")).rpartition(":")[2]
            pid = int(w) if w.isdigit() else None
            kids = [pid] if pid else s.pids()
            m, r = max(((_maps(p), _rss(p)) for p in kids), default=(0, 0))
            tr.add(m, r, s.drops, pid)
        else:
            trace.append((_maps(), _rss()))
            tr.add(*trace[-1], memguard.clears())
        if len(done) % 10 == 0:
            log(f"{executor} {len(done)} batches, last {tr.mode} trace maps/RSS sampled")
        if tr.over():
            raise Budget

    from proleg.study.executors import recycled_pools

    recycled = recycled_pools()
    with Sampler(children=executor == "processes") as s:
        try:
            st.run(design="grid", executor=executor, batch_size=1, workers=2 if executor == "processes" else 1,
                   progress=False, on_batch=on_batch)
        except Budget:
            log(f"{executor}: --max-wall reached after {len(done)} models")
        s.sample()
    ok = int(sum(done))
    if executor == "processes":
        from proleg.study.executors import shutdown_pools

        shutdown_pools()
        return s, [], s.drops, ok, recycled_pools() - recycled
    return s, trace, memguard.clears(), ok, 0


def per_model(trace, k=4):
    """Growth per model over the first k models (before any clear)."""
    if len(trace) < k + 1:
        return float("nan"), float("nan")
    (m0, r0), (m1, r1) = trace[0], trace[k]
    return (m1 - m0) / k, (r1 - r0) / k / 2**20


def summarize(path, every=5):
    """Markdown of a ``--trace`` file: per mode the models reached, the largest maps and RSS
    after any model, the clears, and per clear cycle (models between two clears) the largest
    maps and RSS, so a bound shows as equal peaks cycle after cycle; then every ``every``-th
    model's line."""
    import json

    recs = [json.loads(line) for line in open(path) if line.strip()]
    out = []
    for mode in dict.fromkeys(r["mode"] for r in recs):
        rs = [r for r in recs if r["mode"] == mode]
        out += [f"## {mode}: {len(rs)} models, {rs[-1]['t']:.0f} s, load {min(r['load'] for r in rs):.1f}-{max(r['load'] for r in rs):.1f}", "",
                f"largest after a model: maps {max(r['maps'] for r in rs):,} (limit / 2 = {max_map_count_half():,}), "
                f"RSS {max(r['rss_mib'] for r in rs):,.0f} MiB; clears {rs[-1]['clears']}", "",
                "| cycle | models | largest maps | largest RSS [MiB] | maps after its first model | RSS after its first model [MiB] |",
                "|---:|---|---:|---:|---:|---:|"]
        cycles = {}
        for r in rs:
            cycles.setdefault(r["clears"], []).append(r)
        for c, cr in cycles.items():
            out.append(f"| {c} | {cr[0]['i']}-{cr[-1]['i']} | {max(r['maps'] for r in cr):,} | {max(r['rss_mib'] for r in cr):,.0f} "
                       f"| {cr[0]['maps']:,} | {cr[0]['rss_mib']:,.0f} |")
        out += ["", "| model | t [s] | maps | RSS [MiB] | clears | load |", "|---:|---:|---:|---:|---:|---:|"]
        for r in rs:
            if r["i"] % every == 0 or r["i"] == 1 or r is rs[-1]:
                out.append(f"| {r['i']} | {r['t']:.0f} | {r['maps']:,} | {r['rss_mib']:,.0f} | {r['clears']} | {r['load']:.1f} |")
        out.append("")
    return "\n".join(out)


def rss_growth(recs, first=20, last=160):
    """Least-squares growth of RSS per model [MiB/model] over models ``first``..``last`` (after the
    maps have levelled off), per worker process where the trace names one (processes mode)."""
    import numpy as np

    out = {}
    for key in dict.fromkeys(r.get("pid") for r in recs):
        rs = [r for r in recs if r.get("pid") == key]
        sel = [r for k, r in enumerate(rs, 1) if first <= k <= last]
        if len(sel) >= 3:
            x = np.arange(len(sel), dtype=float)
            out[key] = float(np.polyfit(x, [r["rss_mib"] for r in sel], 1)[0])
    return out


def compare(before, after, at=(16, 28, 40)):
    """``before``, ``after``: a trace file, or several comma-separated. Markdown: resident memory at models ``at`` for every mode both traces hold, before against
    after, and the growth between the last two of ``at``; then, per mode of ``before``, the RSS
    growth per model once the maps have levelled off (models 20-160; per worker for processes)."""
    import json

    def load(paths):  # one path, or several (comma-separated) read as one trace
        return [json.loads(line) for path in str(paths).split(",") for line in open(path) if line.strip()]

    b, a = load(before), load(after)
    at = tuple(at)
    out = [f"| mode | RSS at model {' / '.join(map(str, at))}, before [MiB] | after [MiB] | growth from model {at[-2]} to {at[-1]}, before → after [MiB] |",
           "|---|---:|---:|---:|"]
    for mode in dict.fromkeys(r["mode"] for r in b):
        rb = {r["i"]: r["rss_mib"] for r in b if r["mode"] == mode}
        ra = {r["i"]: r["rss_mib"] for r in a if r["mode"] == mode}
        if not ra or any(i not in rb or i not in ra for i in at):
            continue
        out.append(f"| {mode} | {' / '.join(f'{rb[i]:,.0f}' for i in at)} | {' / '.join(f'{ra[i]:,.0f}' for i in at)} "
                   f"| {rb[at[-1]] - rb[at[-2]]:,.0f} → {ra[at[-1]] - ra[at[-2]]:,.0f} |")
    out += ["", "| mode (before) | models | RSS growth, models 20-160 [MiB/model] |", "|---|---:|---:|"]
    for mode in dict.fromkeys(r["mode"] for r in b):
        rs = [r for r in b if r["mode"] == mode]
        g = rss_growth(rs)
        per = ", ".join(f"{v:.1f}" for v in g.values())
        out.append(f"| {mode}{' (per worker)' if len(g) > 1 else ''} | {len(rs)} | {per} |")
    return "\n".join(out) + "\n"


def default_trace_path(modes):
    """A new trace file outside the repository: $TMPDIR/proleg-bench/memory_maps_<modes>_<time>.jsonl."""
    import tempfile

    d = os.path.join(tempfile.gettempdir(), "proleg-bench")
    os.makedirs(d, exist_ok=True)
    return os.path.join(d, f"memory_maps_{modes.replace(',', '-')}_{time.strftime('%Y%m%d-%H%M%S')}_trace.jsonl")


def max_map_count_half():
    with open("/proc/sys/vm/max_map_count") as f:
        return int(f.read()) // 2


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--n", type=int, default=300, help="models (distinct cylinder lengths) per mode")
    p.add_argument("--modes", default="loop,builder,processes", help="comma-separated: loop, builder, processes, unguarded")
    p.add_argument("--trace", nargs="?", const="", default=None, metavar="FILE",
                   help="append one JSON line per model to FILE (alone: a new file under $TMPDIR/proleg-bench/; raw data, not for the repository)")
    p.add_argument("--max-wall", type=float, default=None, help="seconds per mode; a mode stops there (models reached are reported)")
    p.add_argument("--summarize", default=None, help="print the per-mode summary of a --trace file and exit")
    p.add_argument("--compare", nargs=2, default=None, metavar=("BEFORE", "AFTER"),
                   help="print RSS at --at models for two traces of the same modes (each a --trace file, or several comma-separated), "
                   "and the growth per model of BEFORE's modes, and exit")
    p.add_argument("--at", default="16,28,40", help="--compare: the models to show (comma-separated)")
    add_output_args(p, "memory_maps")
    args = p.parse_args()
    if args.summarize:
        print(summarize(args.summarize))
        return
    if args.compare:
        print(compare(*args.compare, at=[int(k) for k in args.at.split(",")]))
        return
    if args.trace == "":
        args.trace = default_trace_path(args.modes)
    if args.trace:
        log(f"trace: {args.trace}")
    import jax

    jax.config.update("jax_enable_x64", True)
    from proleg import memguard

    limit = memguard.max_map_count()
    rows = []
    for mode in args.modes.split(","):
        t0 = time.perf_counter()
        tr = Trace(args.trace, mode, args.max_wall)
        if mode == "unguarded":
            os.environ["PROLEG_MAX_MAPS"] = os.environ["PROLEG_MAX_RSS_BYTES"] = str(2**62)
            s, trace, clears, ok, recycles = run_loop(args.n, tr)
            os.environ.pop("PROLEG_MAX_MAPS")
            os.environ.pop("PROLEG_MAX_RSS_BYTES")
        elif mode == "loop":
            s, trace, clears, ok, recycles = run_loop(args.n, tr)
        else:
            s, trace, clears, ok, recycles = run_study(args.n, "local" if mode == "builder" else "processes", tr)
        dm, dr = per_model(trace)
        rows.append({"mode": mode, "models": tr.n, "of": args.n, "succeeded": ok, "peak maps": s.peak_maps, "limit / 2": limit // 2,
                     "peak RSS [MiB]": round(s.peak_rss / 2**20), "maps/model": dm, "RSS/model [MiB]": dr,
                     "clears": clears, "recycles": recycles, "wall [s]": round(time.perf_counter() - t0, 1),
                     "status": "ok" if s.peak_maps < limit // 2 else "OVER"})
        log(rows[-1])
        jax.clear_caches()
    mmaps, mrss = memguard.limits()
    emit(args, "Memory maps and RSS over many distinct HyQ-leg models", rows,
         ["mode", "models", "of", "succeeded", "peak maps", "limit / 2", "peak RSS [MiB]", "maps/model", "RSS/model [MiB]", "clears", "recycles", "wall [s]", "status"],
         meta={"memguard maps threshold": mmaps, "memguard RSS threshold [MiB]": mrss // 2**20, "vm.max_map_count": limit})


if __name__ == "__main__":
    main()
