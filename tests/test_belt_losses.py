"""Belt stage losses (proleg.drives.belt): energy balance in both directions of power flow.

Closed form (module docstring): the stage takes P_loss = (1 − η) τ_in ω + τ_d ω when the input
drives (τ_in ω ≥ 0) and (1/η − 1)(−τ_in ω) + τ_d ω when the load back-drives it, with the
no-load drag τ_d(ω) = τ_0 tanh(ω/ω_s) + c_v ω. τ_in ω − τ_out ω must equal it to round-off.
"""

import dataclasses

import jax.numpy as jnp
import numpy as np
import pytest

from proleg.drives.belt import BeltLoss, belt_input_torque, belt_loss_power, belt_output_torque, scout2_belt
from proleg.drives.dcmotor import DCMotorDrive, delivered_torque
from proleg.errors import ModelError

BELT = BeltLoss(efficiency=0.97, drag=0.5, viscous=0.02, drag_speed=0.05)


def _grid():
    tau = np.linspace(-120.0, 120.0, 49)
    w = np.array([-9.0, -2.0, -0.03, 0.0, 0.03, 2.0, 9.0])
    T, W = np.meshgrid(tau, w)
    return T.ravel(), W.ravel()


def test_energy_balance_both_directions_of_power_flow():
    tau_in, w = _grid()
    tau_out = np.asarray(belt_output_torque(BELT, jnp.asarray(tau_in), jnp.asarray(w)))
    loss = np.asarray(belt_loss_power(BELT, jnp.asarray(tau_in), jnp.asarray(w)))
    p_in = tau_in * w
    np.testing.assert_allclose(p_in - tau_out * w, loss, rtol=0, atol=1e-9 * np.max(np.abs(p_in)))
    assert np.all(loss >= -1e-12)
    fwd, back = p_in > 0, p_in < 0
    assert fwd.any() and back.any()
    # forward: the output gets less than the input gives; backward: the input gets less than the load gives
    assert np.all(np.abs(tau_out[fwd] * w[fwd]) < np.abs(p_in[fwd]))
    assert np.all(np.abs(p_in[back]) < np.abs(tau_out[back] * w[back]))
    # the closed form of each branch, independently of the module's own loss function
    tau_d = BELT.drag * np.tanh(w / BELT.drag_speed) + BELT.viscous * w
    expect = np.where(p_in >= 0, 0.97 * tau_in, tau_in / 0.97) - tau_d
    np.testing.assert_allclose(tau_out, expect, rtol=1e-14, atol=1e-12)


def test_inverse_and_efficiency_depends_on_load_and_speed():
    tau_in, w = _grid()
    tau_out = belt_output_torque(BELT, jnp.asarray(tau_in), jnp.asarray(w))
    back = np.asarray(belt_input_torque(BELT, tau_out, jnp.asarray(w)))
    np.testing.assert_allclose(back, tau_in, rtol=1e-12, atol=1e-9)
    eff = lambda t, s: float(belt_output_torque(BELT, t, s) / t)
    assert eff(5.0, 2.0) < eff(20.0, 2.0) < eff(100.0, 2.0) < BELT.efficiency  # load
    assert eff(20.0, 9.0) < eff(20.0, 1.0)  # speed (viscous)


def test_scout2_belt_is_96_percent_at_full_torque():
    full = 2 * DCMotorDrive().tau_current_limit  # two motors per virtual leg, N m at the leg
    b = scout2_belt(float(full))
    tau_in = float(belt_input_torque(b, full, 5.0))
    assert float(full) / tau_in == pytest.approx(0.96, abs=1e-3)  # Table 3's value, at full torque
    assert float(belt_output_torque(b, 0.2 * tau_in, 5.0)) / (0.2 * tau_in) < 0.95  # less at part load


def test_drive_with_belt_balances_energy_in_all_quadrants():
    """Motor shaft power K_T i ω_m = leg power + planetary loss + belt loss, both power flows."""
    belt = BeltLoss(efficiency=0.97, drag=0.3, viscous=0.01)
    d = DCMotorDrive(gear_drag=0.01, gear_viscous=2e-5, drag_speed=0.5, belt=belt)
    tau_cmd = np.linspace(-60.0, 60.0, 31)
    w = np.array([-6.0, -1.0, -0.1, 0.1, 1.0, 6.0])
    T, W = (a.ravel() for a in np.meshgrid(tau_cmd, w))
    out = delivered_torque(d, jnp.asarray(T), jnp.asarray(W), battery=False)
    tau, i = np.asarray(out.torque), np.asarray(out.current)
    w_m = d.beta * W
    tau_dm = np.asarray(d.drag_torque(w_m))
    tau_g = d.K_T * i - tau_dm
    fwd = tau_g * W >= 0
    eg = d.gear_efficiency
    tau_in = tau_g * d.beta * np.where(fwd, eg, 1 / eg)  # planetary output, referred to the leg
    gear_loss = tau_dm * w_m + np.where(fwd, (1 - eg) * tau_g * w_m, (1 / eg - 1) * (-tau_g * w_m))
    belt_loss = np.asarray(belt_loss_power(belt, jnp.asarray(tau_in), jnp.asarray(W)))
    shaft = d.K_T * i * w_m
    scale = np.max(np.abs(shaft))
    np.testing.assert_allclose(shaft - tau * W, gear_loss + belt_loss, rtol=0, atol=1e-9 * scale)
    assert np.any(fwd) and np.any(~fwd)
    np.testing.assert_allclose(np.asarray(out.electrical_power), d.R_a * i**2 + shaft, rtol=1e-12, atol=1e-9)


def test_lossless_drag_free_belt_is_the_papers_drive():
    """BeltLoss(η = 0.96), no drag, no gear drag: exactly the constant-efficiency drive of Eq. 5."""
    d0 = DCMotorDrive()
    d1 = dataclasses.replace(d0, belt=BeltLoss(efficiency=d0.belt_efficiency))
    T, W = (jnp.asarray(a) for a in _grid())
    a, b = delivered_torque(d0, T, W, battery=True), delivered_torque(d1, T, W, battery=True)
    np.testing.assert_allclose(np.asarray(b.torque), np.asarray(a.torque), rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(np.asarray(b.current), np.asarray(a.current), rtol=1e-12, atol=1e-12)


def test_bad_input():
    with pytest.raises(ModelError, match="BeltLoss efficiency = 1.2; expected in \\(0, 1\\]"):
        BeltLoss(efficiency=1.2)
    with pytest.raises(ModelError, match="BeltLoss drag = -0.1; expected ≥ 0"):
        BeltLoss(drag=-0.1)
    with pytest.raises(ModelError, match="scout2_belt"):
        scout2_belt(50.0, no_load_fraction=0.99)
