"""Test configuration: float64 everywhere, strict dtype promotion where proleg allows it."""

import gc
import os

import jax
import pytest

jax.config.update("jax_enable_x64", True)

class JaxEvents:
    """Names of the functions behind one of JAX's duration events while active, e.g.
    ``/jax/core/compile/backend_compile_duration`` (XLA compiles) or
    ``/jax/core/compile/jaxpr_trace_duration`` (traces)."""

    def __init__(self, event):
        self.event, self.names = event, []

    def _on(self, event, duration, **kw):
        if event == self.event:
            self.names.append(str(kw.get("fun_name", "?")))

    def __enter__(self):
        import jax.monitoring as mon

        mon.register_event_duration_secs_listener(self._on)
        return self

    def __exit__(self, *exc):
        import jax.monitoring as mon

        mon.unregister_event_duration_listener(self._on)
        return False


@pytest.fixture
def jax_events():
    """``with jax_events("/jax/core/compile/...") as ev: ...`` then ``ev.names``."""
    return JaxEvents


MAX_MAPS = 40_000  # of the kernel's default vm.max_map_count = 65,530
# proleg.memguard (assemble) would clear at a quarter of the limit; the suite keeps its shared
# executables up to MAX_MAPS, as before (recompiling them costs more than the maps).
os.environ.setdefault("PROLEG_MAX_MAPS", str(MAX_MAPS))


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
        import proleg.compile_cache

        jax.clear_caches()
        proleg.compile_cache.clear()
        gc.collect()
