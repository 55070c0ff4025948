"""Contact force laws: IMPACT normal force, Adams friction, Hertz closed forms vs an ODE."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from proleg import contact_law as cl

MUS, MUD, VS, VD = 0.8, 0.6, 0.01, 0.03
# Round-off allowance for μ (scale μ_s = 0.8): STEP is a cubic of ~8 flops, each rounding or
# FMA-contracted differently by another CPU/XLA build, so a few ulp; 64 eps × μ_s = 1.1e-14
# leaves margin, while a wrong branch or coefficient is off by ≥ 1e-3.
TOL_MU = 64 * np.finfo(float).eps * MUS


def test_friction_coefficient_values():
    mu = lambda v: float(cl.friction_coefficient(v, MUS, MUD, VS, VD))  # noqa: E731
    assert mu(0.0) == 0.0
    assert mu(VS) == pytest.approx(MUS, abs=TOL_MU)
    assert mu(VD) == pytest.approx(MUD, abs=TOL_MU)
    assert mu(10 * VD) == pytest.approx(MUD, abs=TOL_MU)
    assert mu(0.5 * (VS + VD)) == pytest.approx(0.5 * (MUS + MUD), abs=TOL_MU)  # STEP midpoint
    # below v_s: STEP(v, −v_s, −μ_s, v_s, μ_s), slope 1.5 μ_s / v_s at 0
    assert mu(0.5 * VS) == pytest.approx(-MUS + 2 * MUS * 0.75**2 * (3 - 1.5), abs=TOL_MU)
    slope = jax.grad(cl.friction_coefficient)(0.0, MUS, MUD, VS, VD)
    assert float(slope) == pytest.approx(1.5 * MUS / VS, rel=1e-12)


def test_friction_coefficient_is_odd_and_c1():
    v = jnp.linspace(-0.1, 0.1, 401)
    f = jax.jit(jax.vmap(lambda v: cl.friction_coefficient(v, MUS, MUD, VS, VD)))
    np.testing.assert_allclose(f(v), -f(-v), atol=TOL_MU)  # odd to round-off (the two branches round apart)
    df = jax.jit(jax.vmap(jax.grad(lambda v: cl.friction_coefficient(v, MUS, MUD, VS, VD))))
    for vk in (VS, VD, -VS):
        a, b = df(jnp.array([vk - 1e-9, vk + 1e-9]))
        assert abs(float(a) - float(b)) < 1e-4


def test_friction_vector():
    fv = jax.jit(lambda v: cl.friction_vector(v, MUS, MUD, VS, VD))
    v = jnp.array([[0.3, -0.4, 0.0], [0.0, 0.0, 0.0], [0.004, 0.003, 0.0]])
    out = fv(v)
    np.testing.assert_allclose(out[0], MUD * v[0] / 0.5, atol=TOL_MU)
    np.testing.assert_array_equal(out[1], 0.0)  # exact: zero slip times a finite factor is 0.0 in any order
    np.testing.assert_allclose(jnp.linalg.norm(out[2]), float(cl.friction_coefficient(0.005, MUS, MUD, VS, VD)), atol=TOL_MU)
    # Jacobian at zero slip is finite: isotropic viscous-like stiction 1.5 μ_s / v_s (= 120 s/m;
    # a derivative of the cubic, round-off 64 eps relative to that scale)
    jac = jax.jit(jax.jacfwd(lambda v: cl.friction_vector(v, MUS, MUD, VS, VD)))(jnp.zeros(3))
    np.testing.assert_allclose(jac, 1.5 * MUS / VS * jnp.eye(3), atol=64 * np.finfo(float).eps * 1.5 * MUS / VS)
    g = jax.grad(lambda v: jnp.sum(cl.friction_vector(v, MUS, MUD, VS, VD)))(jnp.zeros(2))
    assert bool(jnp.all(jnp.isfinite(g)))


def test_normal_force():
    k, e, c, dmax = 1e6, 1.5, 500.0, 1e-4
    nf = lambda g, gd: float(cl.normal_force(g, gd, k, e, c, dmax))  # noqa: E731
    assert nf(-1e-3, 1.0) == 0.0 and nf(0.0, 1.0) == 0.0
    # rel 1e-12: a non-integer power (XLA's pow vs libm's, a few ulp) plus a sum of positive terms;
    # a wrong exponent or damping ramp is off by ≥ 1e-2
    assert nf(2e-4, 0.1) == pytest.approx(k * (2e-4) ** 1.5 + c * 0.1, rel=1e-12)
    assert nf(5e-5, 0.1) == pytest.approx(k * (5e-5) ** 1.5 + 0.5 * c * 0.1, rel=1e-12)
    assert nf(2e-4, -100.0) == 0.0  # no pulling on rebound
    g = jax.grad(cl.normal_force, argnums=(0, 1))(0.0, 1.0, k, e, c, dmax)
    assert all(np.isfinite(float(x)) for x in g)


def test_hertz_duration_constant():
    # C(1.5) = 2 ∫0^1 (1 − u^2.5)^(−1/2) du, by quadrature; the classic Hertz 2.94
    from scipy.integrate import quad
    from scipy.special import beta

    q = 2 * quad(lambda u: (1 - u**2.5) ** -0.5, 0, 1, limit=200)[0]
    assert float(cl.hertz_duration_constant(1.5)) == pytest.approx(q, rel=1e-8)
    assert float(cl.hertz_duration_constant(1.5)) == pytest.approx(2.9432, abs=1e-4)
    assert float(cl.hertz_duration_constant(1.5)) == pytest.approx(2 / 2.5 * beta(0.4, 0.5), rel=1e-12)
    # linear spring: half a period, T = π sqrt(m/k) = π δmax / v0
    assert float(cl.hertz_duration_constant(1.0)) == pytest.approx(np.pi, rel=1e-12)


def test_hertz_impact_against_ode():
    m, v0, k = 0.5, 1.2, 2e7  # a 0.5 kg sphere at 1.2 m/s, steel-on-steel order stiffness
    resp = cl.impact_response(m, v0, k, 1.5)

    def rhs(t, y):
        return [y[1], -k * max(y[0], 0.0) ** 1.5 / m]

    leave = lambda t, y: y[0]  # noqa: E731
    leave.terminal, leave.direction = True, -1
    sol = solve_ivp(rhs, (0.0, 1.0), [0.0, v0], events=leave, rtol=1e-10, atol=1e-14, dense_output=True)
    t_end = sol.t_events[0][0]
    tt = np.linspace(0.0, t_end, 4001)
    dmax_ode = sol.sol(tt)[0].max()
    assert float(resp.duration) == pytest.approx(t_end, rel=5e-3)
    assert float(resp.max_penetration) == pytest.approx(dmax_ode, rel=5e-3)
    assert float(resp.peak_force) == pytest.approx(k * dmax_ode**1.5, rel=5e-3)
    # closed form in the data: T = 3.2181 (m²/(k² v0))^(1/5) = 2.9432 · (5/4)^(2/5) (...)
    assert float(resp.duration) == pytest.approx(3.2181 * (m**2 / (k**2 * v0)) ** 0.2, rel=1e-4)
    assert float(resp.peak_force) == pytest.approx(1.25**0.6 * (k**2 * m**3 * v0**6) ** 0.2, rel=1e-12)


def test_hertz_sphere_plane_stiffness():
    E, nu, R = 210e9, 0.3, 0.02
    k = float(cl.hertz_sphere_plane_stiffness(R, E, nu, E, nu))
    assert k == pytest.approx(4 / 3 * (E / (2 * (1 - nu**2))) * np.sqrt(R), rel=1e-12)  # ~8 flops and a sqrt, no cancellation
