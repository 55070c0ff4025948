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


def run_loop(n):
    import proleg as pl
    from proleg import memguard

    trace = []
    with Sampler() as s:
        for i, L in enumerate(lengths(n)):
            pl.simulate(pl.assemble(pl.robots.hyq_leg(joints="bushings8", cylinder_length=float(L))), t_end=T_END,
                            dt_output=DT_OUT, progress=False)
            s.sample()
            trace.append((_maps(), _rss()))
            if i % 10 == 0:
                log(f"loop {i}/{n}: maps {trace[-1][0]}, RSS {trace[-1][1] / 2**20:.0f} MiB, clears {memguard.clears()}")
    return s, trace, memguard.clears(), n, 0


def run_study(n, executor):
    import proleg as pl
    from proleg import memguard

    st = pl.study.Study(hyq_builder, {"cylinder_length": list(map(float, lengths(n)))},
                        {"z_slider": lambda r: r.part("slider").position[-1, 2]}, dict(t_end=T_END, dt_output=DT_OUT))
    trace = []

    def on_batch(rows):
        trace.append((_maps(), _rss()))
        if len(trace) % 10 == 0:
            log(f"{executor} {len(trace)} batches")

    from proleg.study.executors import recycled_pools

    recycled = recycled_pools()
    with Sampler(children=executor == "processes") as s:
        tab = st.run(design="grid", executor=executor, batch_size=1, workers=2 if executor == "processes" else 1,
                     progress=False, on_batch=on_batch)
        s.sample()
    ok = int((tab["status"] == "success").sum())
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


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--n", type=int, default=300, help="models (distinct cylinder lengths) per mode")
    p.add_argument("--modes", default="loop,builder,processes", help="comma-separated: loop, builder, processes, unguarded")
    add_output_args(p, "memory_maps")
    args = p.parse_args()
    import jax

    jax.config.update("jax_enable_x64", True)
    from proleg import memguard

    limit = memguard.max_map_count()
    rows = []
    for mode in args.modes.split(","):
        t0 = time.perf_counter()
        if mode == "unguarded":
            os.environ["PROLEG_MAX_MAPS"] = os.environ["PROLEG_MAX_RSS_BYTES"] = str(2**62)
            s, trace, clears, ok, recycles = run_loop(args.n)
            os.environ.pop("PROLEG_MAX_MAPS")
            os.environ.pop("PROLEG_MAX_RSS_BYTES")
        elif mode == "loop":
            s, trace, clears, ok, recycles = run_loop(args.n)
        else:
            s, trace, clears, ok, recycles = run_study(args.n, "local" if mode == "builder" else "processes")
        dm, dr = per_model(trace)
        rows.append({"mode": mode, "models": args.n, "succeeded": ok, "peak maps": s.peak_maps, "limit / 2": limit // 2,
                     "peak RSS [MiB]": round(s.peak_rss / 2**20), "maps/model": dm, "RSS/model [MiB]": dr,
                     "clears": clears, "recycles": recycles, "wall [s]": round(time.perf_counter() - t0, 1),
                     "status": "ok" if s.peak_maps < limit // 2 else "OVER"})
        log(rows[-1])
        jax.clear_caches()
    mmaps, mrss = memguard.limits()
    emit(args, "Memory maps and RSS over many distinct HyQ-leg models", rows,
         ["mode", "models", "succeeded", "peak maps", "limit / 2", "peak RSS [MiB]", "maps/model", "RSS/model [MiB]", "clears", "recycles", "wall [s]", "status"],
         meta={"memguard maps threshold": mmaps, "memguard RSS threshold [MiB]": mrss // 2**20, "vm.max_map_count": limit})


if __name__ == "__main__":
    main()
