"""Dense output (solvers/driver.py): steps are chosen by accuracy and by declared events, never
by the output times; outputs between steps come from the cubic Hermite interpolant of the step.

Models (small, one compilation each):

``pendulum``  a uniform rod (m = 2 kg, ℓ = 1 m) on a pin along ground y, released from 60°; run
    in absolute coordinates (7 per part) so that the Euler-parameter normalisation of the
    interpolated quaternions is exercised.
``servo``     the same rod, gravity off, pin along z, PID (kp = 62.5 N m/rad, kd = 0.75 N m s/rad)
    sampled every 1 ms with a 0.5 rad setpoint: its held command must change only at the ticks.
``step``      a block (2 kg) on a prismatic joint driven by x = STEP(t, 0.1, 0, 0.35, 0.05); the
    law's second derivative jumps at 0.1 and 0.35 s (``Motion(breakpoints=...)``).
"""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import proleg as pl

G, MASS, LENGTH = 9.81, 2.0, 1.0
D = LENGTH / 2
J_C = MASS * LENGTH**2 / 12
RTOL, ATOL = 1e-7, 1e-8
T_END = 0.3
# Two runs that read the same steps through different executables (other output grids, the scan
# or the free-running loop, vmap) agree to round-off, not bitwise: XLA may fuse and vectorise each
# program differently. Allowance: ~100 steps × ~10 flops of round-off each, 1000 eps × the scale
# (positions: ℓ = 1 m; velocities: ℓ sqrt(6 g/ℓ) ≈ 8 m/s bounds ω ℓ). A step that depended on
# the outputs would differ by the integration error, ~RTOL = 1e-7. Times: 16 eps × T_END.
EPS = np.finfo(float).eps
TOL_T, TOL_Q, TOL_V = 16 * EPS * T_END, 1000 * EPS * LENGTH, 1000 * EPS * np.sqrt(6 * G * LENGTH)


def q_rotated(theta):
    p = np.array([np.cos(theta / 2), 0.0, np.sin(theta / 2), 0.0])
    return np.concatenate([[-D * np.sin(theta), 0.0, -D * np.cos(theta)], p])


@pytest.fixture(scope="module")
def pendulum():
    model = pl.Model("dense_pendulum", gravity=(0, 0, -G))
    rod = model.add_part("rod", mass=MASS, inertia=(J_C, J_C, 1e-3), position=(0, 0, -D))
    model.add_joint(pl.Revolute("pin", model.ground, rod, at=(0, 0, 0), axis=(0, 1, 0)))
    return pl.assemble(model)


def run(system, dt_output, **kw):
    integrator = pl.GeneralizedAlpha(rtol=RTOL, atol=ATOL, **kw)
    return pl.simulate(system, t_end=T_END, dt_output=dt_output, integrator=integrator, q0=q_rotated(np.pi / 3), coordinates="absolute")


def test_steps_do_not_depend_on_the_output_times(pendulum):
    """Outputs every 0.1 ms and every 1 ms: the same steps, and at the common times the same
    states (both are read from the same steps' interpolants; round-off only)."""
    fine, coarse = run(pendulum, 1e-4), run(pendulum, 1e-3)
    assert fine.stats["steps"] == coarse.stats["steps"]
    assert len(fine.t) == 3001 and len(coarse.t) == 301
    np.testing.assert_allclose(fine.t[::10], coarse.t, rtol=0, atol=TOL_T)
    np.testing.assert_allclose(np.asarray(fine.q)[::10], np.asarray(coarse.q), rtol=0, atol=TOL_Q)
    np.testing.assert_allclose(np.asarray(fine.v)[::10], np.asarray(coarse.v), rtol=0, atol=TOL_V)
    # far fewer steps than outputs: the steps were not clipped to the 0.1 ms grid
    assert fine.stats["steps"] < 0.5 * len(fine.t)


def test_interpolation_adds_less_than_the_steps_own_error(pendulum):
    """Fixed 1 ms steps with outputs every 0.1 ms (nine in ten interpolated) against a run
    stepping at every output with 25 µs steps (a reference ~1600× more accurate, O(h²)): the
    error at the interpolated outputs is no larger than at the step ends themselves (the cubic
    Hermite's O(h⁴) error is below the method's O(h²) global error), and the interpolated Euler
    parameters are unit quaternions."""
    coarse = run(pendulum, 1e-4, fixed_step=1e-3)
    ref = run(pendulum, 1e-4, fixed_step=2.5e-5)
    assert coarse.stats["steps"] == 300 and ref.stats["steps"] == 12000
    e_q = np.max(np.abs(np.asarray(coarse.q)[:, :3] - np.asarray(ref.q)[:, :3]), axis=1)
    e_v = np.max(np.abs(np.asarray(coarse.v)[:, :3] - np.asarray(ref.v)[:, :3]), axis=1)
    at_steps = np.arange(len(coarse.t)) % 10 == 0
    assert e_q[at_steps].max() > 1e-8  # the step error is measurable (2nd order at 1 ms)
    assert e_q[~at_steps].max() < 1.2 * e_q[at_steps].max()
    assert e_v[~at_steps].max() < 1.2 * e_v[at_steps].max()
    # unit quaternions to the constraint tolerance (the projection solves p·p = 1 to first order)
    np.testing.assert_allclose(np.linalg.norm(np.asarray(coarse.q)[:, 3:7], axis=1), 1.0, rtol=0, atol=1e-12)


def test_interpolated_outputs_lie_on_the_constraints(pendulum):
    """Fixed 1 ms steps, outputs every 0.1 ms (nine in ten interpolated, ten per vectorised
    block): the interpolated positions are projected back onto the constraints with the step's
    Newton matrix. Measured max |Φ|: 3.3e-16 at the step ends; at the interpolated outputs 3.2e-10
    with the plain Hermite polynomial, 2.2e-13 after the projection (it contracts |Φ| by O(h)).
    The free-running loop gives the same outputs."""
    r = run(pendulum, 1e-4, fixed_step=1e-3)
    phi = r.constraint_residual()
    at_steps = np.arange(len(r.t)) % 10 == 0
    assert phi[at_steps].max() < TOL_Q  # Newton-converged: round-off (3.3e-16 measured)
    assert phi[~at_steps].max() < 2e-12  # 10× the projected level, 1/160 of the plain Hermite's
    free = pl.simulate(pendulum, t_end=T_END, dt_output=1e-4, integrator=pl.GeneralizedAlpha(rtol=RTOL, atol=ATOL, fixed_step=1e-3),
                       q0=q_rotated(np.pi / 3), coordinates="absolute", run=pl.RunOptions(free_running=True))
    np.testing.assert_allclose(np.asarray(free.q), np.asarray(r.q), rtol=0, atol=TOL_Q)
    np.testing.assert_allclose(np.asarray(free.v), np.asarray(r.v), rtol=0, atol=TOL_V)


def test_dense_output_under_vmap_and_jacfwd(pendulum):
    """Under jax.vmap, the scan and the free-running loops give the same outputs; jacfwd of an
    interpolated output with respect to the mass matches a central difference."""

    def height(m, free):
        s = pendulum.with_params({"rod.mass": m})
        r = pl.simulate(s, t_end=0.05, dt_output=3e-3, integrator=pl.GeneralizedAlpha(rtol=RTOL, atol=ATOL), q0=q_rotated(np.pi / 3),
                        coordinates="absolute", run=pl.RunOptions(free_running=free, progress=False))
        return r.q[:, 2]

    ms = jnp.array([1.5, 2.5])
    a = jax.vmap(lambda m: height(m, False))(ms)
    b = jax.vmap(lambda m: height(m, True))(ms)
    np.testing.assert_allclose(np.asarray(a), np.asarray(b), rtol=0, atol=TOL_Q)
    # a compound pendulum's motion is independent of its mass: the derivative is ~0, and so is
    # the central difference; both small against the height's own scale.
    d = jax.jacfwd(lambda m: height(m, False))(jnp.asarray(2.0))
    fd = (np.asarray(height(2.0 + 1e-4, False)) - np.asarray(height(2.0 - 1e-4, False))) / 2e-4
    np.testing.assert_allclose(np.asarray(d), fd, rtol=0, atol=1e-6)


def test_controller_command_changes_only_at_its_sample_times():
    """PID sampled every 1 ms, outputs every 0.1 ms: the held command is piecewise constant and
    changes exactly at the ticks (the output at a tick shows the new command): the sample is
    stepped to, never interpolated across."""
    model = pl.Model("dense_servo", gravity=(0, 0, 0))
    rod = model.add_part("rod", 0.3, (1e-5, 0.3 * 0.25 / 12, 0.3 * 0.25 / 12), (0.25, 0, 0))
    model.add_joint(pl.Revolute("pin", rod, model.ground, at=(0, 0, 0), axis=(0, 0, 1)))
    model.add_controller(pl.PID("servo", joint="pin", kp=62.5, kd=0.75, setpoint=0.5, period=1e-3))
    r = pl.simulate(pl.assemble(model), t_end=0.05, dt_output=1e-4, integrator=pl.GeneralizedAlpha(rtol=RTOL, atol=ATOL))
    u = r.controller("servo").output
    changed = np.flatnonzero(np.diff(u) != 0) + 1
    ticks = np.round(r.t[changed] / 1e-3)
    np.testing.assert_allclose(r.t[changed], ticks * 1e-3, rtol=0, atol=1e-12)
    assert len(changed) == 50  # a new command at every tick 1, 2, ... 50 ms (the servo keeps moving)


def test_motion_breakpoints_are_stepped_to():
    """STEP(t, 0.1, 0, 0.35, 0.05): with its breakpoints declared, the steps end at 0.1 and 0.35 s
    and the accelerations restart there (right limit), so the slider follows the cubic without
    the ringing that a step straddling a corner leaves in the velocities. Measured (outputs every
    0.1 ms, rtol 1e-9): velocity error 6.4e-6 m/s with the breakpoints, 7.7e-5 without; 779
    steps and 55 rejections against 891 and 84."""
    T0, T1, X1 = 0.1, 0.35, 0.05

    def block(breakpoints):
        model = pl.Model("dense_step", gravity=(0, -9.81, 0))
        b = model.add_part("block", 2.0, (1e-3, 1e-3, 1e-3), (0, 0, 0))
        model.add_joint(pl.Prismatic("rail", b, model.ground, at=(0, 0, 0), axis=(1, 0, 0)))
        model.add_motion(pl.Motion("lift", joint="rail", displacement=lambda t: pl.fn.step(t, T0, 0.0, T1, X1),
                                   breakpoints=breakpoints))
        r = pl.simulate(pl.assemble(model), t_end=0.45, dt_output=1e-4, integrator=pl.GeneralizedAlpha(rtol=1e-9, atol=1e-10))
        d = np.clip((r.t - T0) / (T1 - T0), 0, 1)
        e_x = np.max(np.abs(r.part("block").position[:, 0] - X1 * d**2 * (3 - 2 * d)))
        e_v = np.max(np.abs(r.part("block").velocity[:, 0] - X1 * 6 * d * (1 - d) / (T1 - T0)))
        return r, e_x, e_v

    r, e_x, e_v = block((T0, T1))
    assert e_x < 5e-10 and e_v < 1e-5
    f = r.motion("lift").effort
    jump = 6 * 2.0 * X1 / (T1 - T0) ** 2  # m ẍ just after t0
    i0 = np.searchsorted(r.t, T0 + 1e-9)
    assert f[i0] == pytest.approx(jump, rel=0.01)
    r_free, _, e_v_free = block(())
    assert e_v_free > 5 * e_v
    assert r.stats["rejected"] < r_free.stats["rejected"]


def test_breakpoints_are_validated():
    with pytest.raises(pl.ModelError, match="lift"):
        pl.Motion("lift", joint="rail", displacement=lambda t: t, breakpoints=("soon",))


@pytest.mark.slow  # two compilations of the HyQ leg's step loop (~1 min)
def test_hal_drop_outputs_do_not_depend_on_their_spacing():
    """The HyQ leg dropped on the HAL bench (seeds 000/001; bench/dense_output.py's model, 0.2 s,
    through the foot's impact at ~0.11 s), outputs every 1 ms and every 0.1 ms (ten per step,
    evaluated in vectorised blocks): the same steps, and at the common times the same states,
    both being read from the same steps' interpolants (round-off only)."""
    system = pl.assemble(pl.robots.hyq_leg(joints="rigid", gain="high", drop_height=0.05, actuators="drop"))
    integ = pl.GeneralizedAlpha(rtol=1e-6, atol=1e-7, dt_max=1e-3)
    coarse, fine = (pl.simulate(system, t_end=0.2, dt_output=dt, integrator=integ, run=pl.RunOptions(prepare_outputs=False))
                    for dt in (1e-3, 1e-4))
    assert fine.stats["steps"] == coarse.stats["steps"] and len(fine.t) == 2001
    # round-off as above, with the scale of the leg (~1 m; 1e-12 m ≈ 4500 eps) and its speeds
    np.testing.assert_allclose(fine.t[::10], coarse.t, rtol=0, atol=16 * EPS * 0.2)
    np.testing.assert_allclose(np.asarray(fine.q)[::10], np.asarray(coarse.q), rtol=0, atol=1e-12)
    np.testing.assert_allclose(np.asarray(fine.v)[::10], np.asarray(coarse.v), rtol=0, atol=1e-10)
    np.testing.assert_allclose(np.asarray(fine.w)[::10], np.asarray(coarse.w), rtol=1e-12, atol=1e-12)
