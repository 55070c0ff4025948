"""Order-5 ODE integrators on the joint-coordinate ODE (solvers/ode.py, analyses/ode.py):
observed order, tolerance proportionality of the energy error, agreement with the implicit
path and with sampled controllers, closed loops in the index-1 form, vmap and jacfwd."""

import jax
import jax.numpy as jnp
import dataclasses

import numpy as np
import pytest
from test_core_rigid_body import A0, J_PART, OMEGA_PRINCIPAL, Q, V0
from test_planar import chain, check_vmap_and_jacfwd, slider_crank

import proleg as pl
from proleg.assembly.system import constraints


@pytest.fixture(scope="module")
def pendulum():
    return pl.assemble(chain(1, tilt=False))


def _tip(result):
    return np.asarray(result.part("link1").position[-1])


@pytest.mark.parametrize("integrator", [pl.Tsit5(), pl.Kvaerno5()], ids=lambda i: type(i).__name__)
def test_observed_order(pendulum, integrator):
    """Fixed steps h = 0.04, 0.02, 0.01 s over 1 s of a pendulum swinging from 20° below the
    horizontal (a smooth, nonlinear problem): the end-position error against an rtol-1e-13 run
    falls as h^p with p within 0.3 of 5 (least-squares slope of log error on log h)."""
    ref = _tip(pl.simulate(pendulum, t_end=1.0, output_times=[0.0, 1.0], integrator=pl.Tsit5(rtol=1e-13, atol=1e-14)))
    hs = np.array([0.04, 0.02, 0.01])
    err = [np.linalg.norm(_tip(pl.simulate(pendulum, t_end=1.0, output_times=[0.0, 1.0], integrator=dataclasses.replace(integrator, fixed_step=h))) - ref) for h in hs]
    slope = np.polyfit(np.log(hs), np.log(err), 1)[0]
    assert abs(slope - integrator.order) < 0.3, (slope, err)


def _energy_error(result):
    T, V = np.asarray(result.energy["kinetic"]), np.asarray(result.energy["potential"])
    E = T + V
    return np.abs(E - E[0]).max() / max(T.max(), 1e-300)


def torque_free():
    """The 'flip' body of test_core_rigid_body (tumbling near its intermediate axis)."""
    model = pl.Model("torque_free", gravity=(0, 0, 0))
    model.add_part("flip", mass=3.0, inertia=J_PART, position=(0, 0, 0), orientation=A0, velocity=V0, angular_velocity=A0 @ Q @ OMEGA_PRINCIPAL["flip"])
    return pl.assemble(model)


@pytest.mark.parametrize("name", ["chain", "torque_free"])
def test_energy_error_follows_rtol(name):
    """Undamped 3-link chain (10 s) and a tumbling torque-free body (a floating base, 10 s), Tsit5:
    the energy error relative to the largest kinetic energy falls at least 100× when rtol falls
    1000× (1e-6 → 1e-9, atol = rtol/100); the body's ground angular momentum is kept alike."""
    system = pl.assemble(chain(3, tilt=False)) if name == "chain" else torque_free()
    errs = []
    for rtol in (1e-6, 1e-9):
        r = pl.simulate(system, t_end=10.0, dt_output=0.05, integrator=pl.Tsit5(rtol=rtol, atol=rtol / 100))
        errs.append(_energy_error(r))
    assert errs[0] / errs[1] >= 100.0, errs
    assert errs[1] < 1e-7


def test_agrees_with_generalized_alpha(pendulum):
    """Tsit5 (rtol 1e-11) and generalized-α (rtol 1e-10) give the same swing within 1e-6 m."""
    opts = dict(t_end=1.0, dt_output=0.1)
    a = pl.simulate(pendulum, integrator=pl.GeneralizedAlpha(rtol=1e-10, atol=1e-11), **opts)
    b = pl.simulate(pendulum, integrator=pl.Tsit5(rtol=1e-11, atol=1e-12), **opts)
    assert b.coordinates == "joint" and b.ok
    np.testing.assert_allclose(a.t, b.t)
    assert np.abs(a.part("link1").position - b.part("link1").position).max() < 1e-6


def test_closed_loop_in_index1_form():
    """A closed loop (slider-crank) runs in the index-1 form: at rtol 1e-10 every joint equation
    of the absolute model holds to 1e-8 over 0.2 s, and the slider follows the generalized-α run
    within 1e-6 m."""
    with pytest.warns(UserWarning, match="redundant"):
        system = pl.assemble(slider_crank())
    opts = dict(t_end=0.2, dt_output=0.02)
    a = pl.simulate(system, integrator=pl.GeneralizedAlpha(rtol=1e-10, atol=1e-11), **opts)
    b = pl.simulate(system, integrator=pl.Tsit5(rtol=1e-10, atol=1e-11), **opts)
    phi = jax.jit(jax.vmap(lambda q: constraints(system, q, 0.0)))(b.q)
    assert np.abs(np.asarray(phi)).max() < 1e-8
    assert np.abs(a.part("slider").position - b.part("slider").position).max() < 1e-6


@pytest.mark.slow
def test_vmap_and_jacfwd_through_tsit5():
    """vmap over 8 spring stiffnesses equals the loop (1e-12); jacfwd of the final position
    equals central differences within 1e-5 relative (Diffrax ForwardMode adjoint)."""
    system = pl.assemble(chain(2, tilt=False, spring=50.0))

    def final_x(k):
        r = pl.simulate(system.with_params({"spring.stiffness": k}), t_end=0.2, dt_output=0.05, integrator=pl.Tsit5(rtol=1e-10, atol=1e-12))
        return r.part("link2").position[-1, 0]

    check_vmap_and_jacfwd(final_x, jnp.linspace(20.0, 90.0, 8))


def sampled_servo():
    """A rod on a pin driven by a PID sampled every PERIOD (test_controllers.py)."""
    from test_controllers import KD, KP, L_ROD, M_ROD, PERIOD, SET

    model = pl.Model("servo", gravity=(0, 0, 0))
    rod = model.add_part("rod", M_ROD, (1e-5, M_ROD * L_ROD**2 / 12, M_ROD * L_ROD**2 / 12), (L_ROD / 2, 0, 0))
    model.add_joint(pl.Revolute("pin", rod, model.ground, at=(0, 0, 0), axis=(0, 0, 1)))
    model.add_controller(pl.PID("servo", joint="pin", kp=KP, kd=KD, setpoint=SET, period=PERIOD))
    return pl.assemble(model)


def test_sampled_pid_same_as_generalized_alpha():
    """A rod on a pin driven by a PID sampled every PERIOD (test_controllers.py): Tsit5 integrates
    from sample to sample with the command held, and the joint angle equals the generalized-α
    run's (both at rtol 1e-8) within 5e-6 rad over 0.3 s (measured difference 1.1e-6 rad, of the
    order of the second-order method's error at that tolerance)."""
    from test_controllers import SET

    system = sampled_servo()
    opts = dict(t_end=0.3, dt_output=0.01)
    a = pl.simulate(system, integrator=pl.GeneralizedAlpha(rtol=1e-8, atol=1e-9), **opts)
    b = pl.simulate(system, integrator=pl.Tsit5(rtol=1e-8, atol=1e-9), **opts)
    angle = lambda r: np.unwrap(np.arctan2(r.part("rod").orientation[:, 1, 0], r.part("rod").orientation[:, 0, 0]))  # noqa: E731
    assert np.abs(angle(b) - SET).min() < 0.5 * abs(SET)  # it moved towards the setpoint
    assert np.abs(angle(a) - angle(b)).max() < 5e-6
