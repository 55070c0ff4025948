"""Sampled controllers in a model: PID servo step response and a StateMachine guard.

One model, gravity off, holds two independent mechanisms (one compilation for the module):

``pendulum``  a uniform rod (m = 0.3 kg, ℓ = 0.5 m) on a Revolute about ground z at one end,
    so its inertia about the pin is J = m ℓ²/3 = 0.025 kg m². PID "servo" (kp = 62.5 N m/rad,
    kd = 0.75 N m s/rad, ki = 0, setpoint 0.5 rad, sampled every 1e-4 s) applies u on the pin.
    Continuous-time closed loop: J θ̈ + kd θ̇ + kp θ = kp θ_set, so
    ω_n = sqrt(kp/J) = 50 rad/s, ζ = kd / (2 sqrt(kp J)) = 0.3,
    overshoot M_p = exp(−ζπ/sqrt(1 − ζ²)) = 37.23 %,
    θ(t) = θ_set [1 − e^(−ζω_n t)(cos ω_d t + ζ/sqrt(1−ζ²) sin ω_d t)], ω_d = ω_n sqrt(1 − ζ²).
    The zero-order hold at period T acts like a delay of T/2, which lowers the effective damping
    by ≈ ω_n T/4; at T = 1e-4 s the exact sampled-data response (test below) has 0.37 % more
    overshoot than the continuous one, hence the 1 % comparison with the continuous closed form.
    At the default 1 kHz the overshoot would grow by ~4 %.
``rotor``     a disk (J_r = 0.01 kg m²) on a Revolute, driven by a JointActuator "push" whose
    command comes from StateMachine "phases" (period 1 ms): state "accelerate" commands
    τ0 = 0.02 N m, the guard joint angle > θ_sw = 0.3 rad switches to "coast" (command 0).
    θ(t) = τ0 t² / (2 J_r), so the crossing is at t_c = sqrt(2 J_r θ_sw / τ0) = 0.5477 s and the
    switch happens at the first sample after it, t_s = ceil(t_c / 1 ms) · 1 ms = 0.548 s; the
    rotor then coasts at ω = τ0 t_s / J_r.
"""

import numpy as np
import pytest
from scipy.linalg import expm

import proleg as pl

# pendulum + PID
M_ROD, L_ROD = 0.3, 0.5
J_PIN = M_ROD * L_ROD**2 / 3
KP, KD, SET, PERIOD = 62.5, 0.75, 0.5, 1e-4
WN = np.sqrt(KP / J_PIN)
ZETA = KD / (2 * np.sqrt(KP * J_PIN))
WD = WN * np.sqrt(1 - ZETA**2)
# rotor + state machine
J_ROTOR, TAU0, TH_SW, SM_PERIOD = 0.01, 0.02, 0.3, 1e-3
T_CROSS = np.sqrt(2 * J_ROTOR * TH_SW / TAU0)
T_SWITCH = np.ceil(T_CROSS / SM_PERIOD) * SM_PERIOD


def closed_loop(t):
    """Step response of J θ̈ + kd θ̇ + kp θ = kp θ_set from rest at θ = 0."""
    s = ZETA / np.sqrt(1 - ZETA**2)
    return SET * (1 - np.exp(-ZETA * WN * t) * (np.cos(WD * t) + s * np.sin(WD * t)))


def settling_time(t, y, final, band=0.02):
    """Last time |y − final| leaves the ±band·final tube (linear interpolation)."""
    out = np.nonzero(np.abs(y - final) > band * abs(final))[0]
    k = out[-1]
    e0, e1 = abs(y[k] - final) - band * abs(final), abs(y[k + 1] - final) - band * abs(final)
    return t[k] + (t[k + 1] - t[k]) * e0 / (e0 - e1)


@pytest.fixture(scope="module")
def result():
    model = pl.Model("servo_and_phases", gravity=(0, 0, 0))
    rod = model.add_part("rod", M_ROD, (1e-5, M_ROD * L_ROD**2 / 12, M_ROD * L_ROD**2 / 12), (L_ROD / 2, 0, 0))
    model.add_joint(pl.Revolute("pin", rod, model.ground, at=(0, 0, 0), axis=(0, 0, 1)))
    model.add_controller(pl.PID("servo", joint="pin", kp=KP, kd=KD, setpoint=SET, period=PERIOD))

    disk = model.add_part("disk", 1.0, (0.005, 0.005, J_ROTOR), (0, 1.0, 0))
    model.add_joint(pl.Revolute("axle", disk, model.ground, at=(0, 1.0, 0), axis=(0, 0, 1)))
    model.add_actuator(pl.JointActuator("push", "axle"))
    model.add_controller(
        pl.StateMachine(
            "phases",
            states={"accelerate": lambda t, s, mem: {"push": TAU0}, "coast": lambda t, s, mem: {"push": 0.0}},
            transitions=[("accelerate", "coast", lambda t, s, mem: s.joint_angle("axle") > TH_SW)],
            initial="accelerate",
            outputs=["push"],
            period=SM_PERIOD,
        )
    )
    system = pl.assemble(model)
    return pl.simulate(system, t_end=0.7, dt_output=1e-3, integrator=pl.GeneralizedAlpha(rtol=1e-8, atol=1e-9))


def test_pid_step_response_overshoot_and_settling(result):
    """Overshoot and 2 % settling time of the sampled PID against the second-order closed form."""
    t = result.t
    th = result.joint("pin").angle
    mp_exact = np.exp(-ZETA * np.pi / np.sqrt(1 - ZETA**2))
    mp = (np.max(th) - SET) / SET
    assert mp == pytest.approx(mp_exact, rel=0.01)
    tf = np.linspace(0, t[-1], 200001)
    ts_exact = settling_time(tf, closed_loop(tf), SET)
    ts = settling_time(t, th, SET)
    assert ts == pytest.approx(ts_exact, rel=0.01)
    # and the whole trajectory, to 1 % of the step
    np.testing.assert_allclose(th, closed_loop(t), rtol=0, atol=0.01 * SET)


def sampled_data_response(n):
    """Exact zero-order-hold closed loop at the sample times k T, k = 0..n: the plant
    x = (θ, θ̇), ẋ = A x + B u is discretised exactly, x_{k+1} = Φ x_k + Γ u_k, with
    u_k = kp (θ_set − θ_k) − kd θ̇_k."""
    A = np.array([[0.0, 1.0], [0.0, 0.0]])
    B = np.array([[0.0], [1.0 / J_PIN]])
    E = expm(np.block([[A, B], [np.zeros((1, 3))]]) * PERIOD)
    Phi, Gam = E[:2, :2], E[:2, 2]
    x, out = np.zeros(2), [0.0]
    for _ in range(n):
        x = Phi @ x + Gam * (KP * (SET - x[0]) - KD * x[1])
        out.append(x[0])
    return np.array(out)


def test_pid_matches_the_exact_sampled_data_response(result):
    """Between samples the plant is a double integrator with constant input, so the sampled
    closed loop has an exact discrete closed form; at rtol = 1e-8 the simulation should follow
    it to 1e-5 rad (2e-5 of the step)."""
    t = result.t
    ks = np.rint(t / PERIOD).astype(int)
    ref = sampled_data_response(ks[-1])[ks]
    np.testing.assert_allclose(result.joint("pin").angle, ref, rtol=0, atol=1e-5)


def test_pid_output_is_the_held_control_law(result):
    """u = kp (θ_set − θ) − kd θ̇ sampled on the PID clock: at the output times (multiples of the
    period) the held output is the law applied to the simulated state."""
    out = result.controller("servo").output
    th = result.joint("pin").angle
    rate = result.part("rod").angular_velocity[:, 2]
    np.testing.assert_allclose(out, KP * (SET - th) - KD * rate, rtol=0, atol=1e-6 * KP * SET)
    assert out[0] == pytest.approx(KP * SET)


def test_state_machine_switches_at_the_sample_after_the_crossing(result):
    """Constant acceleration τ0/J_r until the angle guard fires at the first 1 ms sample after
    t_c = sqrt(2 J_r θ_sw/τ0); then coasting at ω = τ0 t_s / J_r."""
    t = result.t
    z = result.controller("phases").state
    mode = z[:, 0]
    k = np.argmax(mode > 0.5)
    assert t[k] == pytest.approx(T_SWITCH, abs=1e-9)
    assert mode[k - 1] == 0.0 and np.all(mode[k:] == 1.0)
    assert z[k, 1] == pytest.approx(T_SWITCH, abs=1e-9)  # "entered" time of the coast state
    assert T_CROSS < T_SWITCH < T_CROSS + SM_PERIOD
    th = result.joint("axle").angle
    before = t < T_SWITCH - 1e-9
    np.testing.assert_allclose(th[before], 0.5 * TAU0 / J_ROTOR * t[before] ** 2, rtol=1e-7, atol=1e-10)
    after = t > T_SWITCH + 1e-9
    np.testing.assert_allclose(result.actuator("push").effort[before], TAU0, rtol=1e-12)
    np.testing.assert_allclose(result.actuator("push").effort[after], 0.0, atol=1e-12)


def test_coast_speed_after_the_switch(result):
    """Piecewise-constant acceleration: after the switch the rotor coasts at exactly
    ω = τ0 t_s / J_r (the command was τ0 on [0, t_s] and 0 after)."""
    after = result.t > T_SWITCH + 1e-9
    w = result.part("disk").angular_velocity[after, 2]
    np.testing.assert_allclose(w, TAU0 * T_SWITCH / J_ROTOR, rtol=1e-5)
