"""Adams function library: values, continuity of derivatives, safe gradients, spline."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from proleg import fn

X0, H0, X1, H1 = 0.2, -1.0, 1.7, 3.0
EPS = np.finfo(float).eps
# Round-off of the blends (scale max |h| = 3): ~10 flops, maybe FMA-contracted or through XLA's
# own cos, each a few ulp; 64 eps × 3 = 4.3e-14, while a wrong coefficient is off by ≥ 1e-3.
TOL_H = 64 * EPS * max(abs(H0), abs(H1))


@pytest.mark.parametrize("f", [fn.step, fn.step5, fn.havsin])
def test_blend_end_values_and_midpoint(f):
    # value plateaus at both sides, exactly h0/h1 at the ends, mean at the midpoint (all three
    # blends are point-symmetric about the midpoint)
    xs = jnp.array([X0 - 1.0, X0, X1, X1 + 5.0])
    if f is fn.havsin:  # through cos(π), which a libm or XLA build may round 1 ulp off −1
        np.testing.assert_allclose(f(xs, X0, H0, X1, H1), [H0, H0, H1, H1], rtol=0, atol=TOL_H)
    else:  # exact: polynomials in Δ = 0 or 1 with small-integer coefficients, no rounding at all
        np.testing.assert_array_equal(f(xs, X0, H0, X1, H1), [H0, H0, H1, H1])
    assert float(f(0.5 * (X0 + X1), X0, H0, X1, H1)) == pytest.approx(0.5 * (H0 + H1), abs=TOL_H)


def test_step_cubic_formula_seed002_eq18():
    x = jnp.linspace(X0, X1, 11)
    d = (x - X0) / (X1 - X0)
    expected = H0 + (H1 - H0) * d**2 * (3 - 2 * d)  # Eq. 18 with the sign corrected (MODEL_DATA §3)
    np.testing.assert_allclose(fn.step(x, X0, H0, X1, H1), expected, atol=TOL_H)
    d5 = d**3 * (10 - 15 * d + 6 * d**2)
    np.testing.assert_allclose(fn.step5(x, X0, H0, X1, H1), H0 + (H1 - H0) * d5, atol=TOL_H)


_DERIVS = {}


def _derivs(f, x):
    """(f'(x), f''(x)) by jax.grad, jitted once per blend."""
    if f not in _DERIVS:
        g1 = jax.grad(lambda x: f(x, X0, H0, X1, H1))
        _DERIVS[f] = jax.jit(lambda x: (g1(x), jax.grad(g1)(x)))
    d1, d2 = _DERIVS[f](x)
    return float(d1), float(d2)


@pytest.mark.parametrize("f", [fn.step, fn.step5, fn.havsin])
def test_first_derivative_continuous_at_both_ends(f):
    h = 1e-7
    for xe in (X0, X1):
        for x in (xe - h, xe, xe + h):
            assert abs(_derivs(f, x)[0]) < 1e-5  # slope vanishes at the ends (|f'| ~ 6a h / L²)
    # and matches central differences inside
    x = 0.9
    fd = (f(x + 1e-6, X0, H0, X1, H1) - f(x - 1e-6, X0, H0, X1, H1)) / 2e-6
    assert _derivs(f, x)[0] == pytest.approx(float(fd), rel=1e-8)


def test_step5_second_derivative_continuous_step_not():
    h = 1e-6
    for xe in (X0, X1):
        for x in (xe - h, xe, xe + h):
            assert abs(_derivs(fn.step5, x)[1]) < 1e-3
    # STEP jumps in curvature by 6a/L² at x0 (this is why step5 exists)
    L, a = X1 - X0, H1 - H0
    assert _derivs(fn.step, X0 + h)[1] == pytest.approx(6 * a / L**2, rel=1e-4)
    assert _derivs(fn.step, X0 - h)[1] == 0.0


def test_sinusoid():
    t = jnp.array([0.0, 0.125, 0.25])
    # sin(π/2), sin(π) to a few ulp of the 3.0 scale (sin(π) is 1.2e-16, not 0)
    np.testing.assert_allclose(fn.sinusoid(t, 2.0, 2.0, 0.0, 1.0), [1.0, 3.0, 1.0], atol=64 * EPS * 3.0)


K, E, CMAX, D, XC = 1e5, 1.5, 40.0, 1e-3, 0.0


def test_impact_values():
    # zero outside contact, whatever the velocity
    assert float(fn.impact(0.01, -3.0, XC, K, E, CMAX, D)) == 0.0
    assert float(fn.impact(XC, -3.0, XC, K, E, CMAX, D)) == 0.0
    # deep penetration, full damping: k g^e − cmax ẋ (rel 1e-12 in this test: a non-integer power,
    # XLA's against libm's, a few ulp; no cancellation; a wrong term is off by ≥ 1e-3)
    g, v = 2e-3, -0.5
    assert float(fn.impact(XC - g, v, XC, K, E, CMAX, D)) == pytest.approx(K * g**E + CMAX * 0.5, rel=1e-12)
    # half the damping depth: STEP gives cmax/2
    g = 0.5e-3
    assert float(fn.impact(XC - g, v, XC, K, E, CMAX, D)) == pytest.approx(K * g**E + 0.5 * CMAX * 0.5, rel=1e-12)
    # rebound with big damping: clipped to 0 by default, negative when asked
    g, v = 2e-3, 10.0
    assert float(fn.impact(XC - g, v, XC, K, E, CMAX, D)) == 0.0
    raw = float(fn.impact(XC - g, v, XC, K, E, CMAX, D, clip_negative=False))
    assert raw == pytest.approx(K * g**E - CMAX * v, rel=1e-12) and raw < 0


def test_impact_gradient_finite_everywhere():
    f = lambda x, v: fn.impact(x, v, XC, K, E, CMAX, D)  # noqa: E731
    xs = jnp.array([-2e-3, -1e-3, -1e-9, 0.0, 1e-9, 1e-3])
    gx, gv = jax.jit(jax.vmap(jax.grad(f, argnums=(0, 1)), in_axes=(0, None)))(xs, -0.3)
    assert bool(jnp.all(jnp.isfinite(gx))) and bool(jnp.all(jnp.isfinite(gv)))
    # also w.r.t. the parameters, at the contact boundary
    gp = jax.jit(jax.grad(lambda k, e: fn.impact(0.0, -0.3, XC, k, e, CMAX, D), argnums=(0, 1)))(K, E)
    assert all(np.isfinite(float(g)) for g in gp)
    # analytic derivative in contact: ∂F/∂x = −k e g^(e−1) − (∂c/∂x) ẋ, at g > d: ∂c/∂x = 0
    g = 2e-3
    assert float(jax.jit(jax.grad(f))(XC - g, -0.3)) == pytest.approx(-K * E * g ** (E - 1), rel=1e-12)


def test_bistop():
    x1, x2 = -0.1, 0.2
    f = lambda x, v: fn.bistop(x, v, x1, x2, K, E, CMAX, D)  # noqa: E731
    assert float(f(0.0, 5.0)) == 0.0
    g = 3e-3
    assert float(f(x1 - g, -0.1)) == pytest.approx(K * g**E + CMAX * 0.1, rel=1e-12)  # as in test_impact_values
    assert float(f(x2 + g, 0.1)) == pytest.approx(-(K * g**E + CMAX * 0.1), rel=1e-12)
    for x in (x1, x2):
        assert np.isfinite(float(jax.grad(f)(x, 0.1)))


def test_smooth_sign_and_coulomb():
    v = jnp.array([-1.0, -0.01, 0.0, 0.01, 1.0])
    for kind in ("algebraic", "tanh", "step"):
        s = fn.smooth_sign(v, 0.01, kind)
        np.testing.assert_allclose(s, -s[::-1], atol=16 * EPS)  # odd, to round-off of |s| ≤ 1
        assert float(s[2]) == 0.0 and float(s[-1]) > 0.99
    np.testing.assert_allclose(fn.coulomb(jnp.array([-1.0, 1.0]), 5.5e-3, 1e-2, damping=0.1), [5.5e-3 + 0.1, -5.5e-3 - 0.1])


@jax.jit
def _spline_eval(s, x):
    return s(x), s(x, nu=1), s.derivative(2)(x), jax.vmap(jax.grad(s))(x)


def test_spline_interpolates_and_derivatives_match_scipy():
    from scipy.interpolate import CubicSpline

    t = np.linspace(0.0, 2.0, 9) ** 1.3
    y = np.sin(2 * t) + 0.1 * t
    for bc in ("not-a-knot", "natural"):
        s = fn.spline(t, y, bc_type=bc)
        ref = CubicSpline(t, y, bc_type=bc)
        xq = np.linspace(-0.1, t[-1] + 0.1, 101)
        # spline passed as a pytree argument: one compilation serves both boundary conditions
        val, d1, d2, g = _spline_eval(s, jnp.asarray(xq))
        # at the knots: y to round-off of the coefficient solve (a small, well-conditioned banded
        # system) and of the cubic's evaluation: 1000 eps × max |y| (2.2e-13 here)
        np.testing.assert_allclose(_spline_eval(s, jnp.asarray(t))[0], y, atol=1e3 * EPS * np.max(np.abs(y)))
        for nu, out in ((0, val), (1, d1), (2, d2)):
            np.testing.assert_allclose(out, ref(xq, nu), atol=1e-10)
        # jax.grad of the value equals the analytic first derivative (argument is traceable)
        np.testing.assert_allclose(g, ref(xq, 1), atol=1e-11)


def test_spline_c2_at_knots_and_extrapolation_modes():
    t = np.array([0.0, 0.3, 0.7, 1.0, 1.6])
    y = np.array([0.0, 1.0, 0.5, 0.8, -0.2])
    s = fn.spline(t, y, bc_type="natural")
    h = 1e-9
    left = _spline_eval(s, jnp.asarray(t[1:-1] - h))
    right = _spline_eval(s, jnp.asarray(t[1:-1] + h))
    for nu in (0, 1, 2):  # value, slope and curvature continuous across interior knots
        np.testing.assert_allclose(left[nu], right[nu], atol=1e-6)
    # natural end: s'' = 0 to round-off of the solve, 1000 eps × the curvature scale max |s''|
    curvature = np.max(np.abs(np.asarray(left[2])))
    assert float(_spline_eval(s, jnp.asarray([0.0]))[2][0]) == pytest.approx(0.0, abs=1e3 * EPS * curvature)
    lin = fn.spline(t, y, extrapolate="linear")
    slope = float(lin(t[-1], 1))
    assert float(lin(2.0)) == pytest.approx(y[-1] + slope * 0.4, rel=1e-12)
    hold = fn.spline(t, y, extrapolate="hold")
    assert float(hold(-1.0)) == y[0] and float(hold(5.0, 1)) == 0.0
    # vector-valued table and pytree passing into jit
    s2 = fn.spline(t, np.stack([y, 2 * y], axis=1))
    out = jax.jit(lambda sp, x: sp(x))(s2, 0.5)
    # two right-hand sides of one solve: ×2 is exact, but a blocked kernel may round the columns
    # differently, so round-off of the solve, 1000 eps relative
    assert out.shape == (2,) and float(out[1]) == pytest.approx(2 * float(out[0]), rel=1e3 * EPS)


def test_spline_rejects_bad_tables():
    with pytest.raises(ValueError, match="strictly increasing"):
        fn.spline([0.0, 1.0, 1.0], [0.0, 1.0, 2.0])
    with pytest.raises(ValueError, match="first axis"):
        fn.spline([0.0, 1.0, 2.0], [0.0, 1.0])
