"""Gradient-based identification through the simulator (issue: identification and validation).

A mass on a vertical prismatic joint hangs from a spring-damper and is released from a
stretched pose; its trajectory z(t) is the "measurement". The same fixed-step integrator is used
for data and fit, so the exact parameters are a zero-residual solution.
"""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import proleg as pl
from proleg.identify import fit

K_TRUE, C_TRUE = 800.0, 6.0
SIM = dict(integrator=pl.GeneralizedAlpha(fixed_step=2e-3))


@pytest.fixture(scope="module")
def drop():
    m = pl.Model("drop")
    b = m.add_part("mass", mass=2.0, inertia=(1e-3,) * 3, position=(0, 0, 0.1))
    m.add_joint(pl.Prismatic("slide", b, m.ground, at=(0, 0, 0.1), axis=(0, 0, 1)))
    top = m.add_marker(b, "top", (0, 0, 0.1))
    anchor = m.add_marker(m.ground, "anchor", (0, 0, 0.3))
    m.add_force(pl.SpringDamper("spring", top, anchor, stiffness=K_TRUE, damping=C_TRUE, free_length=0.2))
    system = pl.assemble(m)
    times = np.linspace(0.0, 0.8, 401)
    z = pl.simulate(system, t_end=0.8, output_times=times, progress=False, **SIM).part("mass").position[:, 2]
    return system, times, z


def test_fit_recovers_k_and_c_from_2x_off(drop):
    system, times, z = drop
    start = system.with_params({"spring.stiffness": 2 * K_TRUE, "spring.damping": 2 * C_TRUE})
    res = fit(start, ["spring.stiffness", "spring.damping"], times, {"mass.z": z}, simulate_kw=SIM)
    assert res.success
    np.testing.assert_allclose(res.values, [K_TRUE, C_TRUE], rtol=1e-2)
    assert res.values[0] == pytest.approx(K_TRUE, rel=1e-6)  # noise-free: far better than 1 %
    assert np.all(np.isfinite(res.stderr)) and res.correlation.shape == (2, 2)


def test_gradient_through_simulation_matches_finite_differences(drop):
    system, times, z = drop
    zj = jnp.asarray(z)

    def cost(logk):
        s = system.with_params({"spring.stiffness": jnp.exp(logk)})
        zz = pl.simulate(s, t_end=0.8, output_times=times, progress=False, **SIM).part("mass").position[:, 2]
        return jnp.sum((zz - zj) ** 2)

    x0 = jnp.log(1.3 * K_TRUE)
    g = jax.jacfwd(cost)(x0)
    h = 1e-5
    fd = (cost(x0 + h) - cost(x0 - h)) / (2 * h)
    assert float(g) == pytest.approx(float(fd), rel=1e-5)


def test_fit_rejects_bad_measurements(drop):
    system, times, z = drop
    bad = z.copy()
    bad[7] = np.nan
    with pytest.raises(pl.DataError, match="sample 8"):
        fit(system, ["spring.stiffness"], times, {"mass.z": bad}, simulate_kw=SIM)
    with pytest.raises(pl.DataError, match="shape"):
        fit(system, ["spring.stiffness"], times, {"mass.z": z[:-1]}, simulate_kw=SIM)
