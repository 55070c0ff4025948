"""A model the user has dropped is freed (issue 34, studies that cannot exhaust the host).

After ``simulate(assemble(model))`` and ``del``, nothing in proleg or JAX may keep the
System's topology (and with it the Model and what was traced from it) once proleg's own
bounded memo of executables (``CachedJit.MEMO`` per function) has moved past it. Before,
nested jits and ``jax.eval_shape`` calls put each topology into JAX's trace caches, one of
which has no size limit, and a loop over new HyQ legs grew by about 10 MiB per leg for as long
as it ran (bench/memory_maps.py). The test drops the memo to one entry and asks the garbage
collector whether the earlier models are gone, on both integration paths (Diffrax's Tsit5 in
joint coordinates and the generalized-α driver) with a general controller, whose laws
``assemble`` traces to check them.
"""

import gc
import weakref

import pytest

import proleg as pl
import proleg.compile_cache as cc


def _pendulum_with_controller(length):
    m = pl.Model("released", gravity=(0, 0, -9.81))
    rod = m.add_part("rod", 1.0, (1e-4, length**2 / 12, length**2 / 12), (length / 2, 0, 0))
    m.add_joint(pl.Revolute("pin", rod, m.ground, at=(0, 0, 0), axis=(0, 1, 0)))
    m.add_actuator(pl.JointActuator("drive", "pin"))
    m.add_controller(
        pl.StateMachine(
            "phases",
            states={"push": lambda t, s, mem: {"drive": 0.1}, "rest": lambda t, s, mem: {"drive": 0.0}},
            transitions=[("push", "rest", lambda t, s, mem: s.joint_angle("pin") > 0.5)],
            initial="push",
            outputs=["drive"],
            period=1e-2,
        )
    )
    return m


@pytest.mark.parametrize("integrator", [pl.Tsit5, pl.GeneralizedAlpha])
def test_a_dropped_model_is_freed(monkeypatch, integrator):
    monkeypatch.setattr(cc.CachedJit, "MEMO", 1)
    topologies = []
    for length in (0.9, 1.0, 1.1):  # three new models: each compiles anew
        system = pl.assemble(_pendulum_with_controller(length))
        topologies.append(weakref.ref(system.topo))
        result = pl.simulate(system, t_end=0.05, dt_output=1e-2, integrator=integrator(), progress=False)
        assert result.t[-1] == pytest.approx(0.05)
        # the outputs' compile runs in a background thread (simulate's _compile_outputs); a model
        # of a shared structure runs so fast that it may still be queued: wait for it, as any
        # use of the outputs does, so the memo has moved past the previous model
        assert result.qdd.shape[0] == result.t.shape[0]
        del system, result
    gc.collect()
    alive = [i for i, ref in enumerate(topologies[:-1]) if ref() is not None]
    if alive:  # say who holds the first one still alive
        holders = [type(r).__name__ for r in gc.get_referrers(topologies[alive[0]]())]
        pytest.fail(f"models {alive} are still referenced after del (the first by {holders})")
