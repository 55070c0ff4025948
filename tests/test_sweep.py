"""``proleg.sweep``: variants in one vmapped batch equal one-at-a-time simulations; a failing
variant is reported without spoiling the others; bad sweep input is refused up front.

Model: double pendulum (1 m, 1 kg links about y) with a tip spring to a ground anchor
(the README example); one compilation of the batch for the module.
"""

import dataclasses

import numpy as np
import pytest

import proleg as pl
from proleg.analyses import sweep as sweep_mod
from proleg.errors import Status
from models import spring_pendulum


@pytest.fixture(scope="module")
def system():
    return spring_pendulum("sweep_pendulum")


KW = dict(t_end=0.2, dt_output=0.01, integrator=pl.GeneralizedAlpha(dt_min=1e-5))
# The third variant: 1e9 N/m pre-stretched by 2 cm rings at ~5e3 Hz, which the error control
# cannot follow above dt_min = 1e-5 s, so it stops at its first steps.
VALUES = {"spring.stiffness": [20.0, 200.0, 1e9], "spring.free_length": [1.0, 0.98, 0.98]}


@pytest.fixture(scope="module")
def swept(system):
    # Two workers: batches of 2 and 1 (padded) run at the same time in two threads, their
    # Newton matrices factored lane by lane (the concurrent path of sweep; allowed here even on
    # 2 cores: this model has no other batched LAPACK call, see max_concurrent_batches).
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(sweep_mod, "max_concurrent_batches", lambda backend=None: 2)
        return pl.sweep(system, VALUES, workers=2, **KW)


def test_each_variant_equals_its_own_simulation(system, swept):
    assert len(swept) == 3
    for i in range(2):
        ref = pl.simulate(system.with_params({k: v[i] for k, v in VALUES.items()}), progress=False, **KW)
        r = swept[i]
        assert r.ok and swept.status[i] == Status.SUCCESS
        np.testing.assert_allclose(r.t, ref.t)
        np.testing.assert_allclose(np.asarray(r.q), np.asarray(ref.q), rtol=0, atol=1e-10)
        np.testing.assert_allclose(r.part("lower").position, ref.part("lower").position, rtol=0, atol=1e-10)
        assert {k: int(v[i]) for k, v in swept.stats.items()} == {k: ref.stats[k] for k in swept.stats}
        assert r.system.get("spring.stiffness") == pytest.approx(VALUES["spring.stiffness"][i])


def test_a_failing_variant_is_reported_and_cut_at_its_failure(swept):
    assert swept.status[2] == Status.STEP_TOO_SMALL
    assert list(swept.ok) == [True, True, False]
    assert np.isnan(swept.fail_time[:2]).all() and 0 < swept.fail_time[2] < 1e-3
    r = swept[2]
    assert not r.ok and "variant 2" in r.message
    assert r.t[-1] <= swept.fail_time[2]


def test_frame_has_variant_and_swept_columns(swept):
    f = swept.to_frame()
    assert list(f.columns[:3]) == ["variant", "spring.stiffness", "spring.free_length"]
    assert f["variant"].nunique() == 3
    rows = f[f["variant"] == 1]
    assert (rows["spring.stiffness"] == 200.0).all()
    np.testing.assert_allclose(rows["lower.x [m]"].to_numpy(), swept[1].part("lower").position[:, 0])


def test_bad_sweep_input_is_refused(system):
    with pytest.raises(pl.ModelError, match="spring.free_length.*2 values.*3"):
        pl.sweep(system, {"spring.stiffness": [1.0, 2.0, 3.0], "spring.free_length": [1.0, 2.0]}, **KW)
    with pytest.raises(pl.ModelError, match="spring.stiffness.*NaN"):
        pl.sweep(system, {"spring.stiffness": [1.0, np.nan]}, **KW)
    with pytest.raises(pl.ModelError, match="no parameters"):
        pl.sweep(system, {}, **KW)
    with pytest.raises(Exception, match="nosuch"):
        pl.sweep(system, {"nosuch.stiffness": [1.0]}, **KW)
    with pytest.raises(ValueError, match="workers"):
        pl.sweep(system, {"spring.stiffness": [1.0]}, workers=0, **KW)
    with pytest.raises(TypeError, match="progress"):
        pl.sweep(system, {"spring.stiffness": [1.0]}, progress=True, **KW)


# Issue 42 item 5: no integrator named. 0.5 s of the spring pendulum (about a quarter swing).
AUTO_KW = dict(t_end=0.5, dt_output=0.01)


def test_no_integrator_named_gives_simulates_answer(system):
    """With no integrator named a sweep makes ``simulate``'s own choice (``Auto.choose``: Tsit5
    on joint coordinates for this smooth loop-free tree), so each row is
    ``simulate(system.with_params(row))``: the same method, steps and tolerances. Sweeps ran
    generalized-α before, and the README pendulum's rows were 4.6e-4 m off simulate's
    (issue 42)."""
    values = {"spring.stiffness": [20.0, 60.0, 100.0], "spring.damping": [0.1, 0.5, 1.0]}
    res = pl.sweep(system, values, **AUTO_KW)
    assert type(res.integrator).__name__ == "Tsit5" and "loop-free tree" in res.integrator_reason
    assert res.integrator_note is None
    for i in range(3):
        ref = pl.simulate(system.with_params({k: v[i] for k, v in values.items()}), progress=False, **AUTO_KW)
        assert ref.stats["integrator"] == res.integrator.describe() == res[i].stats["integrator"]
        assert res[i].stats["integrator_reason"] == ref.stats["integrator_reason"]
        assert int(res.stats["steps"][i]) == ref.stats["steps"]
        # round-off only (issue 42's target, 1e-9 relative; measured 1e-13): the batch's arithmetic
        # is the single run's, vectorised, so its adaptive steps are the same steps
        np.testing.assert_allclose(np.asarray(res[i].q), np.asarray(ref.q), rtol=0, atol=1e-9 * float(np.abs(np.asarray(ref.q)).max()))


@dataclasses.dataclass(frozen=True)
class Unbatchable(pl.Tsit5):
    """A method that declares it cannot run under ``jax.vmap`` (``batches = False``)."""

    batches = False


def test_a_method_that_cannot_batch_is_replaced_loudly(system):
    """A batch that must run another method than ``simulate`` would says so: a warning, and
    the note the sweep (and a study's rows) carry. The replacement keeps the tolerances asked for."""
    from proleg.analyses.sweep import batch_integrator

    with pytest.warns(pl.ProlegWarning, match="Unbatchable .*cannot run variants in a vmap batch.*GeneralizedAlpha"):
        ig, why, note = batch_integrator(system, 0.5, 0.01, {"integrator": Unbatchable(rtol=1e-7, atol=1e-8)})
    assert type(ig).__name__ == "GeneralizedAlpha" and (ig.rtol, ig.atol) == (1e-7, 1e-8)
    assert why == "named by the caller" and "differ from simulate()" in note
    # what simulate chooses for a run is what a batch of it gets: the chooser sees the run's
    # length (t0 to the last output time), as simulate measures it
    for kw, span in ((dict(), 0.5), (dict(t0=0.1), 0.4), (dict(output_times=[0.2, 0.3]), 0.1)):
        ig, why, note = batch_integrator(system, 0.5, None, kw)
        assert type(ig).__name__ == "Tsit5" and note is None
        assert sweep_mod._run_span(0.5, None, kw) == pytest.approx(span)


def test_lane_by_lane_lu_equals_the_batched_lu():
    """``StepOptions.lu_per_lane``: the same LAPACK factors, one call per lane under vmap."""
    import jax
    import jax.numpy as jnp

    from proleg.solvers.galpha import lu_apply, lu_factors, lu_factors_per_lane

    J = jnp.asarray(np.random.default_rng(1).normal(size=(5, 7, 7)))
    b = jnp.asarray(np.random.default_rng(2).normal(size=(5, 7)))
    lu1, p1 = jax.vmap(lu_factors)(J)
    lu2, p2 = jax.jit(jax.vmap(lu_factors_per_lane))(J)
    # bitwise: both paths call the same LAPACK getrf on the same 7 × 7 matrices in this process;
    # that the per-lane path leaves the factors untouched is what is tested
    np.testing.assert_array_equal(lu1, lu2)
    np.testing.assert_array_equal(p1, p2)
    x = jax.vmap(lu_apply)((lu2, p2), b)
    # backward-stable solve: residual ≤ 64 eps n ‖J‖ ‖x‖ per lane (random J, so ‖x‖ varies)
    scale = np.max(np.linalg.norm(np.asarray(J), 2, axis=(1, 2)) * np.linalg.norm(np.asarray(x), axis=1))
    np.testing.assert_allclose(jnp.einsum("bij,bj->bi", J, x), b, atol=64 * np.finfo(float).eps * 7 * scale)
    lu3, _ = lu_factors_per_lane(J[0])  # unbatched: the plain factors (bitwise, as above)
    np.testing.assert_array_equal(lu3, lu1[0])


def test_gpu_lowering_factors_square_matrices():
    """On the GPU the batched LU must stay square: jaxlib batches square matrices only (cuBLAS
    getrfBatched), and the CPU's augmented form (row numbers as an extra column) ran one
    cuSOLVER call per lane, 37 ms per step for 1,000 lanes on an H100 (bench/README.md). Both
    forms give the same factors and permutation."""
    import jax
    import jax.numpy as jnp

    from proleg.solvers.galpha import _lu_factors_augmented, _lu_factors_square, lu_factors

    J = jnp.asarray(np.random.default_rng(3).normal(size=(8, 5, 5)))
    for a, b in zip(jax.vmap(_lu_factors_augmented)(J), jax.vmap(_lu_factors_square)(J)):
        # two getrf calls on differently shaped operands may round apart: 64 eps n × max |factor|
        np.testing.assert_allclose(a, b, rtol=0, atol=64 * np.finfo(float).eps * 5 * float(np.max(np.abs(np.asarray(b)))))

    def getrf_operands(platform):
        try:
            text = jax.jit(jax.vmap(lu_factors)).trace(J).lower(lowering_platforms=(platform,)).as_text()
        except Exception as exc:  # a jax that cannot lower for a platform it lacks
            pytest.skip(f"cannot lower for {platform} here: {type(exc).__name__}")
        return [ln.split("(tensor<", 1)[1].split(">", 1)[0] for ln in text.splitlines() if "getrf" in ln and "custom_call" in ln]

    assert getrf_operands("cuda") == ["8x5x5xf64"]
    assert getrf_operands("cpu") == ["8x5x6xf64"]


def test_lane_by_lane_lu_is_for_the_cpu_only():
    """``lu_per_lane`` avoids an XLA-CPU deadlock; lowered for a GPU it stays one batched,
    square LU (a loop of single-matrix LU calls would be one cuSOLVER call per lane)."""
    import jax
    import jax.numpy as jnp

    from proleg.solvers.galpha import lu_factors_per_lane

    J = jnp.asarray(np.random.default_rng(4).normal(size=(8, 5, 5)))

    def lowered(platform):
        try:
            return jax.jit(jax.vmap(lu_factors_per_lane)).trace(J).lower(lowering_platforms=(platform,)).as_text()
        except Exception as exc:  # a jax that cannot lower for a platform it lacks
            pytest.skip(f"cannot lower for {platform} here: {type(exc).__name__}")

    gpu = [ln for ln in lowered("cuda").splitlines() if "getrf" in ln and "custom_call" in ln]
    assert len(gpu) == 1 and "tensor<8x5x5xf64>" in gpu[0]
    assert "stablehlo.while" in lowered("cpu")  # the lax.map over lanes


def test_a_single_run_is_placed_on_the_cpu(system, monkeypatch):
    """``simulate/solve_equilibrium/linearize(device=None)``: where JAX's default backend is a GPU, a single untraced run
    goes to the CPU (one variant is ~9× slower on an H100 than on its host's CPU); inside the
    user's jit/vmap JAX places it. Named devices work; unknown ones are refused clearly."""
    import jax

    from proleg.analyses.placement import run_device

    monkeypatch.setattr(jax, "default_backend", lambda: "gpu")
    assert run_device(None, traced=False).platform == "cpu"
    assert run_device(None, traced=True) is None
    assert run_device("default", traced=False) is None
    monkeypatch.undo()
    a = pl.simulate(system, **KW)
    b = pl.simulate(system, device="cpu", **KW)
    # bitwise: untraced simulations run on the CPU anyway, so the same executable runs twice
    np.testing.assert_array_equal(np.asarray(a.q), np.asarray(b.q))
    with pytest.raises(ValueError, match="device='nosuch'"):
        pl.simulate(system, device="nosuch", **KW)
    with pytest.raises(TypeError, match="device must be"):
        pl.simulate(system, device=3, **KW)
    # The static analyses take the same keyword.
    eq = pl.solve_equilibrium(system, device="cpu")
    np.testing.assert_allclose(eq.q, pl.solve_equilibrium(system).q, rtol=0, atol=1e-12)
    assert pl.linearize(system, eq, device="cpu").modes() is not None
    with pytest.raises(ValueError, match="solve_equilibrium: device='nosuch'"):
        pl.solve_equilibrium(system, device="nosuch")


def test_default_batch_sizes():
    """Variants per batch: split over the workers, capped per backend (256 on the CPU, where
    smaller batches run faster per lane; 25,000 on a GPU, which bounds a batch's memory)."""
    from proleg.analyses.sweep import default_batch_size

    assert default_batch_size(1000, 2, "cpu") == 256
    assert default_batch_size(300, 2, "cpu") == 150
    assert default_batch_size(3, 8, "cpu") == 1
    assert default_batch_size(1000, 1, "gpu") == 1000
    assert default_batch_size(100_000, 1, "gpu") == 25_000


def test_concurrent_batches_leave_one_core_free(monkeypatch):
    """At most cores − 1 batches run at once on the CPU (a batched LAPACK call needs a free
    thread of XLA's pool, max_concurrent_batches), 1 on an accelerator."""
    for cores, want in ((1, 1), (2, 1), (3, 2), (16, 15)):
        monkeypatch.setattr(sweep_mod, "default_workers", lambda c=cores: c)
        assert sweep_mod.max_concurrent_batches("cpu") == want
    assert sweep_mod.max_concurrent_batches("gpu") == 1


_HANG = """
from proleg.papers.hyq_study import bushing_study
tab = bushing_study(t_end=0.02).run(design={"pin_stiffness": [1e6, 1e7, 1e9, 1e10]}, workers=2, batch_size=2, progress=False)
assert (tab["status"] == "success").all(), tab
print("ok")
"""


@pytest.mark.slow
def test_two_batches_of_the_hyq_leg_do_not_hang():
    """Regression: two vmap batches of the HyQ 8-bushing leg with workers=2 hung on 2 cores
    (every thread on a futex, no CPU; gdb: both XLA pool threads in a batched LU's
    ParallelBatchMap waiting for lanes queued on the same pool). Run in a subprocess with a
    timeout so that a hang fails the test instead of the suite (~30 s of compilation)."""
    import os
    import subprocess
    import sys

    env = {**os.environ, "PYTHONPATH": os.pathsep.join(p for p in sys.path if p)}
    try:
        out = subprocess.run([sys.executable, "-c", _HANG], capture_output=True, text=True, timeout=420, env=env)
    except subprocess.TimeoutExpired:
        pytest.fail("two concurrent vmap batches of the HyQ leg did not finish in 420 s (the futex hang)")
    assert out.returncode == 0 and out.stdout.strip().endswith("ok"), out.stderr[-2000:]
