"""Newton-matrix reuse across steps (StepOptions.jacobian_reuse): same answers as a fresh matrix
per step within the integration tolerance, far fewer matrices, and batch-wide rebuild decisions
under jax.vmap (solvers/batching.any_lane)."""

import sys
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import proleg as pl
from proleg.solvers.batching import any_lane
from tolerances import CONSTRAINT_RESIDUAL

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "bench"))
from common import build_chain  # noqa: E402


def test_reuse_matches_fresh_matrices_with_fewer_builds():
    system = pl.assemble(build_chain(3, spring=60.0))
    kw = dict(t_end=1.0, dt_output=0.05, progress=False)
    fresh = pl.simulate(system, integrator=pl.GeneralizedAlpha(), **kw)
    reuse = pl.simulate(system, integrator=pl.GeneralizedAlpha(jacobian_reuse=True), **kw)
    # one matrix per attempt without reuse; a fraction of that with it
    assert fresh.stats["jacobians"] == fresh.stats["steps"] + fresh.stats["rejected"]
    assert reuse.stats["jacobians"] < 0.6 * (reuse.stats["steps"] + reuse.stats["rejected"])
    # both are error-controlled at rtol 1e-6: positions agree to a few tolerances (0.15 m rods)
    assert np.max(np.abs(np.asarray(reuse.q[:, :3]) - np.asarray(fresh.q[:, :3]))) < 1e-5
    # outputs between steps are projected onto the constraints with the step's (possibly
    # reused) Newton matrix (solvers/driver.py dense_output)
    assert np.max(reuse.constraint_residual()) < CONSTRAINT_RESIDUAL  # tests/tolerances.py: 50 phi_tol


def test_any_lane_is_identity_alone_and_or_over_a_batch():
    # exact comparisons: small binary fractions times 2 or 3, no rounding anywhere
    f = lambda x: jax.lax.cond(any_lane(x > 1.0), lambda: 2.0 * x, lambda: 3.0 * x)  # noqa: E731
    assert float(f(2.0)) == 4.0 and float(f(0.5)) == 1.5
    np.testing.assert_array_equal(jax.vmap(f)(jnp.array([0.0, 2.0])), [0.0, 4.0])  # one lane needs it: all take it
    np.testing.assert_array_equal(jax.vmap(f)(jnp.array([0.0, 0.5])), [0.0, 1.5])
    assert float(jax.jacfwd(f)(2.0)) == 2.0


@pytest.mark.slow  # ~25 s of compiling; any_lane's batch-wide OR is checked above in < 1 s
def test_reuse_under_vmap_equals_the_loop():
    system = pl.assemble(build_chain(2, spring=100.0))
    kw = dict(t_end=0.3, dt_output=0.1, progress=False, integrator=pl.GeneralizedAlpha(jacobian_reuse=True))
    ks = jnp.array([50.0, 400.0])

    def final(k):
        return pl.simulate(system.with_params({"spring.stiffness": k}), **kw).q[-1]

    batch = jax.vmap(final)(ks)
    for i, k in enumerate(ks):
        np.testing.assert_allclose(batch[i], final(k), atol=1e-6)
