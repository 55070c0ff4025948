"""The on-disk cache of traced functions (proleg/compile_cache.py, issue 20 item 2): a warm start
reuses a model's traced and lowered simulate only when nothing the computation depends on has
changed. A stale hit would be a silent wrong answer, so the tests edit what a user edits (a
Motion law's constant, a global it reads, a closure value) and check that the answer follows.

Model: a disk on a revolute joint about z driven by ``Motion(displacement=law)``: the joint
angle is law(t) exactly (a rheonomic constraint), so each law's result is known in closed form.
"""

import warnings

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import proleg as pl
import proleg.compile_cache as cc

T_END = 0.2
RATE = 0.5  # [rad/s], read as a global by law_global
# XLA's vectorised sin/cos (its own polynomial) against NumPy's libm: each within a few ulp of
# the exact value, and differently so on another CPU or vector width, so 32 eps (7e-15)
# relative; these tests tell executables apart (a wrong static k is off by 50 %, a stale law
# by its own change), not the last bits of sin.
RTOL = 32 * np.finfo(np.float64).eps


@pytest.fixture(autouse=True)
def on_the_cpu(request):
    """proleg's disk cache and XLA options serve CPU compiles (a GPU host places single runs
    there too, analyses/placement.py); these tests also run on a GPU host, on its CPU."""
    if request.node.get_closest_marker("default_device"):
        yield
        return
    with jax.default_device(jax.devices("cpu")[0]):
        yield


@pytest.fixture
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("PROLEG_CACHE_DIR", str(tmp_path))
    return tmp_path / "export"


def spin(law):
    model = pl.Model("spin", gravity=(0, 0, 0))
    disk = model.add_part("disk", 1.0, (0.01, 0.01, 0.02), (0, 0, 0))
    model.add_joint(pl.Revolute("axle", disk, model.ground, at=(0, 0, 0), axis=(0, 0, 1)))
    model.add_motion(pl.Motion("drive", joint="axle", displacement=law))
    return pl.assemble(model)


def angle_at_end(system):
    res = pl.simulate(system, t_end=T_END, dt_output=0.1, coordinates="absolute", run=pl.RunOptions(prepare_outputs=False))
    return float(res.joint("axle").angle[-1])


def law_global(t):
    return RATE * t


def test_edited_motion_law_recomputes_identical_model_reuses(cache, jax_events):
    traces = lambda: jax_events("/jax/core/compile/jaxpr_trace_duration")  # noqa: E731
    law = eval("lambda t: 0.5 * t")  # the same source twice: as if run again in a new process
    before = dict(cc.stats)
    with traces() as tr:
        a = angle_at_end(spin(law))
    assert "advance" in tr.names and cc.stats["exported"] > before["exported"]
    assert a == pytest.approx(0.5 * T_END, rel=1e-9)

    loaded = cc.stats["loaded"]
    with traces() as tr:
        b = angle_at_end(spin(eval("lambda t: 0.5 * t")))  # a new model, new objects, same content
    assert "advance" not in tr.names and "_ic" not in tr.names  # loaded, not traced
    assert cc.stats["loaded"] > loaded
    assert b == a

    with traces() as tr:
        c = angle_at_end(spin(eval("lambda t: 0.7 * t")))  # the constant edited
    assert "advance" in tr.names
    assert c == pytest.approx(0.7 * T_END, rel=1e-9)


def test_global_closure_and_default_values_are_in_the_key(cache):
    global RATE
    k = lambda: cc.fingerprint(spin(law_global).topo.model)  # noqa: E731
    k0 = k()
    assert k() == k0  # deterministic for the same content
    RATE = 0.6
    try:
        assert k() != k0
    finally:
        RATE = 0.5

    def closure(w):
        return lambda t: w * t

    assert cc.fingerprint(closure(1.0)) != cc.fingerprint(closure(2.0))
    assert cc.fingerprint(lambda t, w=1.0: w * t) != cc.fingerprint(lambda t, w=2.0: w * t)
    assert cc.fingerprint(lambda t: jnp.sin(t)) != cc.fingerprint(lambda t: jnp.cos(t))


def test_unknown_module_is_a_miss_not_a_guess(cache):
    import types

    user = types.ModuleType("my_params")  # a user's module: its attributes may change at run time
    user.K = 3.0
    g = {"my_params": user}
    f = eval("lambda t: my_params.K * t", g)
    with pytest.raises(cc.Unkeyable):
        cc.fingerprint(f)
    twice = cc.cached_jit(lambda x: f(x))
    unkeyed = cc.stats["unkeyed"]
    assert float(twice(jnp.asarray(2.0))) == 6.0
    assert cc.stats["unkeyed"] == unkeyed + 1  # ran as a plain jit
    user.K = 4.0
    assert float(cc.cached_jit(lambda x: f(x))(jnp.asarray(2.0))) == 8.0


def scaled(x, k):
    return jnp.sin(x) * k


def test_corrupted_entry_is_ignored_with_a_warning(cache):
    x = jnp.linspace(0.0, 1.0, 5)
    f = cc.cached_jit(scaled, static_argnums=(1,))
    ref = np.sin(np.asarray(x)) * 3.0
    np.testing.assert_allclose(f(x, 3.0), ref, rtol=RTOL)
    files = list(cache.glob("*.entry"))
    assert len(files) == 1
    files[0].write_bytes(b"not a pickle")
    g = cc.cached_jit(scaled, static_argnums=(1,))  # a new process's wrapper (empty memory)
    with pytest.warns(pl.ProlegWarning, match="deleted the damaged entry"):
        np.testing.assert_allclose(g(x, 3.0), ref, rtol=RTOL)
    h = cc.cached_jit(scaled, static_argnums=(1,))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        np.testing.assert_allclose(h(x, 3.0), ref, rtol=RTOL)  # rewritten, read back
    np.testing.assert_allclose(h(x, 2.0), np.sin(np.asarray(x)) * 2.0, rtol=RTOL)  # a static argument is in the key


def test_empty_cache_dir_disables_it(tmp_path, monkeypatch):
    monkeypatch.setenv("PROLEG_CACHE_DIR", "")
    before = dict(cc.stats)
    f = cc.cached_jit(scaled, static_argnums=(1,))
    np.testing.assert_allclose(f(jnp.ones(3), 2.0), 2.0 * np.sin(1.0), rtol=RTOL)
    assert {k: cc.stats[k] for k in ("exported", "loaded")} == {k: before[k] for k in ("exported", "loaded")}


def test_transformations_bypass_the_cache(cache):
    f = cc.cached_jit(scaled, static_argnums=(1,))
    g = jax.grad(lambda x: f(x, 2.0).sum())(jnp.ones(3))
    np.testing.assert_allclose(g, 2.0 * np.cos(1.0), rtol=RTOL)
    v = jax.vmap(lambda x: f(x, 2.0))(jnp.ones((4, 3)))
    np.testing.assert_allclose(v, 2.0 * np.sin(1.0), rtol=RTOL)


def test_clear_drops_executables_and_reloads_from_disk(cache):
    f = cc.cached_jit(scaled, static_argnums=(1,))
    x = jnp.arange(3.0)
    a = f(x, 5.0)
    loaded = cc.stats["loaded"]
    cc.clear()
    assert not f._memo
    np.testing.assert_array_equal(f(x, 5.0), a)
    assert cc.stats["loaded"] == loaded + 1


def test_xla_options_reach_the_top_level_compile_and_not_nested_ones(tmp_path, monkeypatch):
    """XLA refuses ``compiler_options`` on a nested jit, so they go to the compile proleg makes
    for concrete arguments only. An invalid option proves which compiles receive them."""
    monkeypatch.setenv("PROLEG_CACHE_DIR", "")
    f = cc.jit(scaled, static_argnums=(1,))
    assert f.options == cc.XLA_OPTIONS["once"]
    x = jnp.linspace(0.0, 1.0, 4)
    np.testing.assert_allclose(f(x, 2.0), 2.0 * np.sin(np.asarray(x)), rtol=RTOL)
    f.options = {"xla_backend_optimization_level": "not-a-number"}  # a flag XLA 0.10 and 0.11 both know
    f._memo.clear()
    with pytest.raises(Exception, match="xla_backend_optimization_level"):
        f(x, 3.0)  # a top-level compile: the options reach XLA
    np.testing.assert_allclose(jax.jit(lambda y: f(y, 3.0))(x), 3.0 * np.sin(np.asarray(x)), rtol=RTOL)  # nested: plain jit
    np.testing.assert_allclose(jax.grad(lambda y: f(y, 3.0).sum())(x), 3.0 * np.cos(np.asarray(x)), rtol=RTOL)
    monkeypatch.setenv("PROLEG_XLA_OPTIONS", "default")
    assert cc.xla_options("loop") is None


def test_xla_options_do_not_change_the_solution(monkeypatch):
    """The compile-time options (fusion emitters off, LLVM level 0 for one-shot functions) change
    round-off only: a driven spin and a pendulum swing equal XLA's defaults to 1e-10."""
    import proleg.analyses.result as R
    import proleg.solvers.driver as D
    import proleg.solvers.initial as I

    monkeypatch.setenv("PROLEG_CACHE_DIR", "")
    m = pl.Model("swing", gravity=(0, 0, -9.81))
    arm = m.add_part("arm", 1.0, (0.01, 0.05, 0.05), (0.5, 0, 0))
    m.add_joint(pl.Revolute("pin", m.ground, arm, at=(0, 0, 0), axis=(0, 1, 0)))
    system = pl.assemble(m)

    def run():
        res = pl.simulate(system, t_end=0.5, dt_output=0.05, coordinates="absolute")
        return res.q[-1], res.joint("pin").force[-1]

    q_ours, f_ours = run()
    for fn in (D.advance_absolute, D._reduced_start, I._ic, R.post_batch):
        monkeypatch.setattr(fn, "options", None)
        monkeypatch.setattr(fn, "_memo", type(fn._memo)())
    q_xla, f_xla = run()
    np.testing.assert_allclose(q_ours, q_xla, rtol=0, atol=1e-10)
    np.testing.assert_allclose(f_ours, f_xla, rtol=1e-9, atol=1e-9)
    assert abs(q_ours[0] - 0.5) > 1e-3  # it swung: the comparison is of a moving state


@pytest.mark.default_device
@pytest.mark.skipif(not any(d.platform != "cpu" for d in jax.devices()), reason="needs a GPU (JAX sees only the CPU)")
def test_single_run_on_a_gpu_host(cache):
    """Where JAX's default device is a GPU, a single ``simulate`` runs on the host's CPU
    (analyses/placement.py) with proleg's CPU XLA options (less those that XLA refuses), from an
    empty and from a warm disk cache; the answer equals the GPU's (``device="default"``) to
    round-off. Run on an H100 host with JAX 0.11.2 on 25 Nov 2026."""
    system = spin(law_global)
    a = angle_at_end(system)
    loaded = cc.stats["loaded"]
    cc.clear()
    b = angle_at_end(system)  # from the disk cache
    assert cc.stats["loaded"] > loaded
    res = pl.simulate(system, t_end=T_END, dt_output=0.1, coordinates="absolute", device="default",
                      run=pl.RunOptions(prepare_outputs=False))
    np.testing.assert_allclose([a, b], RATE * T_END, rtol=1e-12)
    np.testing.assert_allclose(float(res.joint("axle").angle[-1]), a, rtol=1e-12)


def test_an_option_this_xla_does_not_know_is_dropped_not_fatal(monkeypatch):
    """XLA retires flags (jaxlib 0.11 has no ``xla_cpu_use_fusion_emitters``, which broke every
    ``simulate`` on JAX 0.11.2): an unknown option is dropped and remembered, the compile
    retried; a known option with a bad value still raises."""
    monkeypatch.setenv("PROLEG_CACHE_DIR", "")
    monkeypatch.setattr(cc, "refused_options", set())
    f = cc.jit(scaled, static_argnums=(1,))
    x = np.linspace(0.0, 1.0, 4)
    f.options = {"xla_backend_optimization_level": 0, "xla_no_such_flag_for_proleg": True}
    np.testing.assert_allclose(f(x, 2.0), 2.0 * np.sin(x), rtol=RTOL)
    assert cc.refused_options == {"xla_no_such_flag_for_proleg"}
    f.options = {"xla_backend_optimization_level": "not-a-number"}
    f._memo.clear()
    with pytest.raises(Exception, match="xla_backend_optimization_level"):
        f(x, 3.0)


_TRAIL_CHILD = r"""
import json, sys, warnings
import numpy as np
import proleg as pl
import proleg.compile_cache as cc
m = pl.Model("swing", gravity=(0, 0, -9.81))
arm = m.add_part("arm", 1.0, (0.01, 0.05, 0.05), (0.5, 0, 0))
m.add_joint(pl.Revolute("pin", m.ground, arm, at=(0, 0, 0), axis=(0, 1, 0)))
with warnings.catch_warnings(record=True) as w:
    warnings.simplefilter("always")
    res = pl.simulate(pl.assemble(m), t_end=0.3, dt_output=0.01, progress=False, integrator=pl.GeneralizedAlpha())  # trails: the alpha loop
print(json.dumps(dict(q=res.q[-1].tolist(), stats={k: v for k, v in cc.stats.items() if isinstance(v, int)},
                      warned=[str(x.message)[:60] for x in w if "damaged" in str(x.message)])))
"""


def test_trail_prefetches_the_step_loop_in_the_next_process(tmp_path):
    """The first process records the executables simulate loaded (trail/*.entry); the
    second loads the step loop in a background thread from the start (stats "prefetched") and
    gets the same answer bit for bit; a damaged trail file is reported, ignored and rewritten."""
    import json
    import os
    import subprocess
    import sys

    def run():
        out = subprocess.run([sys.executable, "-c", _TRAIL_CHILD], capture_output=True, text=True, timeout=300,
                             env={**os.environ, "PROLEG_CACHE_DIR": str(tmp_path)})
        assert out.returncode == 0, out.stderr[-3000:]
        return json.loads(out.stdout.strip().splitlines()[-1])

    first = run()
    trails = list((tmp_path / "trail").glob("*.entry"))
    assert len(trails) == 1 and first["stats"]["prefetched"] == 0 and first["stats"]["exported"] >= 3
    second = run()
    assert second["stats"]["prefetched"] == 1 and second["stats"]["exported"] == 0
    assert second["q"] == first["q"]
    trails[0].write_bytes(b"not a pickle")
    third = run()
    assert third["warned"] and third["stats"]["prefetched"] == 0 and third["q"] == first["q"]
    assert run()["stats"]["prefetched"] == 1  # rewritten by the third


def swing():
    """A double pendulum (a smooth tree: ``integrator="auto"`` runs Tsit5 on joint coordinates)."""
    model = pl.Model("swing", gravity=(0, 0, -9.81))
    a = model.add_part("a", 1.0, (0.01, 0.08, 0.08), (0.5, 0, 0))
    b = model.add_part("b", 1.0, (0.01, 0.08, 0.08), (1.5, 0, 0))
    model.add_joint(pl.Revolute("pa", a, model.ground, at=(0, 0, 0), axis=(0, 1, 0)))
    model.add_joint(pl.Revolute("pb", b, a, at=(1, 0, 0), axis=(0, 1, 0)))
    return pl.assemble(model)


@pytest.mark.parametrize("integrator", ["auto", "radau5"])
def test_the_ode_and_radau_loops_are_kept_on_disk(cache, integrator):
    """A new process must not trace the integration loop again (seconds of every warm start,
    issue 29): Diffrax's loop once held equinox's host-callback checks of its output times, which
    neither jax.export nor XLA's persistent cache can keep, so it was traced and compiled anew in
    every process. Here the loop is written to disk, then, with the in-process executables
    dropped (as in a new process), loaded from it and not exported again; equinox's own error
    mode is left as it was."""
    import equinox._errors as eqx_errors

    mode = eqx_errors.EQX_ON_ERROR
    system = swing()
    kw = {} if integrator == "auto" else dict(integrator=pl.Radau5(rtol=1e-6))
    first = pl.simulate(system, t_end=0.2, dt_output=0.05, progress=False, **kw)
    loop = "_run_free" if integrator == "auto" else "_run"
    assert any(p.name.startswith(loop + "-") for p in cache.iterdir()), sorted(p.name for p in cache.iterdir())
    cc.clear()
    exported, loaded = cc.stats["exported"], cc.stats["loaded"]
    again = pl.simulate(system, t_end=0.2, dt_output=0.05, progress=False, **kw)
    assert cc.stats["exported"] == exported and cc.stats["loaded"] > loaded
    np.testing.assert_array_equal(np.asarray(again.q), np.asarray(first.q))
    assert eqx_errors.EQX_ON_ERROR == mode
