"""Every bad input is a proleg error naming the element, parameter or file; every legal but
suspicious one a ProlegWarning (issue 22).

Each case feeds one mistake a robot designer makes to the public API and asserts the documented
class (ModelError, DataError, ConvergenceError) or warning (ProlegWarning, made an error here so
that a warned run stops before computing) and that the message names what is wrong. A bare
TypeError, IndexError, KeyError, LinAlgError, tracer or broadcasting error fails the test: none of
them is a subclass of the classes asserted.
"""

import math
import warnings

import numpy as np
import pytest

import proleg as pl
from proleg.analyses.result import Result


def pendulum(name="pend"):
    m = pl.Model(name)
    rod = m.add_part("rod", 1.0, (1e-3, 1e-2, 1e-2), (0.5, 0, 0))
    m.add_joint(pl.Revolute("hinge", rod, m.ground, at=(0, 0, 0), axis=(0, 1, 0)))
    return m


def ball(stiffness=1e6):
    m = pl.Model("ball")
    b = m.add_part("ball", 1.0, (1e-4, 1e-4, 1e-4), (0, 0, 0.03))
    c = m.add_marker(b, "centre", (0, 0, 0.03))
    m.add_contact(pl.SphereContact("foot", c, radius=0.02, stiffness=stiffness))
    return m


def _rod_ground():
    m = pendulum()
    return m.part("rod"), m.ground


def _markers(m):
    rod = m.part("rod")
    return m.add_marker(rod, "mi", (1.0, 0, 0)), m.add_marker(m.ground, "mj", (1.0, 0, 1.0))


@pytest.fixture(scope="module")
def system():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return pl.assemble(pendulum())


@pytest.fixture(scope="module")
def result(system):
    """The modelled state as a one-sample Result (no integration needed for the output checks)."""
    import jax.numpy as jnp

    q, v = system.params["q_init"], system.params["v_init"]
    return Result(system, np.array([0.0]), q[None], v[None], jnp.zeros((1, 2)), jnp.zeros((1, 0)))


def motion(fn):
    m = pendulum()
    m.add_motion(pl.Motion("drive", m.joint("hinge"), displacement=fn))
    return pl.assemble(m)


def force(fn):
    m = pendulum()
    m.add_force(pl.Force("push", m.part("rod"), fn))
    return pl.assemble(m)


def pid_model(**kw):
    m = pendulum()
    m.add_controller(pl.PID("servo", m.joint("hinge"), **{"kp": 10.0, **kw}))
    return pl.assemble(m)


def locked():
    m = pendulum()
    m.add_joint(pl.Fixed("weld", m.part("rod"), m.ground, at=(0.5, 0, 0)))
    return pl.assemble(m)


def loose():
    m = pendulum()
    m.add_part("loose", 1.0, (1, 1, 1), (2, 0, 0))
    return pl.assemble(m)


def violated():
    m = pl.Model("bad_pose")
    rod = m.add_part("rod", 1.0, (1e-3, 1e-2, 1e-2), (0.5, 0, 0))
    i = m.add_marker(rod, "pin_i", (0.0, 0, 0))
    j = m.add_marker(m.ground, "pin_j", (0.0, 0, 0.05))  # 5 cm from where the rod's pin is
    m.add_joint(pl.Spherical("hinge", i, j))
    return pl.assemble(m)


def contradictory():
    """A rod 1 m long between two ground pins 3 m apart: the violated equation is redundant."""
    m = pl.Model("stretched")
    rod = m.add_part("rod", 1.0, (1e-3, 1e-2, 1e-2), (0.5, 0, 0))
    m.add_joint(pl.Spherical("left", m.add_marker(rod, "a", (0, 0, 0)), m.add_marker(m.ground, "ga", (0, 0, 0))))
    m.add_joint(pl.Spherical("right", m.add_marker(rod, "b", (1, 0, 0)), m.add_marker(m.ground, "gb", (3, 0, 0))))
    return pl.assemble(m)


def slider():
    """A block on a vertical prismatic joint with nothing to hold it: no static equilibrium."""
    m = pl.Model("slider")
    b = m.add_part("block", 1.0, (1, 1, 1), (0, 0, 1))
    m.add_joint(pl.Prismatic("slide", b, m.ground, at=(0, 0, 1), axis=(0, 0, 1)))
    return pl.solve_equilibrium(pl.assemble(m), max_iter=20)


def unwritable(tmp_path):
    """A target no one can create, root included: its folder 'ro' is a file."""
    (tmp_path / "ro").write_text("")
    return tmp_path / "ro" / "out.parquet"


def quiet(fn):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return fn()


M = pl.ModelError
W = pl.ProlegWarning
# (id, call(system, result, tmp_path), expected class, regex the message must match)
CASES = [
    # -- parts and markers (constructors) ------------------------------------------------------
    ("mass_zero", lambda s, r, p: pendulum().add_part("thigh", 0.0, (1, 1, 1), (0, 0, 0)), M, "'thigh'.*mass"),
    ("mass_negative", lambda s, r, p: pendulum().add_part("thigh", -1.0, (1, 1, 1), (0, 0, 0)), M, "'thigh'.*mass"),
    ("mass_nan", lambda s, r, p: pendulum().add_part("thigh", math.nan, (1, 1, 1), (0, 0, 0)), M, "'thigh'"),
    ("mass_string", lambda s, r, p: pendulum().add_part("thigh", "heavy", (1, 1, 1), (0, 0, 0)), M, "'thigh'"),
    ("inertia_shape", lambda s, r, p: pendulum().add_part("thigh", 1.0, (1, 1), (0, 0, 0)), M, "'thigh' inertia.*shape"),
    ("inertia_not_pd", lambda s, r, p: pendulum().add_part("thigh", 1.0, (1, 0, 1), (0, 0, 0)), M, "'thigh'.*positive definite"),
    ("inertia_triangle", lambda s, r, p: pendulum().add_part("thigh", 1.0, (1, 1, 3), (0, 0, 0)), M, "'thigh'.*triangle"),
    ("position_nan", lambda s, r, p: pendulum().add_part("thigh", 1.0, (1, 1, 1), (0, math.nan, 0)), M, "'thigh'.*position"),
    ("position_shape", lambda s, r, p: pendulum().add_part("thigh", 1.0, (1, 1, 1), (0, 0)), M, "'thigh'.*position"),
    ("orientation_not_rotation", lambda s, r, p: pendulum().add_part("thigh", 1.0, (1, 1, 1), (0, 0, 0), orientation=2 * np.eye(3)), M, "'thigh'.*rotation"),
    ("quaternion_not_unit", lambda s, r, p: pendulum().add_part("thigh", 1.0, (1, 1, 1), (0, 0, 0), orientation=(2, 0, 0, 0)), M, "'thigh'.*quaternion"),
    ("duplicate_part", lambda s, r, p: pendulum().add_part("rod", 1.0, (1, 1, 1), (0, 0, 0)), M, "'rod'.*twice"),
    ("part_named_ground", lambda s, r, p: pendulum().add_part("ground", 1.0, (1, 1, 1), (0, 0, 0)), M, "'ground'.*reserved"),
    ("marker_foreign_part", lambda s, r, p: pendulum().add_marker(pendulum("other").part("rod"), "m", (0, 0, 0)), M, "'rod'.*not in model"),
    # -- joints ------------------------------------------------------------------------------
    ("revolute_zero_axis", lambda s, r, p: pl.Revolute("knee", *_rod_ground(), at=(0, 0, 0), axis=(0, 0, 0)), M, "'knee'.*axis"),
    ("revolute_no_axis", lambda s, r, p: pl.Revolute("knee", *_rod_ground(), at=(0, 0, 0)), M, "'knee'.*axis"),
    ("screw_zero_pitch", lambda s, r, p: pl.Screw("lead", *_rod_ground(), at=(0, 0, 0), axis=(0, 0, 1), pitch=0.0), M, "'lead'.*pitch"),
    ("universal_not_perpendicular", lambda s, r, p: pl.Universal("cross", *_rod_ground(), at=(0, 0, 0), axis_i=(1, 0, 0), axis_j=(1, 0, 0)), M, "'cross'.*perpendicular"),
    ("add_joint_not_a_joint", lambda s, r, p: pendulum().add_joint("hinge"), M, "add_joint"),
    # -- force elements ------------------------------------------------------------------------
    ("spring_negative_stiffness", lambda s, r, p: pl.SpringDamper("leg_spring", *_markers(pendulum()), stiffness=-1.0), M, "'leg_spring' stiffness"),
    ("spring_nan_damping", lambda s, r, p: pl.SpringDamper("leg_spring", *_markers(pendulum()), damping=math.nan), M, "'leg_spring' damping"),
    ("spring_coincident_markers", lambda s, r, p: (lambda m: pl.SpringDamper("leg_spring", m.add_marker(m.part("rod"), "a", (0, 0, 0)), m.add_marker(m.ground, "b", (0, 0, 0))))(pendulum()), M, "'leg_spring'.*coincide"),
    ("spring_not_a_marker", lambda s, r, p: pl.SpringDamper("leg_spring", "mi", "mj"), M, "'leg_spring'.*Marker"),
    ("bushing_stiffness_shape", lambda s, r, p: pl.Bushing("pin", *_markers(pendulum()), stiffness=(1, 2, 3)), M, "'pin' stiffness.*shape"),
    ("bushing_negative", lambda s, r, p: pl.Bushing("pin", *_markers(pendulum()), stiffness=(1, 1, 1, 1, 1, -1)), M, "'pin' stiffness.*negative"),
    ("bushing_preload_shape", lambda s, r, p: pl.Bushing("pin", *_markers(pendulum()), stiffness=np.ones(6), preload=(1, 2)), M, "'pin' preload"),
    ("force_value_shape", lambda s, r, p: pl.Force("push", pendulum().part("rod"), (1.0, 2.0)), M, "'push' value"),
    # -- contacts ------------------------------------------------------------------------------
    ("contact_negative_stiffness", lambda s, r, p: pl.SphereContact("toe", _markers(pendulum())[0], stiffness=-1e6), M, "'toe' stiffness"),
    ("contact_exponent_below_one", lambda s, r, p: pl.SphereContact("toe", _markers(pendulum())[0], exponent=0.5), M, "'toe' exponent"),
    ("contact_mu_order", lambda s, r, p: pl.SphereContact("toe", _markers(pendulum())[0], mu_static=0.3, mu_dynamic=0.5), M, "'toe'.*mu_dynamic"),
    ("contact_velocity_order", lambda s, r, p: pl.SphereContact("toe", _markers(pendulum())[0], v_stiction=0.1, v_friction=0.01), M, "'toe'.*v_stiction"),
    ("contact_negative_radius", lambda s, r, p: pl.SphereContact("toe", _markers(pendulum())[0], radius=-0.01), M, "'toe' radius"),
    # -- motions, controllers, couplers, variables -----------------------------------------------
    ("motion_two_functions", lambda s, r, p: pl.Motion("drive", None, displacement=np.sin, velocity=np.cos), M, "'drive'.*exactly one"),
    ("motion_not_callable", lambda s, r, p: pl.Motion("drive", None, displacement=0.3), M, "'drive'.*function of time"),
    ("motion_on_spherical", lambda s, r, p: (lambda m: m.add_motion(pl.Motion("drive", m.add_joint(pl.Spherical("ball_joint", m.part("rod"), m.ground, at=(1, 0, 0))), displacement=lambda t: t)))(pendulum()), M, "'drive'.*ball_joint"),
    ("pid_period_zero", lambda s, r, p: pl.PID("servo", None, kp=1.0, period=0.0), M, "'servo'.*period"),
    ("pid_kp_nan", lambda s, r, p: pl.PID("servo", None, kp=math.nan), M, "'servo' kp"),
    ("pid_lever_arm_zero", lambda s, r, p: pl.PID("servo", None, kp=1.0, lever_arm=0.0), M, "'servo'.*lever_arm"),
    ("coupler_ratio_zero", lambda s, r, p: pl.Coupler("belt", None, None, ratio=0.0), M, "'belt'.*ratio"),
    ("joint_stop_order", lambda s, r, p: pl.JointStop("limit", pendulum().joint("hinge"), lower=1.0, upper=-1.0), M, "'limit'.*lower"),
    ("variable_bad_name", lambda s, r, p: pendulum().add_variable("leg length", 1.0), M, "leg length"),
    # -- assembly: functions JAX cannot trace, topology ------------------------------------------
    ("motion_math_sin", lambda s, r, p: motion(lambda t: math.sin(t)), M, "Motion 'drive'.*jax.numpy"),
    ("motion_if_on_t", lambda s, r, p: motion(lambda t: 0.1 if t > 1.0 else 0.0), M, "Motion 'drive'.*jnp.where"),
    ("motion_returns_vector", lambda s, r, p: motion(lambda t: t * np.ones(3)), M, "Motion 'drive'.*shape"),
    ("force_float_of_t", lambda s, r, p: force(lambda t: (float(t), 0.0, 0.0)), M, "Force 'push'.*jax.numpy"),
    ("force_wrong_shape", lambda s, r, p: force(lambda t: t * np.ones(2)), M, "Force 'push'.*shape"),
    ("pid_setpoint_math", lambda s, r, p: pid_model(setpoint=lambda t: math.cos(t)), M, "PID 'servo'.*setpoint.*jax.numpy"),
    ("assemble_not_a_model", lambda s, r, p: pl.assemble("leg.yaml"), M, "proleg.Model"),
    ("assemble_no_parts", lambda s, r, p: pl.assemble(pl.Model("empty")), M, "'empty'.*no parts"),
    # -- legal but suspicious: warnings ----------------------------------------------------------
    ("pid_negative_kp", lambda s, r, p: pl.PID("servo", None, kp=-10.0), W, "'servo'.*kp = -10"),
    ("pid_negative_kd", lambda s, r, p: pl.PID("servo", None, kp=10.0, kd=-1.0), W, "'servo'.*kd = -1"),
    ("locked_mechanism", lambda s, r, p: locked(), W, "'pend' has 0 degrees of freedom"),
    ("part_attached_to_nothing", lambda s, r, p: loose(), W, r"\['loose'\].*attached to nothing"),
    ("joints_contradict", lambda s, r, p: contradictory(), W, r"'right' \(dx\) by 2 .*redundant.*never enforced"),
    ("pose_violates_joint", lambda s, r, p: violated(), W, "'hinge'.*0.05"),
    ("contact_stiffness_1e20", lambda s, r, p: pl.simulate(pl.assemble(ball(1e20)), 0.01), W, "'foot' stiffness 1e\\+20"),
    ("dt_output_above_t_end", lambda s, r, p: pl.simulate(s, 0.01, 0.1), W, "dt_output = 0.1 s is longer"),
    ("plot_name_matches_nothing", lambda s, r, p: r.plot("hinge.Fq"), W, "'hinge.Fq' matches no output"),
    # -- with_params -----------------------------------------------------------------------------
    ("with_params_unknown", lambda s, r, p: s.with_params({"rod.weight": 2.0}), M, "'rod.weight'"),
    ("with_params_array_shape", lambda s, r, p: s.with_params(body_mass=np.ones(3)), M, r"'body_mass'.*\(1,\)"),
    ("with_params_element_shape", lambda s, r, p: s.with_params({"rod.mass": np.ones(3)}), M, r"'rod.mass'.*\(3,\)"),
    ("with_params_nan", lambda s, r, p: s.with_params({"rod.mass": math.nan}), M, "'rod.mass'.*NaN"),
    ("with_params_string", lambda s, r, p: s.with_params({"rod.mass": "two"}), M, "'rod.mass'.*numeric"),
    # -- simulate's arguments ----------------------------------------------------------------------
    ("t_end_negative", lambda s, r, p: pl.simulate(s, -1.0), M, "t_end = -1"),
    ("t_end_nan", lambda s, r, p: pl.simulate(s, math.nan), M, "t_end = nan"),
    ("t_end_inf", lambda s, r, p: pl.simulate(s, math.inf), M, "t_end = inf"),
    ("t_end_string", lambda s, r, p: pl.simulate(s, "1.0"), M, "t_end must be a number"),
    ("t_end_equals_t0", lambda s, r, p: pl.simulate(s, 0.5, t0=0.5), M, "t_end = 0.5 s must be greater than t0"),
    ("dt_output_zero", lambda s, r, p: pl.simulate(s, 0.1, 0.0), M, "dt_output must be positive"),
    ("dt_output_negative", lambda s, r, p: pl.simulate(s, 0.1, -0.01), M, "dt_output must be positive"),
    ("dt_output_nan", lambda s, r, p: pl.simulate(s, 0.1, math.nan), M, "dt_output = nan"),
    ("rtol_zero", lambda s, r, p: pl.simulate(s, 0.1, integrator=pl.GeneralizedAlpha(rtol=0.0)), M, "rtol must be positive"),
    ("rtol_negative", lambda s, r, p: pl.simulate(s, 0.1, integrator=pl.GeneralizedAlpha(rtol=-1e-6)), M, "rtol must be positive"),
    ("atol_nan", lambda s, r, p: pl.simulate(s, 0.1, integrator=pl.GeneralizedAlpha(atol=math.nan)), M, "atol must be positive, got nan"),
    ("dt_min_above_dt_max", lambda s, r, p: pl.simulate(s, 0.1, integrator=pl.GeneralizedAlpha(dt_min=1e-2, dt_max=1e-3)), M, "dt_min = 0.01 s is above dt_max"),
    ("fixed_step_zero", lambda s, r, p: pl.simulate(s, 0.1, integrator=pl.GeneralizedAlpha(fixed_step=0.0)), M, "fixed_step must be positive"),
    ("max_newton_zero", lambda s, r, p: pl.simulate(s, 0.1, integrator=pl.GeneralizedAlpha(max_newton=0)), M, "max_newton"),
    ("chunk_float", lambda s, r, p: pl.simulate(s, 0.1, run=pl.RunOptions(chunk=2.5)), M, "chunk"),
    ("q0_wrong_length", lambda s, r, p: pl.simulate(s, 0.1, q0=np.zeros(3)), M, r"q0 has shape \(3,\); expected \(7,\)"),
    ("v0_wrong_length", lambda s, r, p: pl.simulate(s, 0.1, v0=np.zeros(8)), M, r"v0 has shape \(8,\)"),
    ("q0_nan", lambda s, r, p: pl.simulate(s, 0.1, q0=np.full(7, math.nan)), M, r"q0\[0\] is nan.*'rod'"),
    ("output_times_decreasing", lambda s, r, p: pl.simulate(s, 0.1, output_times=[0.0, 0.2, 0.1]), M, "output_times must be strictly increasing"),
    ("output_times_2d", lambda s, r, p: pl.simulate(s, 0.1, output_times=np.zeros((2, 2))), M, "output_times.*1-D"),
    ("output_times_nan", lambda s, r, p: pl.simulate(s, 0.1, output_times=[0.0, math.nan]), M, "output_times.*NaN"),
    ("simulate_a_model", lambda s, r, p: pl.simulate(pendulum(), 0.1), M, "proleg.assemble"),
    ("store_unwritable", lambda s, r, p: pl.simulate(s, 0.1, store=unwritable(p)), pl.DataError, "cannot write.*/ro' is a file"),
    # -- linearize, statics ---------------------------------------------------------------------
    ("linearize_state_shape", lambda s, r, p: pl.linearize(s, np.zeros(3)), M, r"linearize: state has shape \(3,\)"),
    ("linearize_t_nan", lambda s, r, p: pl.linearize(s, t=math.nan), M, "linearize: t = nan"),
    ("equilibrium_tol_zero", lambda s, r, p: pl.solve_equilibrium(s, tol=0.0), M, "tol must be positive"),
    ("equilibrium_max_iter_zero", lambda s, r, p: pl.solve_equilibrium(s, max_iter=0), M, "max_iter"),
    ("equilibrium_guess_shape", lambda s, r, p: pl.solve_equilibrium(s, np.zeros(5)), M, r"q_guess has shape \(5,\)"),
    ("equilibrium_loose_part", lambda s, r, p: pl.solve_equilibrium(quiet(loose)), M, "'loose'.*connected to nothing"),
    ("equilibrium_none_exists", lambda s, r, p: slider(), pl.ConvergenceError, "'slider'.*no equilibrium.*part 'block'"),
    # -- sweeps ----------------------------------------------------------------------------------
    ("sweep_negative_mass", lambda s, r, p: pl.sweep(s, {"rod.mass": [1.0, -1.0]}, 0.1), M, "variant 1: 'rod.mass'.*positive"),
    ("sweep_inertia_not_pd", lambda s, r, p: pl.sweep(s, {"rod.inertia": [np.diag([1e-3, 1e-2, 1e-2]), np.diag([1e-3, -1e-2, 1e-2])]}, 0.1), M, "variant 1: 'rod.inertia'.*positive definite"),
    ("sweep_lengths_differ", lambda s, r, p: pl.sweep(s, {"rod.mass": [1.0, 2.0], "gravity": np.zeros((3, 3))}, 0.1), M, "'gravity' has 3 values"),
    ("sweep_nan", lambda s, r, p: pl.sweep(s, {"rod.mass": [1.0, math.nan]}, 0.1), M, "'rod.mass' has NaN"),
    ("sweep_unknown", lambda s, r, p: pl.sweep(s, {"rod.weight": [1.0, 2.0]}, 0.1), M, "'rod.weight'"),
    ("sweep_t_end_negative", lambda s, r, p: pl.sweep(s, {"rod.mass": [1.0, 2.0]}, -0.1), M, "sweep: t_end = -0.1"),
    # -- results and files -------------------------------------------------------------------------
    ("to_parquet_read_only", lambda s, r, p: r.to_parquet(unwritable(p)), pl.DataError, "to_parquet: cannot write to '.*ro/out.parquet'.*/ro' is a file"),
    ("to_parquet_onto_folder", lambda s, r, p: r.to_parquet(p), pl.DataError, "is a folder"),
    ("result_unknown_part", lambda s, r, p: r.part("shin"), M, "'shin'"),
    ("result_unknown_joint", lambda s, r, p: r.joint("knee"), M, "'knee'"),
]


def test_at_least_sixty_cases():
    assert len(CASES) >= 60


@pytest.mark.parametrize("call, cls, match", [c[1:] for c in CASES], ids=[c[0] for c in CASES])
def test_bad_input(system, result, tmp_path, call, cls, match):
    with warnings.catch_warnings():
        # A ProlegWarning becomes an exception (the run stops before computing); other warnings
        # of a case (redundant rows of the locked model, ...) are not what is tested here.
        warnings.simplefilter("ignore")
        warnings.simplefilter("error", pl.ProlegWarning)
        with pytest.raises(cls, match=match) as exc:
            call(system, result, tmp_path)
    assert type(exc.value) is cls or cls is W and isinstance(exc.value, W)
