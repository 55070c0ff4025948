"""A process that compiles many different models watches its own memory maps and resident memory.

Every new compiled model (a new geometry of a builder study, a loop over link lengths) adds XLA
executables: each new ``simulate(assemble(hyq_leg(cylinder_length=...)))`` (8 bushings,
``bench/memory_maps.py``, 2-core Intel VM, jaxlib 0.10.2) compiles 4 functions and adds ~750
memory maps and ~48 MiB of resident memory. proleg keeps at most ``CachedJit.MEMO`` (16)
executables per function, and a model the user dropped is freed
(:func:`proleg.compile_cache.traced_raw`; tests/test_model_release.py), so both plateau: maps
near 12,850 after 17 models, resident memory near 1.4 GiB after ~29 (the kernel stops a process
at ``vm.max_map_count``, 65,530 by default, with SIGSEGV). Before that fix JAX's trace caches
kept every model, and the resident memory grew ~12 MiB per model without end.

The thresholds below are the backstop for what proleg does not bound: larger models, many
functions of the user's own under ``jax.jit``, arrays the user keeps. Clearing the caches
(``jax.clear_caches()`` and :func:`proleg.compile_cache.clear`) returns the maps to ~1,100 at
once, but not the resident memory: the freed executables stay in glibc's heap (10 models:
1,485 MiB before the clear, 1,440 MiB after it). :func:`release` therefore also hands the free
heap back to the kernel (glibc's ``malloc_trim``), which brought the same process to 387 MiB.

:func:`release_if_needed` clears them when the process passes a threshold; :func:`proleg.assemble`
calls it before every new model, and the study's workers after every batch, so a study over
hundreds of geometries runs with no user action. Thresholds:

- maps: ``PROLEG_MAX_MAPS``, default a quarter of ``vm.max_map_count`` (16,382 of 65,530), so a
  process stays below half the kernel's limit with a model's worth of margin;
- resident memory: ``PROLEG_MAX_RSS_BYTES``, default a quarter of the machine's memory and at
  most 4 GiB (:data:`MAX_RSS_DEFAULT`; a worker of a pool of W workers: at most 1/(2W) of the
  memory, :func:`set_worker_share`, so the pool stays inside half the machine whatever W).
  Choosing a value: a loop over new HyQ legs levels off near 1.4 GiB; a lower value clears
  more often and costs recompiling what is used again (seconds per model), a higher one lets a
  process hold more before the clear.

After a clear that leaves the process above a threshold (memory held by the user's own arrays),
the in-process path cannot do more: the next clear waits until it has grown by half again, so
the caches are not cleared before every model. A study's worker in that state asks to be
replaced instead (:func:`should_recycle`; the "processes" executor then ends it once its batch
is back and starts a fresh one), which returns all its memory to the system.
"""

from __future__ import annotations

import gc
import os

_state = {"next_maps": None, "next_rss": None, "clears": 0}
_share = {"workers": 0}  # > 0 in a worker of a pool of that many (set_worker_share)

#: Upper end of the default resident-memory threshold [bytes] (``PROLEG_MAX_RSS_BYTES``).
MAX_RSS_DEFAULT = 4 * 2**30


def memory_maps() -> int:
    """Number of memory mappings of this process (lines of /proc/self/maps; 0 off Linux)."""
    try:
        with open("/proc/self/maps", "rb") as f:
            return sum(1 for _ in f)
    except OSError:
        return 0


def rss_bytes() -> int:
    """Resident memory of this process [bytes] (0 where /proc is missing)."""
    try:
        with open("/proc/self/statm") as f:
            return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, IndexError):
        return 0


def max_map_count() -> int:
    """The kernel's per-process limit on memory maps (vm.max_map_count; 65,530 if unknown)."""
    try:
        with open("/proc/sys/vm/max_map_count") as f:
            return int(f.read().strip())
    except (OSError, ValueError):
        return 65530


def _total_memory() -> int:
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):
        return 16 * 2**30


def env_int(name: str, default: int) -> int:
    """A positive integer setting from the environment variable ``name`` (a float spelling such
    as "1e9" is accepted); ``default`` when it is unset, not a number, or not positive."""
    try:
        v = int(float(os.environ.get(name, "")))
        return v if v > 0 else default
    except ValueError:
        return default


def set_worker_share(workers: int) -> None:
    """Make this process a worker of a pool of ``workers``: its default resident-memory threshold
    becomes at most 1/(2 ``workers``) of the machine's memory (``PROLEG_MAX_RSS_BYTES`` still wins)."""
    _share["workers"] = max(0, int(workers))


def limits() -> tuple[int, int]:
    """(maps, resident bytes) past which :func:`release_if_needed` clears the compiled code."""
    total = _total_memory()
    rss = min(total // 4, MAX_RSS_DEFAULT)
    if _share["workers"]:
        rss = min(rss, total // (2 * _share["workers"]))
    return env_int("PROLEG_MAX_MAPS", max_map_count() // 4), env_int("PROLEG_MAX_RSS_BYTES", rss)


def _trim_heap() -> bool:
    """Return the free pages of the C heap to the kernel (glibc's ``malloc_trim(0)``); False
    where there is no glibc (musl, macOS, Windows: their allocators return memory themselves or
    not at all, and nothing is lost by skipping it)."""
    import ctypes
    import ctypes.util

    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
        trim = libc.malloc_trim
    except (OSError, AttributeError, TypeError):
        return False
    trim.argtypes, trim.restype = [ctypes.c_size_t], ctypes.c_int
    trim(0)
    return True


def release() -> None:
    """Drop every compiled executable this process holds (JAX's caches and proleg's)."""
    import jax

    from . import compile_cache

    jax.clear_caches()
    compile_cache.clear()
    gc.collect()
    _trim_heap()  # the freed executables' pages back to the kernel: without it the RSS stays
    _state["clears"] += 1


def release_if_needed() -> bool:
    """Clear the compiled code if this process passed its map or memory threshold
    (:func:`limits`); True if it did."""
    if not _outside_traces():
        return False
    max_maps, max_rss = limits()
    maps, rss = memory_maps(), rss_bytes()
    if maps <= max(max_maps, _state["next_maps"] or 0) and rss <= max(max_rss, _state["next_rss"] or 0):
        return False
    release()
    maps, rss = memory_maps(), rss_bytes()
    _state["next_maps"] = int(1.5 * maps) if maps > max_maps else None
    _state["next_rss"] = int(1.5 * rss) if rss > max_rss else None
    return True


def should_recycle() -> bool:
    """True if this process is above a threshold although it has just cleared its compiled code
    (:func:`release_if_needed`, called here): what holds the memory is not a cache, and only a
    new process gets it back. A study's worker then asks the driver to replace it."""
    release_if_needed()
    max_maps, max_rss = limits()
    return memory_maps() > max_maps or rss_bytes() > max_rss


def _outside_traces() -> bool:
    """Never clear JAX's caches from inside a trace (a builder called under ``jit``)."""
    try:
        from jax._src import core

        return bool(core.trace_state_clean())
    except (ImportError, AttributeError):  # pragma: no cover - other jax versions: be safe
        return False


def clears() -> int:
    """How many times this process cleared its compiled code (:func:`release`)."""
    return _state["clears"]
