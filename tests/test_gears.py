"""Gear trains, FLEGX worm gear (seed 002, Eqs. 16–17) and backlash (seed 003, Model II)."""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy.optimize import brentq

from proleg.drives import (
    GearTrain,
    WormGear,
    backlash_torque,
    backlash_torque_smooth,
    input_torque,
    output_torque,
)

W = WormGear()
EPS = np.finfo(float).eps


def test_gear_train_power_flow():
    # rel 1e-12 throughout: products and quotients of a few floats (a few ulp, no cancellation);
    # a wrong branch (η instead of 1/η) is off by 50 %
    g = GearTrain(10.0, 0.8)
    assert float(output_torque(g, 2.0, 1.0)) == pytest.approx(10 * 0.8 * 2.0, rel=1e-12)  # motor drives
    assert float(output_torque(g, 2.0, -1.0)) == pytest.approx(10 / 0.8 * 2.0, rel=1e-12)  # back-driven
    assert float(output_torque(g, -2.0, 1.0)) == pytest.approx(-10 / 0.8 * 2.0, rel=1e-12)
    # power balance: out power = η · in power (forward), in power = η · out power (backward)
    for tin, wout in ((2.0, 1.0), (2.0, -1.0), (-3.0, 0.5)):
        pin, pout = tin * 10 * wout, float(output_torque(g, tin, wout)) * wout
        assert (pout / pin if pin > 0 else pin / pout) == pytest.approx(0.8, rel=1e-12)
        assert float(input_torque(g, output_torque(g, tin, wout), wout)) == pytest.approx(tin, rel=1e-12)
    # smooth variant: mean factor at zero speed, exact branches beyond speed_eps
    assert float(output_torque(g, 1.0, 0.0, speed_eps=0.1)) == pytest.approx(5 * (0.8 + 1 / 0.8), rel=1e-12)
    assert float(output_torque(g, 1.0, 0.2, speed_eps=0.1)) == pytest.approx(8.0, rel=1e-12)
    assert np.isfinite(float(jax.grad(output_torque, argnums=2)(g, 1.0, 0.0, 0.1)))


def test_worm_geometry_seed002():
    # Plain Python floats: IEEE + − × ÷ are correctly rounded on every CPU, and libm's tan/atan
    # are within 1 ulp, so 1e-15 m (≥ 30 ulp of these 0.03 to 0.2 values) is round-off with margin.
    assert W.worm_pitch_diameter == pytest.approx(2 * 53e-3 - 29 * 2.5e-3, abs=1e-15)  # 33.5 mm
    assert W.worm_pitch_diameter == pytest.approx(33.5e-3, abs=1e-15)
    assert math.tan(W.lead_angle) == pytest.approx(3 * 2.5 / 33.5, abs=1e-15)
    assert math.degrees(W.lead_angle) == pytest.approx(12.6193, abs=1e-4)
    assert math.tan(W.normal_pressure_angle) == pytest.approx(math.tan(math.radians(15)) * math.cos(W.lead_angle))  # Eq. 17
    assert W.ratio == pytest.approx(29 / 3) and round(W.ratio, 2) == 9.67


def test_worm_efficiency_eq16():
    f = 0.14
    cn, ta = math.cos(W.normal_pressure_angle), math.tan(W.lead_angle)
    # five flops on O(1) values, XLA against Python: a few ulp; 64 eps = 1.4e-14
    assert float(W.efficiency(f)) == pytest.approx((cn - f * ta) / (cn + f / ta), abs=64 * EPS)
    assert float(W.efficiency(0.0)) == pytest.approx(1.0) and float(W.back_efficiency(0.0)) == pytest.approx(1.0)
    # traceable in f
    deta = jax.grad(W.efficiency)(f)
    fd = (W.efficiency(f + 1e-6) - W.efficiency(f - 1e-6)) / 2e-6
    assert float(deta) == pytest.approx(float(fd), rel=1e-7)


def test_friction_for_assumed_efficiency_060():
    # seed 002: η assumed 0.60 → f "approximately 0.14" (root-find to check the closed form)
    f_root = brentq(lambda f: W.efficiency(f) - 0.60, 0.0, 1.0, xtol=1e-15)
    f = W.friction_for_efficiency(0.60)
    assert f == pytest.approx(f_root, abs=1e-12)
    assert f == pytest.approx(0.1333, abs=5e-4)  # the paper's 0.14 is a rounding (η(0.14) = 0.588)
    assert float(W.efficiency(f)) == pytest.approx(0.60, abs=1e-12)


def test_self_locking_boundary():
    f_star = math.cos(W.normal_pressure_angle) * math.tan(W.lead_angle)
    assert W.self_locking_friction == pytest.approx(f_star)
    # zero up to the cancellation cos γ_n tan γ − f* (operands ~0.2, each a few ulp apart in XLA)
    assert float(W.back_efficiency(f_star)) == pytest.approx(0.0, abs=64 * EPS)
    assert float(W.back_efficiency(0.99 * f_star)) > 0 and float(W.back_efficiency(1.01 * f_star)) < 0
    assert not bool(W.is_self_locking(0.133)) and bool(W.is_self_locking(0.25))
    # with the paper's f the FLEGX worm is back-drivable, η_back < η
    assert 0 < float(W.back_efficiency(0.133)) < float(W.efficiency(0.133))
    # a single-start worm with a small lead angle (tan γ ≈ 0.075) locks with the same f
    assert bool(WormGear(starts=1).is_self_locking(0.133))
    with pytest.raises(ValueError, match="self-locking"):
        W.gear_train(0.3)
    gt = W.gear_train(0.133)
    assert gt.ratio == pytest.approx(29 / 3) and gt.back_efficiency == pytest.approx(float(W.back_efficiency(0.133)))


K, C, B = 401.0, 2.0, math.radians(4.0)


def test_backlash_dead_band_and_contact_law():
    th = jnp.array([-0.5 * B, 0.0, 0.99 * B, B])
    np.testing.assert_array_equal(backlash_torque(th, 3.0, K, C, B), 0.0)  # no damping in the gap
    for t, v in ((1.5 * B, 0.7), (-2.0 * B, -0.3), (3 * B, -1.0)):
        expected = -K * (t - math.copysign(B, t)) - C * v
        assert float(backlash_torque(t, v, K, C, B)) == pytest.approx(expected, rel=1e-12)  # 4 flops, |τ| ≥ 14 N m


def test_smooth_backlash_matches_hard_law_outside_band_and_is_c1():
    w = 0.1 * B
    ths = jnp.array([-3 * B, -(B + 0.6 * w), 0.0, 0.3 * B, B - 0.6 * w, B + 0.5 * w, 2 * B])
    hard = backlash_torque(ths, 0.4, K, C, B)
    smooth = backlash_torque_smooth(ths, 0.4, K, C, B, w)
    # the same law outside the band, through other flops: 256 eps × the largest torque (28 N m)
    np.testing.assert_allclose(smooth, hard, atol=256 * EPS * float(np.max(np.abs(hard))))
    dtau = jax.jit(jax.vmap(jax.grad(backlash_torque_smooth), in_axes=(0, None, None, None, None, None)))
    ends = jnp.array([B - 0.5 * w, B + 0.5 * w])
    h = 1e-9
    np.testing.assert_allclose(dtau(ends - h, 0.0, K, C, B, w), dtau(ends + h, 0.0, K, C, B, w), atol=1e-3)
    # stiffness: 0 in the gap, −k in full contact, −k/2 at the band centre
    np.testing.assert_allclose(dtau(jnp.array([0.5 * B, B, 2 * B]), 0.0, K, C, B, w), [0.0, -K / 2, -K], atol=1e-9)
