"""Stability of sampled PID servos (control/servo.py) against closed forms.

``rod``: a uniform rod (m = 0.3 kg, ℓ = 0.5 m) on a Revolute about ground z at one end, gravity
off, so the inertia its PID sees is J = m ℓ²/3 = 0.025 kg m². PID "servo": kp = 62.5 N m/rad,
setpoint 0.1 rad, period T = 1 ms; kd is swept through ``with_params`` (one compilation).
With a = kp T²/J and b = kd T/J the zero-order-hold loop is stable exactly for a/2 < b < 2.

``chain``: two uniform rods (m = 1 kg, ℓ = 1 m) hinged to ground and to each other about y,
straight along x. With the shoulder free, a torque pair on the elbow accelerates θ₂ by
(M⁻¹)₂₂, so the elbow's effective inertia is det M / M₁₁ of the 2×2 mass matrix in
(θ₁, θ₂ relative) (``elbow_inertia``).
"""

import numpy as np
import pytest

import proleg as pl
from proleg.control.servo import servo_stability

M_ROD, L_ROD = 0.3, 0.5
J_PIN = M_ROD * L_ROD**2 / 3
KP, SET, T = 62.5, 0.1, 1e-3


@pytest.fixture(scope="module")
def rod():
    model = pl.Model("servo_rod", gravity=(0, 0, 0))
    r = model.add_part("rod", M_ROD, (1e-5, M_ROD * L_ROD**2 / 12, M_ROD * L_ROD**2 / 12), (L_ROD / 2, 0, 0))
    model.add_joint(pl.Revolute("pin", r, model.ground, at=(0, 0, 0), axis=(0, 0, 1)))
    model.add_controller(pl.PID("servo", joint="pin", kp=KP, kd=1.0, setpoint=SET, period=T))
    return pl.assemble(model)


def closed_loop_matrix(a, b):
    """(θ, T θ̇) ↦ next sample for u = −kp θ − kd θ̇ held over T on a pure inertia."""
    return np.array([[1 - a / 2, 1 - b / 2], [-a, 1 - b]])


def test_effective_inertia_of_a_rod_on_its_pin(rod):
    (row,) = servo_stability(rod)
    assert row["effective inertia"] == pytest.approx(J_PIN, rel=1e-9)
    assert row["kd max"] == pytest.approx(2 * J_PIN / T, rel=1e-9)
    assert row["kd min"] == pytest.approx(KP * T / 2)


def elbow_inertia(m, ell):
    """det M / M₁₁ for two uniform rods, straight (θ₂ = 0), coordinates (θ₁, θ₂ relative)."""
    Ic = m * ell**2 / 12
    lc = ell / 2
    M11 = Ic + m * lc**2 + Ic + m * (ell**2 + lc**2 + 2 * ell * lc)
    M12 = Ic + m * (lc**2 + ell * lc)
    M22 = Ic + m * lc**2
    return (M11 * M22 - M12**2) / M11


def test_effective_inertia_of_an_elbow_with_the_shoulder_free():
    model = pl.Model("servo_chain", gravity=(0, 0, 0))
    up = model.add_part("upper", 1.0, (1e-4, 1 / 12, 1 / 12), (0.5, 0, 0))
    lo = model.add_part("lower", 1.0, (1e-4, 1 / 12, 1 / 12), (1.5, 0, 0))
    model.add_joint(pl.Revolute("shoulder", up, model.ground, at=(0, 0, 0), axis=(0, 1, 0)))
    model.add_joint(pl.Revolute("elbow", lo, up, at=(1, 0, 0), axis=(0, 1, 0)))
    model.add_controller(pl.PID("elbow_servo", joint="elbow", kp=100.0, kd=1.0, period=T))
    (row,) = servo_stability(pl.assemble(model))
    assert row["effective inertia"] == pytest.approx(elbow_inertia(1.0, 1.0), rel=1e-9)
    assert row["stable"]


@pytest.mark.parametrize("a", [1e-3, 0.05, 0.5, 2.0])
def test_stability_criterion_matches_the_discrete_eigenvalues(a):
    """a/2 < b < 2 (Jury) against the spectral radius of the exact sampled closed loop."""
    for b in np.linspace(0.0, 3.0, 301):
        radius = np.max(np.abs(np.linalg.eigvals(closed_loop_matrix(a, b))))
        if abs(b - 2) > 1e-9 and abs(b - a / 2) > 1e-9:
            assert (radius < 1 - 1e-12) == (a / 2 < b < 2), (a, b, radius)


@pytest.mark.parametrize("b", [1.9, 2.1])
def test_simulated_servo_follows_the_discrete_loop_and_warns_when_unstable(rod, b):
    """The simulated samples follow the exact discrete recursion, decaying for b = 1.9 and growing
    (sign flipping every sample) for b = 2.1; only the unstable servo is warned about."""
    kd = b * J_PIN / T
    system = rod.with_params({"controller_kd": np.array([kd])})
    n = 60
    if b > 2:
        with pytest.warns(UserWarning, match=r"PID 'servo' on joint 'pin' is unstable.*Lower kd below 50"):
            res = pl.simulate(system, t_end=n * T, dt_output=T, integrator=pl.GeneralizedAlpha(rtol=1e-9, atol=1e-10))
    else:
        import warnings

        with warnings.catch_warnings():
            warnings.simplefilter("error")
            res = pl.simulate(system, t_end=n * T, dt_output=T, integrator=pl.GeneralizedAlpha(rtol=1e-9, atol=1e-10))
    (row,) = servo_stability(system)
    assert row["stable"] == (b < 2)
    a = KP * T**2 / J_PIN
    A = closed_loop_matrix(a, b)
    x = np.array([-SET, 0.0])  # error coordinates: θ − θ_set, T θ̇
    err = [x[0]]
    for _ in range(n):
        x = A @ x
        err.append(x[0])
    err = np.array(err)
    sim = res.joint("pin").angle - SET
    np.testing.assert_allclose(sim, err, rtol=0, atol=1e-6 * max(1.0, np.max(np.abs(err))))
    # The mode at half the sample rate (eigenvalue −0.90 or −1.10): the second difference of
    # the samples filters out the slow mode; it shrinks for b = 1.9 and grows ×1.1 per sample,
    # flipping sign every sample, for b = 2.1.
    d2 = sim[2:] - 2 * sim[1:-1] + sim[:-2]
    assert (abs(d2[-1]) > 10 * abs(d2[0])) == (b > 2)
    assert (abs(d2[-1]) < 0.1 * abs(d2[0])) == (b < 2)
    if b > 2:
        assert np.all(np.sign(d2[-10:][1:]) != np.sign(d2[-10:][:-1]))
