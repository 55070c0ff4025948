"""Bad input to contacts, motions, controllers and drives is refused with a ModelError that names
the element; a simulation that cannot follow an impact stops with a SolverError that says when
and where, and carries what was computed."""

import numpy as np
import pytest

import proleg as pl
from proleg.drives import GearTrain


def ball_model(name="m"):
    model = pl.Model(name, gravity=(0, 0, -9.81))
    ball = model.add_part("ball", 1.0, (1e-4, 1e-4, 1e-4), (0, 0, 0.03))
    centre = model.add_marker(ball, "centre", (0, 0, 0.03))
    return model, ball, centre


def arm_model():
    """A rod on a revolute 'hip' and a second rod on a spherical 'ball_joint'."""
    model = pl.Model("arm", gravity=(0, 0, -9.81))
    a = model.add_part("a", 1.0, (1e-3, 1e-2, 1e-2), (0.1, 0, 0))
    b = model.add_part("b", 1.0, (1e-3, 1e-2, 1e-2), (0.3, 0, 0))
    model.add_joint(pl.Revolute("hip", a, model.ground, at=(0, 0, 0), axis=(0, 1, 0)))
    model.add_joint(pl.Spherical("ball_joint", b, a, at=(0.2, 0, 0)))
    return model


# ---------------------------------------------------------------------------------------------
# contacts
# ---------------------------------------------------------------------------------------------
def test_negative_contact_stiffness():
    _, _, centre = ball_model()
    with pytest.raises(pl.ModelError, match="left_foot") as exc:
        pl.SphereContact("left_foot", centre, radius=0.02, stiffness=-1e6)
    assert "stiffness" in str(exc.value)


def test_dynamic_friction_above_static():
    _, _, centre = ball_model()
    with pytest.raises(pl.ModelError, match="left_foot") as exc:
        pl.SphereContact("left_foot", centre, radius=0.02, mu_static=0.5, mu_dynamic=0.7)
    assert "mu_dynamic" in str(exc.value)


@pytest.mark.parametrize("v_friction", [1e-3, 5e-4])
def test_stiction_velocity_not_below_friction_velocity(v_friction):
    _, _, centre = ball_model()
    with pytest.raises(pl.ModelError, match="toe") as exc:
        pl.PointContact("toe", centre, mu_static=0.8, mu_dynamic=0.6, v_stiction=1e-3, v_friction=v_friction)
    assert "v_stiction" in str(exc.value)


# ---------------------------------------------------------------------------------------------
# motions
# ---------------------------------------------------------------------------------------------
def test_motion_on_a_spherical_joint():
    model = arm_model()
    with pytest.raises(pl.ModelError, match="swing"):
        model.add_motion(pl.Motion("swing", joint="ball_joint", displacement=lambda t: 0.1 * t))


def test_translation_motion_on_a_revolute():
    model = arm_model()
    with pytest.raises(pl.ModelError, match="lift") as exc:
        model.add_motion(pl.Motion("lift", joint="hip", displacement=lambda t: 0.1 * t, dof="translation"))
    assert "hip" in str(exc.value)


# ---------------------------------------------------------------------------------------------
# controllers and drives
# ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize("period", [0.0, -1e-3])
def test_pid_period_not_positive(period):
    with pytest.raises(pl.ModelError, match="hip_servo"):
        pl.PID("hip_servo", joint="hip", kp=300.0, kd=6.0, period=period)


def test_gear_ratio_zero():
    model = arm_model()
    with pytest.raises(pl.ModelError, match="hip_motor"):
        model.add_actuator(pl.JointActuator("hip_motor", "hip", effort=1.0, gear=GearTrain(0.0)))


def test_pid_drives_an_unknown_actuator():
    """The PID names an actuator that is not in the model: refused at assembly, not in jit."""
    model = arm_model()
    model.add_controller(pl.PID("hip_servo", joint="hip", kp=300.0, kd=6.0, actuator="hip_motr"))
    with pytest.raises(pl.ModelError, match="hip_servo") as exc:
        pl.assemble(model)
    assert "hip_motr" in str(exc.value)


# ---------------------------------------------------------------------------------------------
# a simulation that cannot follow an impact
# ---------------------------------------------------------------------------------------------
# A 1 kg ball dropped 1 cm on a contact of stiffness 1e14 N/m^1.5: the Hertz contact lasts
# ~6 µs. With dt_min = 1e-5 s the error control cannot resolve it and must stop at touchdown
# (t = sqrt(2 · 0.01 / 9.81) = 0.0452 s). (With dt_min = 1e-6 it does not stop: a few ~5 µs
# steps "absorb" the impact, with an unphysical change of the rebound energy.)
T_TOUCH = np.sqrt(2 * 0.01 / 9.81)


@pytest.fixture(scope="module")
def stiff_failure():
    model, ball, centre = ball_model("stiff_drop")
    model.add_contact(pl.SphereContact("heel", centre, radius=0.02, stiffness=1e14, exponent=1.5, damping=0.0))
    system = pl.assemble(model)
    with pytest.raises(pl.SolverError) as exc:
        pl.simulate(system, t_end=0.2, dt_output=1e-3, integrator=pl.GeneralizedAlpha(dt_min=1e-5))
    return exc.value


def test_unresolvable_impact_stops_with_time_and_part(stiff_failure):
    msg = str(stiff_failure)
    assert "part 'ball'" in msg
    t_fail = float(msg.split("at t = ")[1].split(" s")[0])
    assert t_fail == pytest.approx(T_TOUCH, abs=2e-3)
    res = stiff_failure.result
    assert len(res.t) > 1
    assert res.t[-1] <= t_fail
    assert not res.ok
    # what was computed is the free fall up to the stop
    z = res.part("ball").position[:, 2]
    np.testing.assert_allclose(z, 0.03 - 0.5 * 9.81 * res.t**2, atol=1e-6)


def test_unresolvable_impact_names_the_contact(stiff_failure):
    assert "heel" in str(stiff_failure)
