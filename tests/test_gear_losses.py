"""Load-, speed- and power-flow-dependent transmission losses of the DC drive (issue 31).

Closed forms (DCMotorDrive docstring; Pelchen et al. 2002): with the drag τ_d(ω_m) and the mesh
torque τ_g = K_T i − τ_d, the leg gets β η τ_g (power to the leg) or (β/η) τ_g (leg drives the
motor). Power at the motor shaft K_T i ω_m = leg power τ φ̇ + loss, with

    loss = τ_d ω_m + (1 − η) τ_g ω_m       forward   (τ_g ω_m ≥ 0)
    loss = τ_d ω_m + (1/η − 1)(−τ_g ω_m)   backward  (τ_g ω_m < 0)

both ≥ 0; the electrical power V_t i = R_a i² + K_ω ω_m i closes the balance with K_ω = K_T.
"""


import jax.numpy as jnp
import numpy as np
import pytest

import proleg as pl
from proleg.drives.dcmotor import DCMotorDrive, delivered_torque

DRIVE = DCMotorDrive(gear_drag=0.01, gear_viscous=2e-5, drag_speed=0.5)


def _quadrants():
    tau = np.linspace(-40.0, 40.0, 41)
    w = np.array([-6.0, -1.0, -0.05, 0.05, 1.0, 6.0])
    T, W = np.meshgrid(tau, w)
    return T.ravel(), W.ravel()


def test_power_balance_both_directions():
    d = DRIVE
    tau_cmd, w = _quadrants()
    out = delivered_torque(d, jnp.asarray(tau_cmd), jnp.asarray(w), battery=False)
    tau, i = np.asarray(out.torque), np.asarray(out.current)
    w_m = d.beta * w
    shaft = d.K_T * i * w_m
    leg = tau * w
    tau_d = np.asarray(d.drag_torque(w_m))
    tau_g = d.K_T * i - tau_d
    fwd = tau_g * w_m >= 0
    eta = d.efficiency
    loss = tau_d * w_m + np.where(fwd, (1 - eta) * tau_g * w_m, (1 / eta - 1) * (-tau_g * w_m))
    scale = np.maximum(np.abs(shaft), 1.0)
    np.testing.assert_allclose((shaft - leg) / scale, loss / scale, atol=1e-9)  # energy balance, both flows
    assert np.all(loss >= -1e-12)
    assert np.any(fwd) and np.any(~fwd)  # both directions were exercised
    # electrical side: V_t i = copper + shaft power (K_ω = K_T)
    np.testing.assert_allclose(np.asarray(out.electrical_power), d.R_a * i**2 + shaft, rtol=1e-12, atol=1e-9)


def test_efficiency_grows_with_load_and_falls_with_speed():
    d = DRIVE
    eff = lambda tm, wm: float(d.efficiency_at(tm, wm))
    assert eff(0.05, 300.0) < eff(0.2, 300.0) < eff(0.8, 300.0) < d.efficiency  # load
    assert eff(0.5, 600.0) < eff(0.5, 100.0)  # speed (viscous drag)
    # back-driven: the motor receives less than the leg gives, with the same η the other way
    e_back = eff(-0.5, 300.0)
    assert 0 < e_back < d.efficiency
    # no drag: the paper's constant η in both directions (seed 003 Eq. 5)
    d0 = DCMotorDrive()
    # a ratio of two powers, each a product of a few floats: a few ulp; 64 eps relative
    assert float(d0.efficiency_at(0.3, 200.0)) == pytest.approx(d0.efficiency, rel=64 * np.finfo(float).eps)
    assert float(d0.efficiency_at(-0.3, 200.0)) == pytest.approx(d0.efficiency, rel=64 * np.finfo(float).eps)


def flywheel(drive, J=0.05):
    m = pl.Model("flywheel", gravity=(0, 0, 0))
    b = m.add_part("wheel", mass=1.0, inertia=(J, J, J), position=(0, 0, 0))
    j = m.add_joint(pl.Revolute("axle", b, m.ground, at=(0, 0, 0), axis=(0, 0, 1)))
    # 0.3 s motoring (+20 N m), then braking (−20 N m) while it still turns forward: back-driven
    m.add_actuator(pl.JointActuator("motor", j, effort=lambda t: jnp.where(t < 0.3, 20.0, -20.0), drive=drive))
    return m


def test_flywheel_motoring_then_back_driven():
    """Spin-up and braking: the result's input work equals the kinetic energy (integrator
    bookkeeping), and the drive's losses match the closed form integrated over the run."""
    res = pl.simulate(pl.assemble(flywheel(DRIVE)), t_end=0.5, dt_output=1e-4, integrator=pl.GeneralizedAlpha(rtol=1e-9, dt_max=1e-4))
    e = res.energy
    # the command jumps inside a step at t = 0.3 s: the step quadrature of the power carries
    # ~5e-6 of the work there (second order elsewhere); 5e-5 bounds it
    np.testing.assert_allclose(e.input[-1] - e.input[0], e.kinetic[-1] - e.kinetic[0], rtol=5e-5)
    a = res.actuator("motor")
    w = np.asarray(a.rate)
    tau = np.asarray(a.effort)
    assert np.any((tau < 0) & (w > 0.5))  # the back-driven phase happened
    i = np.asarray(a.current)
    d = DRIVE
    w_m = d.beta * w
    tau_d = np.asarray(d.drag_torque(w_m))
    tau_g = d.K_T * i - tau_d
    fwd = tau_g * w_m >= 0
    loss = tau_d * w_m + np.where(fwd, (1 - d.efficiency) * tau_g * w_m, (1 / d.efficiency - 1) * (-tau_g * w_m))
    gap = d.K_T * i * w_m - tau * w - loss
    assert np.max(np.abs(gap)) < 1e-9 * np.max(np.abs(d.K_T * i * w_m))
