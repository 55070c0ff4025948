"""Test configuration: float64 everywhere, strict dtype promotion where proleg allows it."""

import gc

import jax
import pytest

jax.config.update("jax_enable_x64", True)


@pytest.fixture(autouse=True, scope="module")
def _release_compiled_code():
    """Drop JAX's compiled executables after each test module.

    XLA-CPU maps every compiled kernel as its own small code/data mappings (~2,000 per assembled
    and simulated model); a full run keeps hundreds of models alive in the jit caches and
    reaches the kernel's vm.max_map_count (65,530), after which the process dies with SIGSEGV.
    """
    yield
    jax.clear_caches()
    gc.collect()
