"""Compound pendulum on a revolute joint: small- and large-amplitude periods against closed forms.

The pendulum is a uniform rod of mass m and length ℓ hung from one end on a pin along ground y.
Its COM sits d = ℓ/2 below the pin; its inertia about the COM is J_c = m ℓ²/12, so the inertia
about the pin is I = J_c + m d² = m ℓ²/3.

One assembled system and one set of integrator options serve both amplitudes (the initial
pose is passed as ``q0``), so the solver is compiled once for the module.
"""

import numpy as np
import pytest
from scipy.special import ellipk

import proleg as pl
from tolerances import CONSTRAINT_RESIDUAL

G = 9.81
MASS = 2.0
LENGTH = 1.0
D = LENGTH / 2  # pin → COM [m]
J_C = MASS * LENGTH**2 / 12  # about the COM [kg m^2]
I_PIN = J_C + MASS * D**2  # about the pin [kg m^2]
T_SMALL = 2 * np.pi * np.sqrt(I_PIN / (MASS * G * D))  # linearized period [s]

# Tolerances of the error-controlled integrator used in this module (tighter than the defaults
# rtol = 1e-6, atol = 1e-7): with them the measured period error is ~2e-5 (0.01 rad swing) and
# ~4e-6 (90° release), against the asserted 1e-4 and 1e-5.
RTOL, ATOL = 1e-8, 1e-9


def q_rotated(theta):
    """Coordinates of the rod turned by ``theta`` about +y (COM at R_y(θ)(0, 0, −d))."""
    p = np.array([np.cos(theta / 2), 0.0, np.sin(theta / 2), 0.0])
    r = np.array([-D * np.sin(theta), 0.0, -D * np.cos(theta)])
    return np.concatenate([r, p])


def hermite_roots(t, y, dy):
    """Times where y crosses zero, from the cubic Hermite interpolant of (y, dy) on each interval."""
    out = []
    for k in range(len(t) - 1):
        if y[k] * y[k + 1] >= 0:
            continue
        h = t[k + 1] - t[k]

        def H(s, k=k, h=h):
            return (
                (2 * s**3 - 3 * s**2 + 1) * y[k]
                + (s**3 - 2 * s**2 + s) * h * dy[k]
                + (-2 * s**3 + 3 * s**2) * y[k + 1]
                + (s**3 - s**2) * h * dy[k + 1]
            )

        def dH(s, k=k, h=h):
            return (
                (6 * s**2 - 6 * s) * y[k]
                + (3 * s**2 - 4 * s + 1) * h * dy[k]
                + (-6 * s**2 + 6 * s) * y[k + 1]
                + (3 * s**2 - 2 * s) * h * dy[k + 1]
            )

        s = y[k] / (y[k] - y[k + 1])
        for _ in range(20):
            s -= H(s) / dH(s)
        out.append(t[k] + s * h)
    return np.array(out)


@pytest.fixture(scope="module")
def system():
    model = pl.Model("rod_pendulum", gravity=(0, 0, -G))
    rod = model.add_part("rod", mass=MASS, inertia=(J_C, J_C, 1e-3), position=(0, 0, -D))
    model.add_joint(pl.Revolute("pin", model.ground, rod, at=(0, 0, 0), axis=(0, 1, 0)))
    return pl.assemble(model)


def swing(system, theta0, t_end=4.0):
    """Release from rest at θ0; returns (t, θ, θ̇, max constraint residual)."""
    res = pl.simulate(system, t_end=t_end, dt_output=0.01, integrator=pl.GeneralizedAlpha(rtol=RTOL, atol=ATOL), q0=q_rotated(theta0))
    rod = res.part("rod")
    x, z = rod.position[:, 0], rod.position[:, 2]
    theta = np.arctan2(-x, -z)  # rotation about +y from the hanging pose
    return res.t, theta, rod.angular_velocity[:, 1], float(np.max(res.constraint_residual()))


def period_from_crossings(t, theta, omega):
    """Mean period from zero crossings of θ (two crossings per period)."""
    c = hermite_roots(t, theta, omega)
    assert len(c) >= 3
    return 2 * np.mean(np.diff(c)), c


def test_small_amplitude_period(system):
    """T = 2π sqrt(I / (m g d)), I = m ℓ²/3 about the pin (physical pendulum), for θ0 → 0.

    At θ0 = 0.01 rad the finite-amplitude correction is θ0²/16 = 6e-6, well inside 1e-4.
    """
    t, th, om, resid = swing(system, 0.01)
    T, _ = period_from_crossings(t, th, om)
    assert T == pytest.approx(T_SMALL, rel=1e-4)
    assert np.max(np.abs(th)) == pytest.approx(0.01, rel=1e-6)
    assert resid < CONSTRAINT_RESIDUAL  # tests/tolerances.py: 50 phi_tol


def test_large_amplitude_period_elliptic(system):
    """Release from 90°: T = 4 sqrt(I / (m g d)) K(k²), k = sin(θ0/2) (complete elliptic integral
    of the first kind; scipy's ellipk takes the parameter m = k²). Here T/T_small − 1 = 0.180."""
    theta0 = np.pi / 2
    t, th, om, resid = swing(system, theta0)
    T, crossings = period_from_crossings(t, th, om)
    T_exact = 4 * np.sqrt(I_PIN / (MASS * G * D)) * ellipk(np.sin(theta0 / 2) ** 2)
    assert T == pytest.approx(T_exact, rel=1e-5)
    # every half period, not just their mean
    np.testing.assert_allclose(2 * np.diff(crossings), T_exact, rtol=1e-5)
    # Outputs come from the steps' dense output, projected back onto the constraints
    # (solvers/driver.py; without the projection |Φ| reached 2.2e-9 at the turning points).
    assert resid < CONSTRAINT_RESIDUAL  # tests/tolerances.py: 50 phi_tol
