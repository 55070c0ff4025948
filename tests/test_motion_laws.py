"""Motion laws whose knots are design variables (issue 30, proleg.model.laws).

- Values and derivatives against closed forms: a clamped spline through samples of
  y = 3u² − 2u³ (zero slope at both ends, so the spline reproduces it exactly), the STEP5
  quintic h0 + a Δ³(10 − 15Δ + 6Δ²) per segment, and the Fourier series' term-by-term
  derivatives; the nu = 1, 2 forms also against jax's derivative of the value.
- Through the simulation: a free rotor (inertia J) driven by each law needs the torque
  J θ̈(t), the law's closed-form second derivative. A knot change through ``with_params``
  reruns the compiled simulation with no backend compile (JAX's compile event counter, as in
  test_one_compile.py) and gives the new law's torque.
- Gradients: a pendulum under gravity driven by a feed-forward torque law; ∂θ(t_end)/∂knot by
  ``jax.jacfwd`` through the simulation against central differences (fixed steps, so the
  differences see no step-size change).
"""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import proleg as pl

J = 0.02  # rotor inertia about the pin [kg m²]


def test_spline_law_reproduces_a_cubic_with_zero_end_slopes():
    T = 0.4
    t = np.linspace(0.0, T, 5)
    y = lambda x: 3 * (x / T) ** 2 - 2 * (x / T) ** 3  # noqa: E731
    law = pl.SplineLaw("s", t, y(t))
    x = np.linspace(-0.1, T + 0.1, 37)
    p = law.variables
    u = np.clip(x / T, 0, 1)
    inside = (x >= 0) & (x <= T)
    # reproduced to round-off of the spline's coefficient solve (5 knots, well conditioned) and
    # of its evaluation: 1000 eps × the unit scale of y (2.2e-13); a wrong end condition is ≥ 1e-3
    np.testing.assert_allclose(law.at(x, p), 3 * u**2 - 2 * u**3, atol=1e3 * np.finfo(float).eps)
    np.testing.assert_allclose(law.at(x, p, 1), np.where(inside, (6 * u - 6 * u**2) / T, 0.0), atol=1e-12)
    np.testing.assert_allclose(law.at(x, p, 2), np.where(inside, (6 - 12 * u) / T**2, 0.0), atol=1e-10)
    # the derivative forms are jax's derivatives of the value, also at the first knot (no
    # half-derivative from a clip tie at t = t_0, where a simulation starts)
    for xi in (0.0, 0.05, 0.1, 0.33):
        assert float(jax.grad(lambda s: law.at(s, p))(xi)) == pytest.approx(float(law.at(xi, p, 1)), abs=1e-12)
        assert float(jax.grad(jax.grad(lambda s: law.at(s, p)))(xi)) == pytest.approx(float(law.at(xi, p, 2)), abs=1e-10)


def test_step5_chain_matches_the_quintic_blend_and_its_derivatives():
    times, vals = [0.1, 0.3, 0.45], [1.0, 3.0, 2.5]
    law = pl.Step5Chain("c", times, vals, vary_durations=True)
    assert list(law.variables) == ["c_y0", "c_y1", "c_y2", "c_d0", "c_d1"]
    p = law.variables
    x = np.linspace(0.0, 0.6, 61)
    ref, ref1, ref2 = np.full_like(x, 1.0), np.zeros_like(x), np.zeros_like(x)
    for (a0, a1), (h0, h1) in zip(zip(times[:-1], times[1:]), zip(vals[:-1], vals[1:])):
        h = a1 - a0
        d = np.clip((x - a0) / h, 0, 1)
        ref += (h1 - h0) * d**3 * (10 - 15 * d + 6 * d**2)
        ref1 += (h1 - h0) * 30 * d**2 * (1 - d) ** 2 / h
        ref2 += (h1 - h0) * 60 * d * (1 - d) * (1 - 2 * d) / h**2
    # quintics in XLA against NumPy, summed over segments: 256 eps × max |y| = 3 (1.7e-13)
    tol_y = 256 * np.finfo(float).eps * 3.0
    np.testing.assert_allclose(law.at(x, p), ref, atol=tol_y)
    np.testing.assert_allclose(law.at(x, p, 1), ref1, atol=1e-11)
    np.testing.assert_allclose(law.at(x, p, 2), ref2, atol=1e-9)
    # a longer second segment moves the last knot: y(t) reaches 2.5 at 0.3 + 0.3 s
    q = {**p, "c_d1": 0.3}
    assert float(law.at(0.6, q)) == pytest.approx(2.5, abs=tol_y)
    assert float(law.at(0.45, q)) == pytest.approx(3.0 - 0.5 * 0.5, abs=tol_y)  # the blend's midpoint
    # the derivative with respect to a duration, against central differences
    g = jax.grad(lambda d1: law.at(0.5, {**p, "c_d1": d1}))(0.3)
    fd = (law.at(0.5, {**p, "c_d1": 0.3 + 1e-6}) - law.at(0.5, {**p, "c_d1": 0.3 - 1e-6})) / 2e-6
    assert float(g) == pytest.approx(float(fd), rel=1e-7)


def test_fourier_law_and_its_derivatives():
    law = pl.FourierLaw("f", period=0.5, a0=0.2, a=[0.3, -0.1], b=[0.05, 0.4])
    p = law.variables
    w = 2 * np.pi / 0.5
    x = np.linspace(0, 1, 41)
    y = 0.2 + 0.3 * np.cos(w * x) - 0.1 * np.cos(2 * w * x) + 0.05 * np.sin(w * x) + 0.4 * np.sin(2 * w * x)
    y1 = -0.3 * w * np.sin(w * x) + 0.2 * w * np.sin(2 * w * x) + 0.05 * w * np.cos(w * x) + 0.8 * w * np.cos(2 * w * x)
    y2 = -0.3 * w**2 * np.cos(w * x) + 0.4 * w**2 * np.cos(2 * w * x) - 0.05 * w**2 * np.sin(w * x) - 1.6 * w**2 * np.sin(2 * w * x)
    # Round-off: the arguments k w x (up to 25 rad) may round 1 ulp apart between XLA and NumPy
    # (another association of k, w, x), and sin/cos pass that on times the amplitude; so
    # 64 eps × 25 × Σ |c_k| (k w)^n for the n-th derivative (3.0e-13, 6.1e-12, 1.3e-10).
    arg = 2 * w * x.max()
    amp = [sum(abs(c) * (k * w) ** n for k, c in ((1, 0.3), (2, 0.1), (1, 0.05), (2, 0.4))) for n in range(3)]
    tol = [64 * np.finfo(float).eps * arg * a for a in amp]
    np.testing.assert_allclose(law.at(x, p), y, atol=tol[0])
    np.testing.assert_allclose(law.at(x, p, 1), y1, atol=tol[1])
    np.testing.assert_allclose(law.at(x, p, 2), y2, atol=tol[2])


def test_law_errors_name_the_law():
    with pytest.raises(pl.ModelError, match="SplineLaw 'bad'.*increasing"):
        pl.SplineLaw("bad", [0.0, 0.2, 0.1], [0, 1, 2])
    with pytest.raises(pl.ModelError, match="Step5Chain 'c'.*2 values"):
        pl.Step5Chain("c", [0.0, 0.2, 0.3], [0, 1])
    with pytest.raises(pl.ModelError, match="FourierLaw 'f'.*harmonics"):
        pl.FourierLaw("f", 1.0, a=[1.0, 2.0], b=[1.0])
    law = pl.SplineLaw("s", [0.0, 1.0], [0.0, 1.0])
    with pytest.raises(pl.ModelError, match="'s_y5'"):
        law.space(0.0, 1.0, names=["s_y5"])
    with pytest.raises(pl.ModelError, match="give lo= and hi="):
        law.space()
    m = pl.Model("twice")
    m.add_law(law)
    with pytest.raises(pl.ModelError, match="twice"):
        m.add_law(pl.SplineLaw("s", [0.0, 1.0], [0.0, 1.0]))


def _rotors():
    """Three free rotors on pins along z, each driven by one law (no gravity about the axes)."""
    m = pl.Model("law_rotors", gravity=(0, 0, 0))
    laws = [pl.SplineLaw("sp", [0.0, 0.1, 0.2, 0.3], [0.0, 0.2, 0.5, 1.0]),
            pl.Step5Chain("st", [0.05, 0.2, 0.3], [0.0, 0.8, 0.5], vary_durations=True),
            pl.FourierLaw("fo", period=0.2, a0=-0.3, a=[0.3], b=[0.1])]  # θ(0) = 0: the modelled pose
    for k, law in enumerate(laws):
        r = m.add_part(f"r{k}", mass=1.0, inertia=(0.01, 0.01, J), position=(k, 0, 0))
        m.add_joint(pl.Revolute(f"pin{k}", m.ground, r, at=(k, 0, 0), axis=(0, 0, 1)))
        m.add_law(law)
        m.add_motion(pl.Motion(f"drive{k}", f"pin{k}", displacement=law, breakpoints=law.breakpoints))
    return pl.assemble(m), laws


@pytest.fixture(scope="module")
def rotors():
    return _rotors()


def _check_torques(res, laws, values):
    t = res.t
    for k, law in enumerate(laws):
        need = J * np.asarray(law.at(jnp.asarray(t), values, 2))
        # the motion's reaction is exact to the integrator's acceleration error; 1e-6 of the peak
        np.testing.assert_allclose(res.motion(f"drive{k}").effort, need, atol=1e-6 * np.abs(need).max() + 1e-9)
        # the joint follows the law (wrapped angle: each law stays inside ±π here)
        np.testing.assert_allclose(res.joint(f"pin{k}").angle, np.asarray(law.at(jnp.asarray(t), values)), atol=1e-9)


def test_motion_laws_drive_rotors_and_a_knot_change_does_not_recompile(rotors, jax_events):
    system, laws = rotors
    values = {k: v for law in laws for k, v in law.variables.items()}
    kw = dict(t_end=0.4, dt_output=0.01, integrator=pl.GeneralizedAlpha(rtol=1e-8, atol=1e-10))
    res = pl.simulate(system, **kw)
    if hasattr(res._compiled_post, "result"):
        res._compiled_post.result()
    _check_torques(res, laws, values)
    new = {"sp_y2": 0.8, "st_y1": -0.4, "st_d0": 0.1, "fo_b1": -0.2}
    with jax_events("/jax/core/compile/backend_compile_duration") as c:
        res2 = pl.simulate(system.with_params(new), **kw)
        res2.to_frame()
    assert c.names == []
    _check_torques(res2, laws, {**values, **new})
    assert not np.allclose(res2.motion("drive0").effort, res.motion("drive0").effort)


def _pendulum_with_torque_law():
    """A pendulum (m = 1 kg at 0.5 m) about y under gravity, with a feed-forward torque law."""
    m = pl.Model("law_pendulum", gravity=(0, 0, -9.81))
    bob = m.add_part("bob", mass=1.0, inertia=(1e-3, 1e-3, 1e-3), position=(0.5, 0, 0))
    m.add_joint(pl.Revolute("pin", m.ground, bob, at=(0, 0, 0), axis=(0, 1, 0)))
    law = m.add_law(pl.SplineLaw("tau", [0.0, 0.1, 0.2, 0.3], [0.0, -2.0, -3.0, 0.0], unit="N m"))
    m.add_actuator(pl.JointActuator("motor", "pin", effort=law))
    return pl.assemble(m), law


def test_gradient_through_the_simulation_matches_central_differences():
    system, law = _pendulum_with_torque_law()
    kw = dict(t_end=0.3, dt_output=0.01, integrator=pl.GeneralizedAlpha(fixed_step=1e-3))
    names = list(law.variables)
    p0 = np.array(list(law.variables.values()))

    def theta_end(p):
        r = pl.simulate(system.with_params(dict(zip(names, p))), progress=False, **kw)
        return r.part("bob").position[-1, 2]

    g = np.asarray(jax.jit(jax.jacfwd(theta_end))(jnp.asarray(p0)))
    h = 1e-4  # [N m]
    fd = np.array([(float(theta_end(p0 + h * e)) - float(theta_end(p0 - h * e))) / (2 * h) for e in np.eye(len(p0))])
    # central differences: truncation ~h² |z'''| (z is nearly linear in a knot: < 1e-10) and
    # the implicit steps' Newton residual (~1e-13 m) over h: ~1e-9 m/(N m)
    np.testing.assert_allclose(g, fd, rtol=1e-6, atol=5e-9)
    assert np.all(np.abs(g[1:]) > 1e-4)  # every interior knot moves the bob


def test_pid_setpoint_reads_a_law_and_follows_its_knots():
    """A PID servo (kp = 50 N m/rad, kd = 2 N m s/rad on J = 0.02 kg m²: ω_n = 50 rad/s, ζ = 1)
    whose set point is a STEP5 chain settles on the chain's last knot; a new last knot through
    with_params moves where it settles (steady state of a type-0 loop without load: no error)."""
    m = pl.Model("law_pid", gravity=(0, 0, 0))
    r = m.add_part("rotor", mass=1.0, inertia=(0.01, 0.01, J), position=(0, 0, 0))
    m.add_joint(pl.Revolute("pin", m.ground, r, at=(0, 0, 0), axis=(0, 0, 1)))
    law = m.add_law(pl.Step5Chain("sp", [0.0, 0.2], [0.0, 0.5]))
    m.add_controller(pl.PID("servo", "pin", kp=50.0, kd=2.0, setpoint=law))
    system = pl.assemble(m)
    for last in (0.5, -0.3):
        res = pl.simulate(system.with_params(sp_y1=last), t_end=0.6, dt_output=0.01)
        # 0.4 s after the set point's end, e^{-ω_n t}(1 + ω_n t) ≈ 4e-8 of the step remains
        assert res.joint("pin").angle[-1] == pytest.approx(last, abs=1e-4)
