"""Coupler constraint, JointStop and JointFriction forces, shared Battery, design variables.

Closed forms:
- a two-gear train θ₁ = r θ₂ under a constant torque T on gear 1: J_eff = J₁ + J₂/r²,
  θ̈₁ = T / J_eff; reaction on gear 2 τ₂ = J₂ θ̈₁ / r, on gear 1 τ₁ = −τ₂ / r (ideal gear:
  power τ₁ω₁ + τ₂ω₂ = 0); kinetic energy equals the input work;
- two drives saturated at the full battery voltage: i_k = (V − K_ω ω_k)/R_a and
  V = V_nom − R_s Σ i_k, so V = (V_nom + R_s Σ K_ω ω_k / R_a) / (1 + n R_s / R_a).
"""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import proleg as pl
from proleg.drives.battery import shared_supply
from proleg.drives.dcmotor import DCMotorDrive, delivered_torque
from proleg.errors import ModelError
from tolerances import CONSTRAINT_RESIDUAL

JA, JB, R, TQ = 2e-3, 5e-2, 4.0, 0.05


def gear_pair(closed_loop=False, ratio=R):
    m = pl.Model("gears", gravity=(0, 0, 0))
    a = m.add_part("pinion", mass=0.1, inertia=(JA, JA, JA), position=(0, 0, 0))
    b = m.add_part("wheel", mass=0.3, inertia=(JB, JB, JB), position=(0.2, 0, 0))
    ja = m.add_joint(pl.Revolute("ja", a, m.ground, at=(0, 0, 0), axis=(0, 0, 1)))
    jb = m.add_joint(pl.Revolute("jb", b, m.ground, at=(0.2, 0, 0), axis=(0, 0, 1)))
    m.add_coupler(pl.Coupler("gear", ja, jb, ratio=ratio))
    m.add_force(pl.Torque("motor", a, (0, 0, TQ)))
    return m


@pytest.fixture(scope="module")
def gear_result():
    return pl.simulate(pl.assemble(gear_pair()), t_end=1.0, dt_output=0.01)


def test_coupler_gear_train_closed_form(gear_result):
    res = gear_result
    thdd = TQ / (JA + JB / R**2)
    t = res.t
    th1 = np.unwrap(res.joint("ja").angle)  # the fast gear turns 0.78 rev: its angle wraps
    th2 = res.joint("jb").angle
    np.testing.assert_allclose(th1, 0.5 * thdd * t**2, rtol=1e-6, atol=1e-9)
    np.testing.assert_allclose(th2, th1 / R, rtol=1e-9, atol=1e-12)
    c = res.coupler("gear")
    np.testing.assert_allclose(c.torque_2[1:], JB * thdd / R, rtol=1e-6)
    np.testing.assert_allclose(c.torque_1, -c.torque_2 / R, rtol=1e-12)


def test_coupler_energy_and_power_balance(gear_result):
    e = gear_result.energy
    # all input work becomes kinetic energy (the gear constraint does no work)
    np.testing.assert_allclose(e.kinetic, e.input, atol=1e-9 * max(1.0, e.input[-1]))
    c = gear_result.coupler("gear")
    w1 = np.gradient(np.unwrap(gear_result.joint("ja").angle), gear_result.t)
    w2 = np.gradient(gear_result.joint("jb").angle, gear_result.t)
    p = c.torque_1 * w1 + c.torque_2 * w2
    assert np.max(np.abs(p)) < 1e-6 * np.max(np.abs(c.torque_1 * w1))


def test_coupler_in_closed_loop_four_bar():
    """A gear pair whose driven gear is the crank of a four-bar: the loop closes, the coupler
    row stays independent, and θ₁ = r θ₂ holds while the rocker moves."""
    m = pl.Model("geared_fourbar", gravity=(0, -9.81, 0))
    crank = m.add_part("crank", mass=0.5, inertia=(1e-3,) * 3, position=(0.05, 0, 0))
    link = m.add_part("link", mass=0.5, inertia=(5e-3,) * 3, position=(0.1, 0.15, 0))
    rocker = m.add_part("rocker", mass=0.5, inertia=(5e-3,) * 3, position=(0.2, 0.15, 0))
    pinion = m.add_part("pinion", mass=0.05, inertia=(1e-5,) * 3, position=(-0.1, 0, 0))
    jc = m.add_joint(pl.Revolute("crank_pin", crank, m.ground, at=(0, 0, 0), axis=(0, 0, 1)))
    m.add_joint(pl.Revolute("a", link, crank, at=(0.1, 0, 0), axis=(0, 0, 1)))
    m.add_joint(pl.Revolute("b", rocker, link, at=(0.1, 0.3, 0), axis=(0, 0, 1)))
    m.add_joint(pl.Revolute("c", rocker, m.ground, at=(0.3, 0.0, 0), axis=(0, 0, 1)))
    jp = m.add_joint(pl.Revolute("pinion_pin", pinion, m.ground, at=(-0.1, 0, 0), axis=(0, 0, 1)))
    m.add_coupler(pl.Coupler("gear", jp, jc, ratio=-3.0))
    m.add_force(pl.Torque("drive", pinion, (0, 0, 0.02)))
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the planar four-bar has redundant out-of-plane rows
        sys_ = pl.assemble(m)
    assert ("gear", "q1 - r q2") in sys_.topo.ct.labels
    # the α-method named: the closure at every output (50 phi_tol) is its projected outputs'; "auto"
    # runs closed loops with Radau5, interpolated between steps (solvers/auto.py)
    res = pl.simulate(sys_, t_end=0.5, dt_output=0.01, integrator=pl.GeneralizedAlpha())
    th_p = res.joint("pinion_pin").angle
    th_c = res.joint("crank_pin").angle
    assert np.ptp(th_c) > 0.1
    d = th_p + 3.0 * th_c  # both angles wrap at ±π; r = −3 is an integer, so compare modulo 2π
    np.testing.assert_allclose(np.arctan2(np.sin(d), np.cos(d)), 0.0, atol=1e-8)
    assert np.max(res.constraint_residual()) < CONSTRAINT_RESIDUAL  # tests/tolerances.py: 50 phi_tol


def test_coupler_under_vmap_and_jacfwd():
    sys_ = pl.assemble(gear_pair())

    def end_angle(r):
        res = pl.simulate(sys_.with_params(coupler_ratio=jnp.atleast_1d(r)), t_end=0.2, dt_output=0.1, coordinates="absolute")
        return res.q[-1, 7 * 1 + 3]  # wheel Euler parameter e0 changes with its angle

    rs = jnp.array([3.0, 4.0])
    vals = jax.vmap(end_angle)(rs)
    assert vals.shape == (2,) and vals[0] != vals[1]
    g = jax.jacfwd(end_angle)(4.0)
    h = 1e-4
    fd = (end_angle(4.0 + h) - end_angle(4.0 - h)) / (2 * h)
    np.testing.assert_allclose(g, fd, rtol=1e-4)


def test_coupler_bad_input():
    m = pl.Model("bad", gravity=(0, 0, 0))
    a = m.add_part("a", mass=1, inertia=(1, 1, 1), position=(0, 0, 0))
    b = m.add_part("b", mass=1, inertia=(1, 1, 1), position=(1, 0, 0))
    ja = m.add_joint(pl.Revolute("ja", a, m.ground, at=(0, 0, 0), axis=(0, 0, 1)))
    jb = m.add_joint(pl.Prismatic("jb", b, m.ground, at=(1, 0, 0), axis=(1, 0, 0)))
    with pytest.raises(ModelError, match="'g'.*rotation.*translation|same kind"):
        m.add_coupler(pl.Coupler("g", ja, jb, ratio=2.0))
    with pytest.raises(ModelError, match="Coupler 'z'.*ratio is zero"):
        pl.Coupler("z", ja, jb, ratio=0.0)
    with pytest.raises(ModelError, match="same joint"):
        m.add_coupler(pl.Coupler("s", ja, ja, ratio=2.0))


def stop_model(damping=0.0):
    """A mass on a vertical slider falling onto a stop at x = −0.1 (x = slider translation)."""
    m = pl.Model("stop", gravity=(0, 0, -9.81))
    blk = m.add_part("block", mass=2.0, inertia=(1e-2,) * 3, position=(0, 0, 0))
    j = m.add_joint(pl.Prismatic("slide", blk, m.ground, at=(0, 0, 0), axis=(0, 0, 1)))
    m.add_force(pl.JointStop("floor", j, lower=-0.1, stiffness=1e5, exponent=1.0, damping=damping, penetration=1e-3))
    return m


def test_joint_stop_static_penetration_and_energy():
    res = pl.simulate(pl.assemble(stop_model()), t_end=0.5, dt_output=1e-3, integrator=pl.GeneralizedAlpha(rtol=1e-9, atol=1e-11))
    s = res.force("floor")
    # undamped: the energy is conserved through the bounce, the block returns to its height
    e = res.energy
    assert np.max(np.abs(e.total - e.total[0])) < 1e-3 * 2.0 * 9.81 * 0.1  # the kink at contact costs accuracy
    assert s.in_contact.max() == 1.0 and s.in_contact[0] == 0.0
    # peak penetration from energy: m g (h + p) = k p² / 2
    mg, k = 2.0 * 9.81, 1e5
    p = (mg + np.sqrt(mg**2 + 2 * k * mg * 0.1)) / k
    np.testing.assert_allclose(s.penetration.max(), p, rtol=2e-3)
    assert np.all(s.force >= 0.0)  # the lower stop pushes up, never pulls


def test_joint_stop_damped_settles_at_static_penetration():
    res = pl.simulate(pl.assemble(stop_model(damping=400.0)), t_end=2.0, dt_output=1e-2)
    s = res.force("floor")
    np.testing.assert_allclose(s.penetration[-1], 2.0 * 9.81 / 1e5, rtol=1e-3)
    np.testing.assert_allclose(s.force[-1], 2.0 * 9.81, rtol=1e-3)


def test_joint_stop_and_friction_bad_input():
    m = stop_model()
    j = m.joint("slide")
    with pytest.raises(ModelError, match="JointStop 'x'.*lower= and/or upper="):
        pl.JointStop("x", j)
    with pytest.raises(ModelError, match="JointStop 'x'.*lower"):
        pl.JointStop("x", j, lower=1.0, upper=0.0)
    with pytest.raises(ModelError, match="starts at 0 outside"):
        m.add_force(pl.JointStop("late", j, lower=0.1, stiffness=1e5))
    with pytest.raises(ModelError, match="JointFriction 'f' friction must be non-negative"):
        pl.JointFriction("f", j, friction=-1.0)


def test_joint_friction_dissipates():
    m = pl.Model("spin", gravity=(0, 0, 0))
    w = m.add_part("wheel", mass=1.0, inertia=(0.1,) * 3, position=(0, 0, 0), angular_velocity=(0, 0, 10.0))
    j = m.add_joint(pl.Revolute("axle", w, m.ground, at=(0, 0, 0), axis=(0, 0, 1)))
    m.add_force(pl.JointFriction("fr", j, friction=0.2, damping=0.0, slip_rate=1e-3))
    res = pl.simulate(pl.assemble(m), t_end=2.0, dt_output=0.01)
    # Coulomb deceleration 0.2 / 0.1 = 2 rad/s²: ω = 10 − 2 t while slipping
    om = res.part("wheel").angular_velocity[:, 2]
    np.testing.assert_allclose(om[res.t <= 1.0], 10.0 - 2.0 * res.t[res.t <= 1.0], rtol=1e-5)
    e = res.energy
    np.testing.assert_allclose(e.dissipated[-1], e.kinetic[0] - e.kinetic[-1], rtol=1e-5)


D = DCMotorDrive()


def test_shared_battery_single_drive_equals_closed_form():
    for tau, w in [(-10.0, -2.0), (-60.0, -1.0), (-60.0, -8.0), (30.0, 5.0), (-30.0, 5.0), (-100.0, -15.0)]:
        ref = delivered_torque(D, tau, w, battery=True)
        V = shared_supply([D], jnp.array([tau]), jnp.array([w]), D.V_nom, D.R_s)
        out = delivered_torque(D, tau, w, V=V)
        np.testing.assert_allclose(out.torque, ref.torque, rtol=1e-12)
        np.testing.assert_allclose(V, ref.supply_voltage, rtol=1e-12)


def test_shared_battery_two_saturated_drives_sag():
    w = jnp.array([-2.0, -3.0])  # leg speeds; both commanded far beyond the voltage limit
    tau = jnp.array([-500.0, -500.0])
    big = DCMotorDrive(i_max=1e3)  # no current limit: both drives saturate on the voltage
    V = shared_supply([big, big], tau, w, big.V_nom, big.R_s)
    e = big.K_omega * big.beta * w  # K_ω ω_m; reverse-voltage saturation: i = (−V − K_ω ω_m)/R_a, i_s = −i
    V_cf = (big.V_nom - big.R_s * np.sum(e) / big.R_a) / (1 + 2 * big.R_s / big.R_a)
    np.testing.assert_allclose(V, V_cf, rtol=1e-12)
    i = [(-V - big.K_omega * big.beta * wk) / big.R_a for wk in w]
    np.testing.assert_allclose(V, big.V_nom - big.R_s * (-(i[0] + i[1])), rtol=1e-12)
    # the sag with two drives is larger than with one
    V1 = shared_supply([big], tau[:1], w[:1], big.V_nom, big.R_s)
    assert V < V1 < big.V_nom


def test_shared_battery_gradient_matches_finite_differences():
    f = lambda w: delivered_torque(D, -60.0, w, V=shared_supply([D, D], jnp.array([-60.0, -40.0]), jnp.array([w, -2.0]), D.V_nom, D.R_s)).torque
    w0, h = -6.0, 1e-6
    np.testing.assert_allclose(jax.grad(f)(w0), (f(w0 + h) - f(w0 - h)) / (2 * h), rtol=1e-6)


def test_design_variable_in_controller_changes_without_recompile():
    m = pl.Model("servo", gravity=(0, 0, 0))
    w = m.add_part("wheel", mass=1.0, inertia=(0.1,) * 3, position=(0, 0, 0))
    j = m.add_joint(pl.Revolute("axle", w, m.ground, at=(0, 0, 0), axis=(0, 0, 1)))
    m.add_actuator(pl.JointActuator("motor", j))
    m.add_variable("target", 0.5, "rad")
    law = lambda t, s, mem: {"motor": 5.0 * (s.variable("target") - s.joint_angle("axle")) - 2.0 * s.joint_rate("axle")}
    m.add_controller(pl.StateMachine("ctl", {"hold": law}, [], "hold", ["motor"]))
    sys_ = pl.assemble(m)
    a = pl.simulate(sys_, t_end=5.0, dt_output=0.1).joint("axle").angle[-1]
    b = pl.simulate(sys_.with_params(target=0.2), t_end=5.0, dt_output=0.1).joint("axle").angle[-1]
    np.testing.assert_allclose([a, b], [0.5, 0.2], atol=1e-3)
    assert "target" in sys_.param_names()


def test_state_machine_unknown_signal_is_a_model_error_at_assembly():
    m = pl.Model("bad_guard", gravity=(0, 0, 0))
    w = m.add_part("wheel", mass=1.0, inertia=(0.1,) * 3, position=(0, 0, 0))
    j = m.add_joint(pl.Revolute("axle", w, m.ground, at=(0, 0, 0), axis=(0, 0, 1)))
    m.add_actuator(pl.JointActuator("motor", j))
    guard = lambda t, s, mem: s.contact_force("toe") > 5.0
    m.add_controller(pl.StateMachine("legctl", {"a": lambda t, s, mem: {}, "b": lambda t, s, mem: {}}, [("a", "b", guard)], "a", ["motor"]))
    with pytest.raises(ModelError, match="StateMachine 'legctl'.*no contact named 'toe'"):
        pl.assemble(m)


def test_model_file_round_trip_with_coupler_stop_and_friction(tmp_path):
    from proleg.io import dump_model, load_model_file

    m = gear_pair()
    m.add_force(pl.JointStop("stop", m.joint("jb"), upper=0.5, stiffness=1e3))
    m.add_force(pl.JointFriction("fr", m.joint("ja"), damping=1e-3))
    path = dump_model(m, tmp_path / "gears.yaml")
    m2, _ = load_model_file(path)
    assert [c.name for c in m2.couplers] == ["gear"] and m2.couplers[0].ratio == R
    a = pl.simulate(pl.assemble(m), t_end=0.5, dt_output=0.1)
    b = pl.simulate(pl.assemble(m2), t_end=0.5, dt_output=0.1)
    np.testing.assert_allclose(a.coupler("gear").torque_2, b.coupler("gear").torque_2, rtol=1e-9)
