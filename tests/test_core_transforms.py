"""JAX transformations through a whole simulation: vmap over a parameter, forward-mode derivative.

Model: m = 1 kg on a prismatic joint along ground x, no gravity, a SpringDamper (stiffness k,
no damping) to a ground anchor 1 m away with free length 1 m, released from rest at
x0 = 0.1 m from the spring's unstretched position. Closed form:

    x(t) = x0 cos(ω t),  ω = sqrt(k/m),   ∂x(T)/∂k = −x0 sin(ω T) T / (2 m ω)
"""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import proleg as pl
from tolerances import CONSTRAINT_RESIDUAL

MASS, K0, X0, T_END, DT_OUT = 1.0, 100.0, 0.1, 1.0, 0.01
H_FIXED = 1e-3
KS = np.linspace(60.0, 200.0, 8)


@pytest.fixture(scope="module")
def system():
    model = pl.Model("oscillator", gravity=(0, 0, 0))
    box = model.add_part("mass", mass=MASS, inertia=(0.01, 0.02, 0.03), position=(X0, 0, 0))
    model.add_joint(pl.Prismatic("slide", box, model.ground, at=(X0, 0, 0), axis=(1, 0, 0)))
    anchor = model.add_marker(model.ground, "anchor", position=(-1.0, 0, 0))
    hook = model.add_marker(box, "hook", position=(X0, 0, 0))
    model.add_force(pl.SpringDamper("spring", hook, anchor, stiffness=K0, free_length=1.0))
    return pl.assemble(model)


def x_history(system, k, **kw):
    """x(t) of the mass at every output, for spring stiffness k (traceable in k)."""
    res = pl.simulate(system.with_params({"spring.stiffness": k}), t_end=T_END, dt_output=DT_OUT, **kw)
    return res.q[:, 0]


def test_with_params_changes_the_frequency(system):
    """Sanity of the parameter path: x(t) for k = 2 K0 follows x0 cos(sqrt(2 K0/m) t). At the default
    tolerances the GA phase error after 2.25 periods is 2e-4 m (0.2 % of x0); asserted at 5e-4 m,
    while k = K0 would be off by 3e-2 m."""
    res = pl.simulate(system.with_params({"spring.stiffness": 2 * K0}), t_end=T_END, dt_output=DT_OUT)
    x = res.part("mass").position[:, 0]
    np.testing.assert_allclose(x, X0 * np.cos(np.sqrt(2 * K0 / MASS) * res.t), atol=5e-4)
    assert np.max(res.constraint_residual()) < CONSTRAINT_RESIDUAL  # tests/tolerances.py: 50 phi_tol
    assert float(system.get("spring.stiffness")) == K0  # the original system is unchanged


def test_vmap_equals_loop(system):
    """jax.vmap over 8 stiffnesses gives the Python loop's trajectories to 1e-12 m (adaptive steps,
    default tolerances: each batch member keeps its own step-size sequence)."""
    batched = jax.vmap(lambda k: x_history(system, k))(jnp.asarray(KS))
    looped = np.stack([np.asarray(x_history(system, k)) for k in KS])
    assert batched.shape == looped.shape == (8, round(T_END / DT_OUT) + 1)
    np.testing.assert_allclose(np.asarray(batched), looped, rtol=0, atol=1e-12)
    # and the stiffness really changed the motion
    assert np.ptp(looped[:, -1]) > 0.05


def _x_final_fixed(system, k):
    return x_history(system, k, integrator=pl.GeneralizedAlpha(fixed_step=H_FIXED))[-1]


def test_jacfwd_matches_central_differences(system):
    """∂x(T)/∂k by jax.jacfwd through the fixed-step simulation (h = 1e-3) equals central finite
    differences of the same discrete map (δk = 1e-4 k; truncation O(δk²) ≈ 1e-10 relative) to
    1e-5 relative, and the closed form to the discretisation error (1e-3 relative)."""
    dk = 1e-4 * K0
    d_ad = float(jax.jacfwd(lambda k: _x_final_fixed(system, k))(jnp.asarray(K0)))
    xp = float(_x_final_fixed(system, K0 + dk))
    xm = float(_x_final_fixed(system, K0 - dk))
    d_fd = (xp - xm) / (2 * dk)
    assert d_ad == pytest.approx(d_fd, rel=1e-5)
    w = np.sqrt(K0 / MASS)
    d_exact = -X0 * np.sin(w * T_END) * T_END / (2 * MASS * w)
    assert d_ad == pytest.approx(d_exact, rel=1e-3)


@pytest.mark.slow
def test_jacfwd_adaptive(system):
    """With error control the step sizes are not differentiated (stop_gradient in the driver), so
    jacfwd gives the derivative of the discrete map along a frozen step sequence. Measured at the
    default tolerances: jacfwd / closed form − 1 = −2.4e-3 (the integration error; −1.6e-4 at
    rtol = 1e-8), and jacfwd vs central differences of adaptive runs (δk = 1e-4 k) 4e-5 relative
    (the step sequence changes with k, so differences are noisy at the tolerance level: at
    δk = 1e-3 k they were off by 1e-3)."""
    f = lambda k: x_history(system, k)[-1]  # noqa: E731
    d_ad = float(jax.jacfwd(f)(jnp.asarray(K0)))
    w = np.sqrt(K0 / MASS)
    d_exact = -X0 * np.sin(w * T_END) * T_END / (2 * MASS * w)
    assert d_ad == pytest.approx(d_exact, rel=1e-2)
    dk = 1e-4 * K0
    d_fd = (float(f(K0 + dk)) - float(f(K0 - dk))) / (2 * dk)
    assert d_ad == pytest.approx(d_fd, rel=1e-3)


def test_quaternion_of_a_matrix_matches_scipy():
    """spatial.rotation.p_from_matrix is SciPy's Rotation.from_matrix in NumPy (scipy.spatial is
    not imported by assemble): the same quaternion to round-off, e0 ≥ 0, for random rotations, the
    180° turns (pivot on the diagonal) and slightly non-orthogonal matrices (SVD projection).

    Round-off: 16 eps (3.6e-15) on unit quaternions. The map is well conditioned, but SciPy's
    compiled code may contract FMAs (GCC does on ARM) and its SVD is another LAPACK build's, so
    1 ulp here is 1 to 3 on another machine; a wrong pivot fails the 180° turns by O(1)."""
    from scipy.spatial.transform import Rotation

    from proleg.spatial.rotation import A_of_p, p_from_matrix

    rng = np.random.default_rng(3)
    mats = [Rotation.random(random_state=k).as_matrix() for k in range(200)]
    mats += [np.eye(3), np.diag([1.0, -1, -1]), np.diag([-1.0, 1, -1]), np.diag([-1.0, -1, 1])]
    mats += [m + 1e-9 * rng.standard_normal((3, 3)) for m in mats[:20]]
    for m in mats:
        x, y, z, w = Rotation.from_matrix(m).as_quat()
        ref = np.array([w, x, y, z]) * (1 if w >= 0 else -1)
        p = p_from_matrix(m)
        np.testing.assert_allclose(p, ref, rtol=0, atol=16 * np.finfo(float).eps)
        assert p[0] >= 0
        np.testing.assert_allclose(A_of_p(p), m, atol=1e-8)  # A(p) is the matrix (to its non-orthogonality)
    with pytest.raises(ValueError, match="determinant"):
        p_from_matrix(np.diag([1.0, 1.0, -1.0]))
