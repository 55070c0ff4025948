"""Scout II drive (seed 003, Table 3, Eqs. 3–14): every check against the closed form."""

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from proleg.drives import (
    DCMotorDrive,
    delivered_torque,
    specific_resistance,
    torque_speed_limits,
    torque_speed_line,
)

TOL = 1e-9
D = DCMotorDrive()
KT, KW, RA = 0.0389, 0.0389, 1.23
ALPHA = (72.38 * 0.68) * (48 / 34 * 0.96)  # Eq. 5
BETA = 72.38 * 48 / 34


def test_table3_defaults_and_eq5():
    assert (D.K_T, D.K_omega, D.R_a, D.i_max, D.V_supply, D.V_nom, D.R_s) == (KT, KW, RA, 20.0, 36.0, 37.17, 0.13)
    assert D.alpha == pytest.approx(ALPHA, abs=TOL)
    assert D.beta == pytest.approx(BETA, abs=TOL)
    # the printed 6.78e-4 V/(deg/s) agrees with the interpreted K_omega to 0.2 %
    assert 6.78e-4 * 180 / np.pi == pytest.approx(D.K_omega, rel=2e-3)


def test_stall_torque_no_load_speed_and_slope_eq3_4():
    tau_max = ALPHA * KT * 36.0 / RA
    A = -BETA * ALPHA * KT * KW / RA
    assert D.tau_max == pytest.approx(tau_max, abs=TOL)
    assert D.A == pytest.approx(A, abs=TOL)
    # Eq. 3: τ_des = −τ_max + A φ̇: stall at φ̇ = 0, zero torque at the no-load speed −V/(β K_ω)
    assert float(torque_speed_line(D, 0.0)) == pytest.approx(-tau_max, abs=TOL)
    w0 = 36.0 / (BETA * KW)
    assert D.no_load_speed == pytest.approx(w0, abs=TOL)
    assert float(torque_speed_line(D, -w0)) == pytest.approx(0.0, abs=TOL)
    slope = jax.grad(lambda w: torque_speed_line(D, w))(-3.0)
    assert float(slope) == pytest.approx(A, abs=TOL)
    # without the current limit, the voltage envelope at zero speed is the stall torque ±τ_max
    lo, hi = torque_speed_limits(dataclasses.replace(D, i_max=1e3), 0.0)
    assert float(hi) == pytest.approx(tau_max, abs=TOL) and float(lo) == pytest.approx(-tau_max, abs=TOL)


def test_third_quadrant_envelope_is_eqs_13_14():
    # Eq. 14: τ_leg = sgn · min(|Eq. 13|, α K_T i_max); Eq. 13 on the saturation line
    speeds = jnp.linspace(-9.0, 0.0, 19)
    lo, _ = jax.jit(torque_speed_limits)(D, speeds)
    eq13 = -ALPHA * KT * 36.0 / RA - BETA * ALPHA * KT * KW / RA * np.asarray(speeds)
    expected = -np.minimum(np.abs(eq13), ALPHA * KT * 20.0)
    np.testing.assert_allclose(lo, expected, atol=TOL)
    # first quadrant by symmetry
    _, hi = jax.jit(torque_speed_limits)(D, -speeds)
    np.testing.assert_allclose(hi, -expected, atol=TOL)


def test_current_limit_clipping_at_20A():
    f = jax.jit(delivered_torque, static_argnames="battery")
    out = f(D, -500.0, -1.0, battery=False)  # stance-retraction, far beyond what the drive can do
    # at −1 rad/s the voltage allows (36 − 0.0389·β)/1.23 = 26.0 A, so the 20 A limit binds
    assert float(out.torque) == pytest.approx(-ALPHA * KT * 20.0, abs=TOL)
    assert float(out.current) == pytest.approx(-20.0, abs=TOL)
    assert bool(out.saturated)
    small = f(D, -10.0, -1.0, battery=False)  # inside the envelope: delivered as commanded
    assert float(small.torque) == pytest.approx(-10.0, abs=TOL) and not bool(small.saturated)
    assert float(small.current) == pytest.approx(-10.0 / (ALPHA * KT), abs=TOL)


def test_voltage_sag_with_battery_model_eq9():
    f = jax.jit(delivered_torque, static_argnames="battery")
    w = -6.0  # fast retraction: the voltage limit binds below 20 A
    wm = BETA * w
    i_sat = (-37.17 - KW * wm) / (RA + 0.13)  # closed form: V_nom − |i| R_s = |R_a i + K_ω ω_m|
    assert -20.0 < i_sat < 0.0
    out = f(D, -500.0, w, battery=True)
    assert float(out.current) == pytest.approx(i_sat, abs=TOL)
    assert float(out.torque) == pytest.approx(ALPHA * KT * i_sat, abs=TOL)
    v_batt = 37.17 - abs(i_sat) * 0.13  # Eq. 9
    assert float(out.supply_voltage) == pytest.approx(v_batt, abs=TOL)
    assert float(out.terminal_voltage) == pytest.approx(-v_batt, abs=TOL)  # amplifier fully on
    assert float(out.supply_current) == pytest.approx(abs(i_sat), abs=TOL)
    # power bookkeeping: P_el = V_t i = R_a i² + K_ω ω_m i = V_s i_s; mechanical = τ φ̇
    p_el = RA * i_sat**2 + KW * wm * i_sat
    assert float(out.electrical_power) == pytest.approx(p_el, abs=TOL)
    assert float(out.electrical_power) == pytest.approx(v_batt * abs(i_sat), abs=1e-8)
    assert float(out.mechanical_power) == pytest.approx(ALPHA * KT * i_sat * w, abs=TOL)
    # the sagging battery gives less torque than the fixed 36 V line of Eq. 3 only once
    # V_nom − |i| R_s < 36 V, i.e. |i| > 9 A: true here
    assert abs(float(out.torque)) < abs(float(torque_speed_line(D, w)))


def test_unsaturated_battery_voltage_solves_power_balance():
    out = delivered_torque(D, -10.0, -2.0, battery=True)
    vs, i_s, p = float(out.supply_voltage), float(out.supply_current), float(out.electrical_power)
    assert vs == pytest.approx(37.17 - i_s * 0.13, abs=TOL)  # Eq. 9 with i_s = P/V_s
    assert vs * i_s == pytest.approx(p, abs=TOL)


def test_back_driven_quadrant_uses_inverse_efficiency():
    # leg moving forward (φ̇ > 0) while the motor brakes (τ < 0): power flows leg → motor
    out = delivered_torque(D, -20.0, 2.0, battery=False)
    eta = 0.68 * 0.96
    assert float(out.current) == pytest.approx(-20.0 * eta / (BETA * KT), abs=TOL)
    lo, hi = torque_speed_limits(D, 2.0)
    assert float(lo) == pytest.approx(-BETA / eta * KT * 20.0, abs=TOL)  # 20 A, efficiency reversed
    assert float(hi) == pytest.approx(ALPHA * KT * min(20.0, (36.0 - KW * BETA * 2.0) / RA), abs=TOL)


def test_vmap_grad_and_pytree_parameters():
    speeds = jnp.linspace(-8.0, 8.0, 9)
    tau = jax.jit(jax.vmap(lambda w: delivered_torque(D, -30.0, w).torque))(speeds)
    assert tau.shape == (9,) and bool(jnp.all(jnp.isfinite(tau)))
    # gradient w.r.t. a drive parameter (the drive is a pytree): on the current limit
    # τ = −α K_T i_max, so ∂τ/∂K_T = −α i_max
    g = jax.grad(lambda d: delivered_torque(d, -500.0, -1.0, battery=False).torque)(D)
    assert float(g.K_T) == pytest.approx(-ALPHA * 20.0, abs=TOL)
    assert float(g.i_max) == pytest.approx(-ALPHA * KT, abs=TOL)


def test_specific_resistance_eq8():
    # Scout II: ε ≈ 1.4 electrical at 1.3 m/s, total mass ≈ 20.865 + 4·0.97 kg
    m = 20.865 + 4 * 0.97
    P = 1.4 * m * 9.80665 * 1.3
    assert float(specific_resistance(P, m, 1.3)) == pytest.approx(1.4, abs=TOL)
