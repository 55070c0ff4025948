"""The Result's accessors, table and plot as a new user meets them (issue 42 item 8, issue 43's
joint accelerations).

Models are tiny and runs short: a pendulum (closed form θ̈ = −m g L sin φ / (I + m L²)), a bead
on a rod turning at a constant rate (closed form ẍ = ω² r), and a planar two-segment leg (a 6 kg
body on a vertical slider, PD servos through JointActuator and PID, a sphere foot) dropped.
"""

import warnings

import numpy as np
import pytest

import proleg as pl
from proleg.errors import ModelError, ProlegWarning

G = 9.81


# ---------------------------------------------------------------------------------------------
# models
# ---------------------------------------------------------------------------------------------
def pendulum(th0=1.0, m=1.0, L=0.5, I=1e-3):
    """A point-like bob (inertia I about its COM) on a hinge about y at the origin, released at
    φ = th0 from hanging down. The hinge's I marker is on the bob, so its angle θ = −(φ − th0)."""
    model = pl.Model("pendulum", gravity=(0, 0, -G))
    bob = model.add_part("bob", mass=m, inertia=(I, I, I), position=(L * np.sin(th0), 0, -L * np.cos(th0)))
    model.add_joint(pl.Revolute("hinge", bob, model.ground, at=(0, 0, 0), axis=(0, 1, 0)))
    return pl.assemble(model)


def leg(drop=0.03):
    """Planar two-segment leg: 6 kg body on a vertical slider, hip and knee PD servos (PID →
    JointActuator), a sphere foot with friction; the foot ``drop`` [m] above the ground (below
    it when negative)."""
    thigh = shank = 0.25
    m = pl.Model("leg", gravity=(0, 0, -G))
    knee_x = thigh * np.sin(0.3)
    knee_z = -thigh * np.cos(0.3)
    foot_z = knee_z - np.sqrt(shank**2 - knee_x**2)
    h = -foot_z + 0.02 + drop  # hip height: the sphere (radius 0.02) `drop` above z = 0
    body = m.add_part("body", mass=6.0, inertia=(0.05, 0.05, 0.05), position=(0, 0, h))
    m.add_joint(pl.Prismatic("slider", body, m.ground, at=(0, 0, h), axis=(0, 0, 1)))
    th = m.add_part("thigh", mass=1.0, inertia=(0.01, 0.01, 0.01), position=(knee_x / 2, 0, h + knee_z / 2))
    sh = m.add_part("shank", mass=0.5, inertia=(0.005, 0.005, 0.005), position=(knee_x / 2, 0, h + (knee_z + foot_z) / 2))
    m.add_joint(pl.Revolute("hip", th, body, at=(0, 0, h), axis=(0, 1, 0)))
    m.add_joint(pl.Revolute("knee", sh, th, at=(knee_x, 0, h + knee_z), axis=(0, 1, 0)))
    m.add_actuator(pl.JointActuator("hip_motor", "hip"))
    m.add_actuator(pl.JointActuator("knee_motor", "knee"))
    m.add_controller(pl.PID("hip_servo", "hip", kp=200.0, kd=5.0, actuator="hip_motor"))
    m.add_controller(pl.PID("knee_servo", "knee", kp=200.0, kd=5.0, actuator="knee_motor"))
    c = m.add_marker(sh, "foot_centre", (0, 0, h + foot_z))
    m.add_contact(pl.SphereContact("foot", c, radius=0.02, stiffness=1e6, damping=500.0, mu_static=0.8,
                                   mu_dynamic=0.6, v_stiction=0.01, v_friction=0.05))
    return pl.assemble(m)


@pytest.fixture(scope="module")
def leg_result():
    return pl.simulate(leg(), 0.2, 1e-3)


# ---------------------------------------------------------------------------------------------
# accessors that say what a name is
# ---------------------------------------------------------------------------------------------
def test_actuator_given_a_controller_points_to_controller(leg_result):
    with pytest.raises(ModelError, match=r"'knee_servo' is a controller.*result\.controller\('knee_servo'\).*knee_motor"):
        leg_result.actuator("knee_servo")


def test_contact_given_an_actuator_points_to_actuator(leg_result):
    with pytest.raises(ModelError, match=r"'knee_motor' is a joint actuator.*result\.actuator\('knee_motor'\).*\['foot'\]"):
        leg_result.contact("knee_motor")


def test_unknown_names_list_the_valid_ones(leg_result):
    with pytest.raises(ModelError, match=r"No actuator named 'nope'.*Known actuators: \['hip_motor', 'knee_motor'\]"):
        leg_result.actuator("nope")
    with pytest.raises(ModelError, match=r"Close matches: \['knee_motor'"):
        leg_result.actuator("knee_motr")
    with pytest.raises(ModelError, match=r"No controller named 'servo'.*\['hip_servo', 'knee_servo'\]"):
        leg_result.controller("servo")
    with pytest.raises(ModelError, match=r"'knee' is a revolute joint.*result\.joint\('knee'\).*Known parts"):
        leg_result.part("knee")
    with pytest.raises(ModelError, match=r"'foot' is a contact.*result\.contact\('foot'\)"):
        leg_result.joint("foot")
    with pytest.raises(ModelError, match=r"'knee' is a revolute joint.*The model has no motions"):
        leg_result.motion("knee")
    with pytest.raises(ModelError, match=r"'knee' is a revolute joint.*not a coupler.*The model has no couplers"):
        leg_result.coupler("knee")


def test_right_kind_still_reads(leg_result):
    assert {"effort", "command", "power"} <= set(leg_result.actuator("knee_motor"))
    assert {"normal_force", "force"} <= set(leg_result.contact("foot"))
    # element() reads any kind; a controller through it gives the controller's outputs, not {}
    assert set(leg_result.element("knee_servo")) == set(leg_result.controller("knee_servo")) >= {"output", "command"}


# ---------------------------------------------------------------------------------------------
# the table: controller outputs, units of joint elements, joint accelerations
# ---------------------------------------------------------------------------------------------
def test_to_frame_has_controller_outputs_with_units(leg_result):
    df = leg_result.to_frame()
    for servo in ("hip_servo", "knee_servo"):
        np.testing.assert_array_equal(df[f"{servo}.output [N m]"], leg_result.controller(servo).output)
        assert f"{servo}.command [N m]" in df.columns
    # the servo's held command is what its JointActuator applies (no drive, no limit)
    np.testing.assert_allclose(df["knee_servo.command [N m]"], df["knee_motor.effort [N m]"], rtol=0, atol=1e-12)
    assert np.ptp(df["knee_servo.output [N m]"]) > 1.0  # the landing moves the servo
    assert not [c for c in df.columns if "|" in c]  # "N m|N" resolved per joint


def test_joint_acceleration_columns(leg_result):
    df = leg_result.to_frame()
    for q in ("angle [rad]", "angular_velocity [rad/s]", "angular_acceleration [rad/s²]"):
        assert f"knee.{q}" in df.columns
    for q in ("translation [m]", "velocity [m/s]", "acceleration [m/s²]"):
        assert f"slider.{q}" in df.columns
    # the slider's I marker is on the body, J on ground along +z: its acceleration is the body's
    np.testing.assert_allclose(df["slider.acceleration [m/s²]"], leg_result.part("body").acceleration[:, 2], rtol=0, atol=1e-9)
    free = df["time [s]"] < 0.05  # the foot starts 30 mm up: free fall for 78 ms
    assert (df["foot.normal_force [N]"][free] == 0).all()
    np.testing.assert_allclose(df["slider.acceleration [m/s²]"][free], -G, atol=1e-9)
    jr = leg_result.joint("knee")
    np.testing.assert_array_equal(jr.angular_acceleration, df["knee.angular_acceleration [rad/s²]"])


def test_pendulum_joint_acceleration_closed_form():
    """θ̈ against −m g L sin φ / (I + m L²) at the output's own state, φ = th0 − θ, and against
    central differences of the rates (the ODE method's dense output is order 4, so with 1 ms
    outputs the difference is below 1e-4 of the peak)."""
    m, L, I, th0 = 1.0, 0.5, 1e-3, 1.0
    r = pl.simulate(pendulum(th0, m, L, I), 1.0, 1e-3)
    jr = r.joint("hinge")
    phi = th0 - jr.angle
    closed = m * G * L * np.sin(phi) / (I + m * L * L)  # = θ̈ (θ = −φ + th0)
    peak = np.max(np.abs(closed))
    assert peak > 10.0
    np.testing.assert_allclose(jr.angular_acceleration, closed, rtol=0, atol=1e-9 * peak)
    fd = np.gradient(jr.angular_velocity, r.t)
    np.testing.assert_allclose(fd[1:-1], jr.angular_acceleration[1:-1], rtol=0, atol=1e-4 * peak)
    df = r.to_frame()
    np.testing.assert_array_equal(df["hinge.angular_acceleration [rad/s²]"], jr.angular_acceleration)


def test_bead_on_turning_rod_translation_acceleration():
    """A bead slides freely on a rod that a motion turns at ω about z (gravity along z, so no
    load along the rod): ẍ = ω² r with r = r0 + x the bead's distance from the axis. The rod
    (J) turns, so this checks the ż_J and z̈_J terms of the translation's acceleration. The
    formula is exact for the stored velocities; rtol= picks Radau5, which holds the velocity
    constraints too (the index-3 α-method's velocities miss them by ~1e-4 m/s, ~4e-4 in ẍ)."""
    w, r0 = 3.0, 0.2
    model = pl.Model("bead", gravity=(0, 0, -G))
    rod = model.add_part("rod", mass=1.0, inertia=(0.01, 0.01, 0.01), position=(0.25, 0, 0), angular_velocity=(0, 0, w))
    bead = model.add_part("bead", mass=0.1, inertia=(1e-5, 1e-5, 1e-5), position=(r0, 0, 0), velocity=(0, w * r0, 0),
                          angular_velocity=(0, 0, w))
    spin = model.add_joint(pl.Revolute("spin", rod, model.ground, at=(0, 0, 0), axis=(0, 0, 1)))
    model.add_joint(pl.Prismatic("slide", bead, rod, at=(r0, 0, 0), axis=(1, 0, 0)))
    model.add_motion(pl.Motion("turn", spin, displacement=lambda t: w * t))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ProlegWarning)
        r = pl.simulate(pl.assemble(model), 0.3, 1e-3, rtol=1e-9)
    jr = r.joint("slide")
    x = jr.translation
    assert x[-1] > 0.01  # it slid out
    np.testing.assert_allclose(jr.acceleration, w * w * (r0 + x), rtol=1e-8, atol=0)
    # the motion's own coordinate: constant rate, no acceleration
    turn = r.joint("turn")
    np.testing.assert_allclose(turn.angular_velocity, w, rtol=1e-6)
    np.testing.assert_allclose(turn.angular_acceleration, 0.0, atol=1e-6 * w * w)


def test_peak_between_outputs_and_how_to_get_it(leg_result):
    """docs/guide/analyses.md "Peaks fall between outputs": the same run (same steps) sampled
    every 1 ms misses the touch-down peak of the ground force by more than 2 %; dense outputs
    in a window around it find it, and leave the 1 ms samples as they were."""
    coarse = leg_result.t
    times = np.union1d(coarse, np.arange(0.0774, 0.0794, 2e-6))
    fine = pl.simulate(leg(), 0.2, output_times=times)
    assert fine.stats["steps"] == leg_result.stats["steps"]
    F1, F2 = leg_result.contact("foot").normal_force, fine.contact("foot").normal_force
    np.testing.assert_allclose(F2[np.isin(fine.t, coarse)], F1, rtol=1e-9, atol=1e-9)
    assert F1.max() < 0.98 * F2.max()
    assert 0.0774 < fine.t[np.argmax(F2)] < 0.0794  # the touch-down peak, inside the window


@pytest.mark.slow
def test_joint_acceleration_on_a_flexible_part():
    """A joint marker on a flexible part moves with the modes: its acceleration comes from the
    compiled marker kinematics differentiated along (v, q̈). The pin's marker I sits on the
    frame node, so its angular acceleration is the floating frame's (NumPy, from q̈)."""
    from test_flexible_body import pendulum as flexible_pendulum
    from test_flexible_body import reduced_strip

    beam, rb, root, tip = reduced_strip(n_el=4, n_modes=1)
    r = pl.simulate(flexible_pendulum(rb, root, tip), 0.1, 1e-3, integrator=pl.GeneralizedAlpha(rtol=1e-8, atol=1e-10))
    jr = r.joint("pin")
    frame = r.part("link").angular_acceleration[:, 1]  # the pin's z_J is ground y
    assert np.max(np.abs(frame)) > 10.0
    np.testing.assert_allclose(jr.angular_acceleration, frame, rtol=0, atol=1e-9 * np.max(np.abs(frame)))
    assert "pin.angular_acceleration [rad/s²]" in r.to_frame().columns


# ---------------------------------------------------------------------------------------------
# plot: one axis per unit
# ---------------------------------------------------------------------------------------------
def test_plot_puts_each_unit_on_its_own_axis(leg_result):
    import matplotlib.pyplot as plt

    ax = leg_result.plot("body.z", "foot.force_z")
    axes = ax.figure.axes
    assert len(axes) == 2 and axes[0] is ax
    assert sorted(a.get_ylabel() for a in axes) == ["[N]", "[m]"]
    by_label = {a.get_ylabel(): [ln.get_label() for ln in a.lines] for a in axes}
    assert by_label == {"[m]": ["body.z [m]"], "[N]": ["foot.force_z [N]"]}
    # the shared time axis
    assert axes[0].get_shared_x_axes().joined(axes[0], axes[1])
    plt.close(ax.figure)
    # into the caller's axis: twin axes, one per unit
    fig, own = plt.subplots()
    out = leg_result.plot("body.z", "foot.force_z", "knee_servo.output", ax=own)
    assert out is own and len(fig.axes) == 3
    assert [a.get_ylabel() for a in fig.axes] == ["[m]", "[N]", "[N m]"]
    plt.close(fig)
    # one unit: one axis, as before
    ax = leg_result.plot("body.z", "thigh.z")
    assert len(ax.figure.axes) == 1 and len(ax.lines) == 2
    plt.close(ax.figure)


# ---------------------------------------------------------------------------------------------
# a contact that starts inside its plane warns once per run
# ---------------------------------------------------------------------------------------------
def ball(depth):
    """A 0.5 kg ball on a vertical slider, its sphere ``depth`` [m] inside the ground at t = 0."""
    model = pl.Model("ball", gravity=(0, 0, -G))
    z = 0.02 - depth
    b = model.add_part("ball", mass=0.5, inertia=(2e-4, 2e-4, 2e-4), position=(0, 0, z))
    model.add_joint(pl.Prismatic("slide", model.ground, b, at=(0, 0, z), axis=(0, 0, 1)))
    centre = model.add_marker(b, "centre", (0, 0, z))
    model.add_contact(pl.SphereContact("foot", centre, radius=0.02, stiffness=1e6, damping=50.0))
    return pl.assemble(model)


def test_buried_contact_warns_once_per_run():
    system = ball(0.002)  # 2 mm in the ground: 89 N at t = 0, 18× the weight
    with warnings.catch_warnings(record=True) as got:
        warnings.simplefilter("always")
        pl.simulate(system, 0.01, 1e-3)
    buried = [w for w in got if "inside its plane" in str(w.message)]
    assert len(buried) == 1 and "SphereContact 'foot'" in str(buried[0].message)
    # inside a batch (traced parameters) simulate's check is quiet: the sweep or study that
    # made the batch has checked before it (its own warning)
    import jax

    from proleg.analyses.checks import check_simulate

    def batch_check(c):
        check_simulate(system.with_params(contact_damping=c), {"t_end": 0.01, "dt_output": 1e-3})
        return c

    with warnings.catch_warnings(record=True) as got:
        warnings.simplefilter("always")
        jax.vmap(batch_check)(np.array([[50.0], [80.0]]))
    assert not [w for w in got if "inside its plane" in str(w.message)]


@pytest.mark.slow
def test_buried_contact_warns_once_per_sweep():
    """A sweep of two batches warns once (it was 1 + one per batch: three for two batches)."""
    system = ball(0.002)
    with warnings.catch_warnings(record=True) as got:
        warnings.simplefilter("always")
        pl.sweep(system, {"contact_damping": np.array([[50.0], [80.0]])}, 0.01, 1e-3, batch_size=1, workers=1)
    buried = [w for w in got if "inside its plane" in str(w.message)]
    assert len(buried) == 1 and str(buried[0].message).startswith("sweep:")
