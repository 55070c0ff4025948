"""Drives inside a model: DC motor drive (Scout II, seed 003 Table 3), gear train, backlash.

One model, gravity off, four independent rotors on Revolutes about ground z (one compilation):

``motor_rotor`` (J = 0.01 kg m²) — JointActuator "motor" with ``drive=DCMotorDrive()`` (Table 3
    defaults) and a constant command of 500 N m, far above anything the drive can deliver.
    The JointActuator applies ``delivered_torque(drive, τ_cmd, φ̇)`` with the battery model
    (Eq. 9: V_nom = 37.17 V behind R_s = 0.13 Ω), so:
    stall (φ̇ = 0): the amplifier limit i_max = 20 A is below V_nom/(R_a + R_s) = 27.3 A, and
    the torque is the current-limited stall torque α K_T i_max (Eq. 6) = 51.9 N m;
    steady speed: the voltage limit i = (V_nom − K_ω β φ̇)/(R_a + R_s) reaches 0 at the no-load
    speed φ̇_0 = V_nom/(β K_ω) = 9.349 rad/s (with the fixed V_supply = 36 V of Eq. 4,
    ``drive.no_load_speed``, it would be 9.055 rad/s). Near φ̇_0 the speed error decays with
    the time constant J (R_a + R_s)/(α β K_T K_ω) = 1.3 ms.
``gear_fwd`` (J = 0.02) — JointActuator with ``gear=GearTrain(12, 0.85)``, command 0.1 N m from
    rest: motor drives the load, joint torque = n η τ_in = 1.02 N m, θ̈ = n η τ_in / J.
``gear_back`` (J = 0.02, ω0 = 5 rad/s) — the same gear braking the rotor, command −0.01 N m:
    the load back-drives the motor, joint torque = n τ_in / η_back = −0.14118 N m.

Speeds are checked to 1e-5 only: for a spinning part the generalized-α velocity (from the
Euler-parameter rates) carries an O((ω h)²) relative error that the position-level error
control does not see; with h = 0.5 ms (the output spacing caps the step) and ω = 15 rad/s it is
~4e-6, the same at rtol 1e-6 and 1e-8. Torques and accelerations (KKT at the simulated state)
are checked to round-off.
``bl_rotor`` (J = 0.005, ω0 = 1 rad/s) — RotationalBacklash to ground, k = 20 N m/rad,
    c = 0.02 N m s/rad, half gap b = 0.1 rad, width w = 0.02 rad: zero torque for |θ| < b − w/2
    (the rotor coasts at ω0), the hard spring-damper law −k(θ − sign θ b) − c θ̇ for
    |θ| > b + w/2.
"""

import numpy as np
import pytest

import proleg as pl
from proleg.drives import DCMotorDrive, GearTrain, backlash_torque

DRIVE = DCMotorDrive()
J_MOTOR = 0.01
J_GEAR, GEAR, TAU_IN, TAU_BACK, W0_BACK = 0.02, GearTrain(12.0, 0.85), 0.1, -0.01, 5.0
J_BL, W0_BL, K_BL, C_BL, B_BL, W_BL = 0.005, 1.0, 20.0, 0.02, 0.1, 0.02


@pytest.fixture(scope="module")
def result():
    model = pl.Model("drives", gravity=(0, 0, 0))

    def rotor(name, J, y, w0=0.0):
        part = model.add_part(name, 1.0, (J / 2 + 1e-4, J / 2 + 1e-4, J), (0, y, 0), angular_velocity=(0, 0, w0))
        return model.add_joint(pl.Revolute(f"{name}_axle", part, model.ground, at=(0, y, 0), axis=(0, 0, 1)))

    rotor("motor_rotor", J_MOTOR, 0.0)
    model.add_actuator(pl.JointActuator("motor", "motor_rotor_axle", effort=500.0, drive=DRIVE))
    rotor("gear_fwd", J_GEAR, 1.0)
    model.add_actuator(pl.JointActuator("geared_fwd", "gear_fwd_axle", effort=TAU_IN, gear=GEAR))
    rotor("gear_back", J_GEAR, 2.0, W0_BACK)
    model.add_actuator(pl.JointActuator("geared_back", "gear_back_axle", effort=TAU_BACK, gear=GEAR))
    bl = rotor("bl_rotor", J_BL, 3.0, W0_BL)
    model.add_force(pl.RotationalBacklash("belt", joint=bl, stiffness=K_BL, damping=C_BL, half_gap=B_BL, width=W_BL))
    system = pl.assemble(model)
    # dt_max = the output spacing, as simulate's default was before outputs stopped limiting the
    # steps (dense output): the backlash engagements are events the model does not declare, and
    # the coast-speed checks below (1e-7) need steps that resolve them (with 1e-2 s steps the
    # speed after the bounce was off by 5e-6)
    return pl.simulate(system, t_end=0.3, dt_output=5e-4, integrator=pl.GeneralizedAlpha(rtol=1e-8, atol=1e-9, dt_max=5e-4))


def test_dc_motor_stall_torque_is_current_limited(result):
    """At φ̇ = 0 the drive delivers α K_T i_max (seed 003 Eq. 6), not the 500 N m commanded."""
    eff = result.actuator("motor").effort
    assert DRIVE.i_max < DRIVE.V_nom / (DRIVE.R_a + DRIVE.R_s)  # the amplifier limit is active
    assert eff[0] == pytest.approx(DRIVE.alpha * DRIVE.K_T * DRIVE.i_max, rel=1e-12)
    assert eff[0] == pytest.approx(DRIVE.tau_current_limit, rel=1e-12)


def test_dc_motor_runs_up_to_the_no_load_speed(result):
    """Steady speed = V_nom / (β K_ω) (battery model) within 1e-6; the torque there is 0."""
    w_nl = DRIVE.V_nom / (DRIVE.beta * DRIVE.K_omega)
    w = result.part("motor_rotor").angular_velocity[:, 2]
    late = result.t > 0.1  # > 70 time constants of 1.3 ms
    np.testing.assert_allclose(w[late], w_nl, rtol=1e-6)
    assert abs(result.actuator("motor").effort[-1]) < 1e-6 * DRIVE.tau_current_limit
    # on the way up the torque follows the envelope of torque_speed_limits (current, then voltage)
    from proleg.drives import torque_speed_limits

    wall = result.part("motor_rotor").angular_velocity[:, 2]
    hi = np.asarray(torque_speed_limits(DRIVE, wall, battery=True)[1])
    np.testing.assert_allclose(result.actuator("motor").effort, hi, rtol=1e-12, atol=1e-12)


def test_gear_train_multiplies_by_ratio_times_efficiency_when_driving(result):
    """Motor driving (τ_in ω > 0): joint torque n η τ_in, and θ̈ = n η τ_in / J."""
    t = result.t
    w = result.part("gear_fwd").angular_velocity[:, 2]
    eff = result.actuator("geared_fwd").effort
    driving = w > 1e-2  # beyond the ±gear_speed_eps (1e-3 rad/s) blend around zero speed
    tau_out = GEAR.ratio * GEAR.efficiency * TAU_IN
    np.testing.assert_allclose(eff[driving], tau_out, rtol=1e-12)
    alpha = result.part("gear_fwd").angular_acceleration[driving, 2]
    np.testing.assert_allclose(alpha, tau_out / J_GEAR, rtol=1e-10)
    a = np.polyfit(t[driving], w[driving], 1)[0]
    assert a == pytest.approx(tau_out / J_GEAR, rel=1e-5)  # measured 3e-6 (velocity O((ωh)²))


def test_gear_train_back_driven_uses_the_inverse_efficiency(result):
    """Load back-driving the motor (τ_in ω < 0): joint torque n τ_in / η_back; the rotor slows
    down linearly from ω0 = 5 rad/s."""
    t = result.t
    w = result.part("gear_back").angular_velocity[:, 2]
    eff = result.actuator("geared_back").effort
    tau_out = GEAR.ratio * TAU_BACK / GEAR.eta_back
    assert np.all(w > 1.0)
    np.testing.assert_allclose(eff, tau_out, rtol=1e-12)
    assert abs(tau_out) > GEAR.ratio * GEAR.efficiency * abs(TAU_BACK)  # braking: more than n η τ
    np.testing.assert_allclose(result.part("gear_back").angular_acceleration[:, 2], tau_out / J_GEAR, rtol=1e-10)
    np.testing.assert_allclose(w, W0_BACK + tau_out / J_GEAR * t, rtol=1e-5)


def test_backlash_coasts_in_the_dead_band(result):
    """Inside |θ| < b − w/2 nothing is transmitted: zero torque, constant speed ω0, θ = ω0 t."""
    t = result.t
    bl = result.force("belt")
    th = bl.angle
    w = result.part("bl_rotor").angular_velocity[:, 2]
    free = np.abs(th) < B_BL - W_BL / 2
    first = t < (B_BL - W_BL / 2) / W0_BL  # until the first engagement
    assert np.all(free[first])
    np.testing.assert_allclose(bl.torque[free], 0.0, atol=1e-15)  # exact: the dead band's gate and deflection are 0.0
    # The engagement is an event the model does not declare: outputs read from the dense output
    # of the step that crosses it carry the interpolant's O(h·Δq̈) error (7e-6 measured in the
    # last three outputs before it with 1e-2 s steps), so the exact speed is checked up to 2 ms before it.
    dt = t[1] - t[0]
    before = t < (B_BL - W_BL / 2) / W0_BL - 4 * dt
    np.testing.assert_allclose(w[before], W0_BL, rtol=1e-9)
    np.testing.assert_allclose(w[first], W0_BL, rtol=1e-5)
    np.testing.assert_allclose(th[before], W0_BL * t[before], rtol=1e-8, atol=1e-12)
    np.testing.assert_allclose(th[first], W0_BL * t[first], rtol=1e-7, atol=1e-12)  # 7e-9 m at the last outputs
    # the rotor bounces off the spring and later coasts through the band at a constant speed
    back = free & (t > 0.05) & (w < 0)
    assert np.count_nonzero(back) > 5
    np.testing.assert_allclose(w[back], w[back][0], rtol=1e-7)  # measured 9e-9


def test_backlash_spring_damper_law_when_engaged(result):
    """For |θ| > b + w/2 the element torque is the hard law −k(θ − sign θ b) − c θ̇ and it is
    what accelerates the rotor: J θ̈ = τ."""
    bl = result.force("belt")
    th, rate, tq = bl.angle, bl.velocity, bl.torque
    engaged = np.abs(th) > B_BL + W_BL / 2
    assert np.count_nonzero(engaged) > 20
    hard = np.asarray(backlash_torque(th, rate, K_BL, C_BL, B_BL))
    np.testing.assert_allclose(tq[engaged], hard[engaged], rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(tq[engaged], (-K_BL * (th - np.sign(th) * B_BL) - C_BL * rate)[engaged], rtol=1e-12)
    alpha = result.part("bl_rotor").angular_acceleration[:, 2]
    np.testing.assert_allclose(J_BL * alpha, tq, rtol=0, atol=1e-9 * K_BL * B_BL)
