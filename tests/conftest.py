"""Test configuration: float64 everywhere, strict dtype promotion where proleg allows it."""

import gc
import os

import jax
import pytest

jax.config.update("jax_enable_x64", True)

MAX_MAPS = 40_000  # of the kernel's default vm.max_map_count = 65,530


def _memory_maps() -> int:
    try:
        with open(f"/proc/{os.getpid()}/maps") as f:
            return sum(1 for _ in f)
    except OSError:  # not Linux: no such limit to watch
        return 0


@pytest.fixture(autouse=True, scope="module")
def _release_compiled_code():
    """Drop JAX's compiled executables after a test module once the process holds many.

    XLA-CPU maps every compiled kernel as its own small code/data mappings (~2,000 per assembled
    and simulated model); a full run keeps hundreds of models alive in the jit caches and
    reaches vm.max_map_count, after which the process dies with SIGSEGV. Clearing after every
    module would also drop the small shared executables, and recompiling them made the suite
    ~1.7× slower, so the caches are cleared only above MAX_MAPS.
    """
    yield
    if _memory_maps() > MAX_MAPS:
        jax.clear_caches()
        gc.collect()
