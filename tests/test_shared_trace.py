"""One trace per model structure (issue 42): a new design is a new argument, not a new compile.

Two assemblies of one structure with other numbers share their compiled functions once the
compile cache has checked that tracing reads none of the numbers (proleg.compile_cache,
``CachedJit._shared``); the answers are those of a compile of their own, to round-off. A number
a trace does read, and a change of structure, still compile anew and give the right answer.
"""

from __future__ import annotations

import warnings

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import proleg as pl
import proleg.compile_cache as cc
from proleg.analyses.structure import numbers_read, same_structure, structure_summary

#: a run and the same run compiled apart execute the same operations on the same numbers; the
#: executables may still differ in XLA's fusion decisions, so allow round-off of the state's size
#: over the run's steps (2 s, ~10^3 steps of O(1) m)
RTOL = 1e-12


def readme_pendulum(length=1.0, links=2):
    """The README's double pendulum with its upper link ``length`` [m] long (``links=3`` adds a
    third link: another structure)."""
    model = pl.Model("double_pendulum", gravity=(0.0, 0.0, -9.81))
    upper = model.add_part("upper", mass=1.0, inertia=(0.01, 0.09, 0.09), position=(length / 2, 0, 0))
    lower = model.add_part("lower", mass=1.0, inertia=(0.01, 0.09, 0.09), position=(length + 0.5, 0, 0))
    model.add_joint(pl.Revolute("shoulder", model.ground, upper, at=(0, 0, 0), axis=(0, 1, 0)))
    model.add_joint(pl.Revolute("elbow", upper, lower, at=(length, 0, 0), axis=(0, 1, 0)))
    last, end = lower, length + 1.0
    if links == 3:
        last = model.add_part("third", mass=0.5, inertia=(0.01, 0.04, 0.04), position=(end + 0.5, 0, 0))
        model.add_joint(pl.Revolute("wrist", lower, last, at=(end, 0, 0), axis=(0, 1, 0)))
        end += 1.0
    tip, anchor = model.add_marker(last, "tip", (end, 0, 0)), model.add_marker(model.ground, "anchor", (2, 0, -1))
    model.add_force(pl.SpringDamper("spring", tip, anchor, stiffness=50.0, damping=0.5, free_length=1.0))
    return model


def _run(model):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return pl.simulate(pl.assemble(model), t_end=0.5, dt_output=0.01, progress=False)


@pytest.fixture
def cache(tmp_path, monkeypatch):
    """A fresh on-disk cache, this process's compiled functions and verdicts dropped."""
    monkeypatch.setenv("PROLEG_CACHE_DIR", str(tmp_path))
    cc.clear()
    cc._Verdicts.memo.clear()
    yield tmp_path
    cc.clear()
    cc._Verdicts.memo.clear()


def _alone(model, monkeypatch):
    """``model`` run with sharing off (a compile of its own)."""
    with monkeypatch.context() as m:
        m.setenv("PROLEG_SHARE_STRUCTURES", "0")
        cc.clear()
        return _run(model)


def test_new_link_lengths_share_one_trace_and_give_their_own_answers(cache, monkeypatch):
    """The README pendulum with four upper-link lengths: the first compiles, the second decides
    (traced as it is and perturbed, no new export), the third and fourth trace nothing; each
    answer equals a compile of its own, and differs from the others (the length is used)."""
    lengths = (1.0, 1.1, 1.2, 1.3)
    runs, exported = [], []
    for L in lengths:
        runs.append(_run(readme_pendulum(L)))
        exported.append(cc.stats["exported"])
    assert exported[2] == exported[1] == exported[3], "a third and fourth length traced again"
    assert cc.stats["shared"] >= 2 * 4  # every function of the last two runs shared
    ends = [np.asarray(r.part("lower").position[-1]) for r in runs]
    assert min(np.linalg.norm(a - b) for i, a in enumerate(ends) for b in ends[i + 1:]) > 1e-3
    for L, end in zip(lengths[2:], ends[2:]):
        ref = np.asarray(_alone(readme_pendulum(L), monkeypatch).part("lower").position[-1])
        np.testing.assert_allclose(end, ref, rtol=RTOL, atol=RTOL)


def test_a_structural_change_compiles_anew_and_is_right(cache, monkeypatch):
    """A third link is another structure: it is compiled for itself (new exports, no sharing
    with the two-link model) and its answer is that of a compile of its own."""
    for L in (1.0, 1.1, 1.2):
        _run(readme_pendulum(L))
    before = cc.stats["exported"]
    three = _run(readme_pendulum(1.0, links=3))
    assert cc.stats["exported"] > before
    assert not same_structure(pl.assemble(readme_pendulum(1.0)), pl.assemble(readme_pendulum(1.0, links=3)))
    ref = _alone(readme_pendulum(1.0, links=3), monkeypatch)
    np.testing.assert_allclose(three.part("third").position[-1], ref.part("third").position[-1], rtol=RTOL, atol=RTOL)


# -- the guard: a number a trace reads is found, and then nothing is shared ---------------------
class Holder:
    """A topology-like static object whose numbers are model data (``_numbers_are_data``)."""

    _numbers_are_data = True

    def __init__(self, gain, offset):
        self.gain, self.offset = gain, offset


@jax.tree_util.register_pytree_node_class
class Box:
    def __init__(self, x, holder):
        self.x, self.holder = x, holder

    def tree_flatten(self):
        return (self.x,), self.holder

    @classmethod
    def tree_unflatten(cls, holder, kids):
        return cls(kids[0], holder)


@cc.cached_jit
def _reads_gain(box):
    return box.x * box.holder.gain  # reads a number of the static object: must not be shared


@cc.cached_jit
def _reads_sign(box):
    return jnp.sin(box.x) if box.holder.offset > 0 else jnp.cos(box.x)  # a branch on a number


@cc.cached_jit
def _reads_nothing(box):
    return 2.0 * box.x


@pytest.mark.parametrize("fn, expected", [
    (_reads_gain, lambda x, h: x * h.gain),
    (_reads_sign, lambda x, h: np.sin(x) if h.offset > 0 else np.cos(x)),
])
def test_a_number_the_trace_reads_is_found_and_never_shared(cache, fn, expected):
    """Every holder gets its own answer, however many share the structure: the check finds the
    constant (gain) and the branch (sign of offset) and keeps each model's own compile."""
    x = jnp.linspace(0.0, 1.0, 5)
    holders = [Holder(g, o) for g, o in ((2.0, 1.0), (3.0, 1.0), (5.0, -1.0), (7.0, 2.0))]
    assert cc.reads_numbers(fn, Box(x, holders[0]))
    shared = cc.stats["shared"]
    for h in holders:
        np.testing.assert_allclose(fn(Box(x, h)), expected(np.asarray(x), h), rtol=1e-15)
    assert cc.stats["shared"] == shared


def test_a_trace_that_reads_no_number_is_shared(cache):
    x = jnp.linspace(0.0, 1.0, 5)
    assert cc.reads_numbers(_reads_nothing, Box(x, Holder(2.0, 1.0))) == ""
    shared, exported = cc.stats["shared"], cc.stats["exported"]
    for g in (2.0, 3.0, 4.0, 5.0):
        np.testing.assert_allclose(_reads_nothing(Box(x, Holder(g, g))), 2.0 * np.asarray(x), rtol=1e-15)
    assert cc.stats["shared"] - shared >= 2 and cc.stats["exported"] - exported == 1


# -- builders: two designs of one robot are one structure, and their physics reads only params ---
def _hyq_trot(**kw):
    from proleg.robots.hyq_trot import hyq_trot_model

    return hyq_trot_model(**kw)


BUILDERS = {
    "readme pendulum": (lambda: readme_pendulum(1.0), lambda: readme_pendulum(1.25)),
    "hyq_leg rigid": (lambda: pl.robots.hyq_leg("rigid"),
                      lambda: pl.robots.hyq_leg("rigid", cylinder_length=0.31, kp=250.0, foot_stiffness=3e5, hip_angle=-0.6)),
    "hyq_leg bushings8": (lambda: pl.robots.hyq_leg("bushings8"),
                          lambda: pl.robots.hyq_leg("bushings8", cylinder_length=0.31, bushing_stiffness=2e7, kd=8.0)),
    "flegx": (lambda: pl.robots.flegx(), lambda: pl.robots.flegx(stand=(-0.45, 1.0), contact_stiffness=2e5)),
}
SLOW_BUILDERS = {
    "hyq (URDF)": (lambda: pl.robots.hyq(drop=0.05), lambda: pl.robots.hyq(drop=0.06, kp=250.0)),
    "hyq trot, torque sources": (lambda: _hyq_trot(speed=1.0, actuators="torque"), lambda: _hyq_trot(speed=0.8, actuators="torque")),
}


def _check_builder(a, b):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sa, sb = pl.assemble(a()), pl.assemble(b())
    assert same_structure(sa, sb), structure_summary(sa)
    assert numbers_read(sa) == {}
    assert any(not np.array_equal(np.asarray(sa.params[k]), np.asarray(sb.params[k])) for k in sa.params)


@pytest.mark.parametrize("name", sorted(BUILDERS))
def test_two_designs_of_a_builder_share_a_trace(name):
    _check_builder(*BUILDERS[name])


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(SLOW_BUILDERS))
def test_two_designs_of_a_whole_robot_share_a_trace(name):
    _check_builder(*SLOW_BUILDERS[name])


def test_a_urdf_robot_with_other_link_lengths_and_masses_shares_a_trace(tmp_path):
    """A URDF's numbers (joint origins, masses, inertias) are data: two files that differ only
    in them are one structure."""
    def urdf(length, mass):
        return f"""<robot name="arm">
  <link name="base"><inertial><mass value="2"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="link"><inertial><origin xyz="0 0 {-length / 2}"/><mass value="{mass}"/>
    <inertia ixx="0.02" iyy="0.02" izz="0.001" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="j" type="revolute"><parent link="base"/><child link="link"/><origin xyz="0 0 {length}"/>
    <axis xyz="0 1 0"/><limit lower="-3" upper="3" effort="10" velocity="10"/></joint>
</robot>"""
    paths = []
    for k, (L, m) in enumerate(((0.3, 1.0), (0.35, 1.2))):
        p = tmp_path / f"arm{k}.urdf"
        p.write_text(urdf(L, m))
        paths.append(p)
    from proleg.io import load_urdf

    _check_builder(lambda: load_urdf(paths[0], floating_base=False), lambda: load_urdf(paths[1], floating_base=False))


def test_structure_summary_names_the_key_parts():
    s = pl.assemble(pl.robots.hyq_leg("rigid"))
    info = structure_summary(s)
    assert info["parts"] == s.topo.nbody and info["elements"]["contact"] == 1
    assert info["structure numbers"]["hip_servo.period"] == pytest.approx(1e-3)
    assert len(info["key"]) == 16


# -- gradients with respect to geometry ------------------------------------------------------------
def test_geometry_gradient_matches_central_differences():
    """∂(lower link's final height)/∂(upper-link length) of the README pendulum through the
    simulation (forward mode along the builder's parameter direction) against central
    differences of whole runs. Both at rtol 1e-11, where the integration error in a difference
    quotient of step 1e-4 is below 1e-6 of the derivative; tolerance 1e-4 relative (issue 42)."""
    from proleg.analyses.structure import design_gradient

    kw = dict(t_end=0.5, dt_output=0.05, progress=False, rtol=1e-11)

    def metric(r):
        return r.part("lower").position[-1, 2]

    value, grad = design_gradient(lambda length: readme_pendulum(length), {"length": 1.0}, metric, **kw)
    h = 1e-4
    fd = (float(metric(_sim(readme_pendulum(1.0 + h), kw))) - float(metric(_sim(readme_pendulum(1.0 - h), kw)))) / (2 * h)
    assert value == pytest.approx(float(metric(_sim(readme_pendulum(1.0), kw))), rel=1e-12)
    assert abs(fd) > 1e-2  # the length matters
    assert grad["length"] == pytest.approx(fd, rel=1e-4)


def _sim(model, kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return pl.simulate(pl.assemble(model), **kw)


def test_a_structural_design_argument_has_no_gradient():
    from proleg.analyses.structure import design_gradient

    with pytest.raises(pl.ModelError, match="changes the structure"):
        design_gradient(lambda links: readme_pendulum(1.0, links=int(round(links))), {"links": 2.4}, lambda r: 0.0,
                        rel_step=0.1, t_end=0.1)


@cc.cached_jit
def _returns_the_box(box):
    return Box(2.0 * box.x, box.holder)  # the result carries the static object


def test_a_result_that_carries_the_model_is_not_shared(cache):
    """An executable whose result holds a topology would hand every model the first one's."""
    x = jnp.linspace(0.0, 1.0, 3)
    assert "static data" in cc.reads_numbers(_returns_the_box, Box(x, Holder(1.0, 1.0)))
    for g in (1.0, 2.0, 3.0):
        h = Holder(g, g)
        assert _returns_the_box(Box(x, h)).holder is h


@cc.cached_jit
def _skips_zero(box):
    return box.x if box.holder.offset == 0 else box.x + jnp.sin(box.x)  # a branch on zero


def test_a_branch_on_zero_is_found_when_no_model_seen_is_zero(cache):
    """The models' own offsets are all nonzero and the first change keeps them so; the second
    change (every number zero) takes the other branch, so nothing is shared and the model with a
    zero offset gets its own answer."""
    x = jnp.linspace(0.0, 1.0, 3)
    assert cc.reads_numbers(_skips_zero, Box(x, Holder(1.0, 2.0)))
    for o in (2.0, 3.0, 0.0):
        want = np.asarray(x) if o == 0 else np.asarray(x) + np.sin(np.asarray(x))
        np.testing.assert_allclose(_skips_zero(Box(x, Holder(1.0, o))), want, rtol=1e-15)


def test_simulation_key_groups_designs_without_tracing_each():
    """Two link lengths share a simulation key (decided once), a third link does not; a run that
    reads a number of the topology (here the first part's mass, read in Python) gets none."""
    from proleg.analyses.structure import simulation_key

    def run(s):
        r = pl.simulate(s, t_end=0.05, dt_output=0.01, progress=False, throw=False)
        return r.q

    a, b = pl.assemble(readme_pendulum(1.0)), pl.assemble(readme_pendulum(1.2))
    ka = simulation_key(a, run)
    assert ka is not None and simulation_key(b, run) == ka
    assert simulation_key(pl.assemble(readme_pendulum(1.0, links=3)), run) not in (None, ka)

    def reads_mass(s):
        return run(s) * s.topo.model.parts[0].mass

    assert simulation_key(a, reads_mass) is None


@pytest.mark.parametrize("name", ["double_pendulum.yaml", "four_bar.yaml"])
def test_the_example_model_files_read_no_number_in_their_trace(name):
    """The docs' model files (examples/): their physics reads its numbers from params only, and a
    copy with another gravity and part masses is the same structure."""
    from pathlib import Path

    from proleg.io.modelfile import load_model

    path = Path(__file__).resolve().parents[1] / "examples" / name

    def changed():
        m = load_model(path)
        m.gravity = np.array([0.0, 0.0, -9.0])
        for p in m.parts:
            p.mass = 1.1 * p.mass
        return m

    _check_builder(lambda: load_model(path), changed)


def _hold(z, state=None):
    """A discrete controller's law: its state is the torque it holds (and keeps)."""
    return z, {"motor": z[0]}


def _held_torque(z0):
    model = readme_pendulum(1.0)
    model.add_actuator(pl.JointActuator("motor", "shoulder"))
    model.add_controller(pl.DiscreteController("hold", lambda t, s, z: _hold(z), z0=[z0], outputs=["motor"], period=1e-2))
    return model


def test_a_discrete_controllers_initial_state_is_a_number_of_params():
    """A DiscreteController's z0 is a parameter (``controller_state0``), not a number the trace
    reads: two initial states share a simulation key, and the run follows each (the held torque
    of 2 N m against none moves the pendulum). It was read at trace time, so a builder study over
    the HyQ leg, whose pin servo is a DiscreteController, traced every design (issue 42)."""
    from proleg.analyses.structure import simulation_key

    def run(s):
        return pl.simulate(s, t_end=0.05, dt_output=0.01, progress=False, throw=False).q

    a, b = pl.assemble(_held_torque(0.0)), pl.assemble(_held_torque(2.0))
    assert np.array_equal(np.asarray(b.params["controller_state0"]), [2.0])
    assert numbers_read(a) == {}
    ka = simulation_key(a, run)
    assert ka is not None and simulation_key(b, run) == ka
    qa, qb = np.asarray(run(a)), np.asarray(run(b))
    assert np.max(np.abs(qa - qb)) > 1e-6
    qc = np.asarray(run(a.with_params(controller_state0=np.array([2.0]))))
    np.testing.assert_allclose(qc, qb, rtol=0, atol=1e-12)


def _limited_geared(limit, ratio):
    from proleg.drives import GearTrain

    model = readme_pendulum(1.0)
    model.add_actuator(pl.JointActuator("motor", "shoulder", effort=lambda t: 3.0 * jnp.sin(20.0 * t), limit=limit,
                                        gear=GearTrain(ratio, 0.9, 0.7), gear_speed_eps=1e-2))
    return model


def test_a_joint_actuators_limit_and_gear_are_numbers_of_params():
    """A JointActuator's effort limit and gear train (ratio, efficiencies, the blend speed) are
    parameters: designs that differ in them share one simulation, and a new limit or ratio
    through with_params gives the run of the model built with it (they were read at trace time:
    every new limit or gear ratio compiled again)."""
    from proleg.analyses.structure import simulation_key

    def run(s):
        return pl.simulate(s, t_end=0.1, dt_output=0.01, progress=False, throw=False).q

    a, b = pl.assemble(_limited_geared(2.0, 10.0)), pl.assemble(_limited_geared(1.5, 12.0))
    assert numbers_read(a) == {}
    ka = simulation_key(a, run)
    assert ka is not None and simulation_key(b, run) == ka
    qa, qb = np.asarray(run(a)), np.asarray(run(b))
    assert np.max(np.abs(qa - qb)) > 1e-6  # the limit and the ratio act
    qc = np.asarray(run(a.with_params({"motor.limit": 1.5, "motor.gear_ratio": 12.0})))
    np.testing.assert_allclose(qc, qb, rtol=0, atol=1e-12)


def test_element_fields_of_mixed_controllers_name_their_own_numbers():
    """A DiscreteController before a PID: ``servo.kp`` is the PID's gain (``controller_kp``
    holds the PIDs only) and ``hold.state0`` the discrete controller's slice of
    ``controller_state0``; neither has the other's fields. ``servo.kp`` used to index
    ``controller_kp`` by the controller's place among all controllers, out of bounds here, and
    JAX drops an out-of-bounds update: the new gain was silently ignored."""
    model = readme_pendulum(1.0)
    model.add_actuator(pl.JointActuator("motor", "shoulder"))
    model.add_actuator(pl.JointActuator("elbow_motor", "elbow"))
    model.add_controller(pl.DiscreteController("hold", lambda t, s, z: _hold(z), z0=[0.5], outputs=["motor"], period=1e-2))
    model.add_controller(pl.PID("servo", "elbow", kp=20.0, kd=1.0, actuator="elbow_motor", period=1e-2))
    system = pl.assemble(model)
    names = system.public_param_names()
    assert "servo.kp" in names and "hold.state0" in names
    assert "hold.kp" not in names and "servo.state0" not in names
    assert np.asarray(system.with_params({"servo.kp": 5.0}).params["controller_kp"]).tolist() == [5.0]
    assert float(system.with_params({"servo.kp": 5.0}).get("servo.kp")) == 5.0
    assert np.asarray(system.with_params({"hold.state0": 2.0}).params["controller_state0"]).tolist() == [2.0]
    with pytest.raises(pl.ModelError, match="hold.kp"):
        system.with_params({"hold.kp": 1.0})


@pytest.mark.slow
def test_hyq_leg_geometry_gradient_matches_central_differences():
    """∂(knee cylinder's height after a 0.15 s drop)/∂(cylinder length) of the HyQ leg (rigid
    pins, servos, foot contact) through the simulation, forward mode along the builder's params
    direction, against central differences of whole runs; both at rtol 1e-10 (the α-method's
    derivative is that of its discrete map with the step sequence held: it meets the adaptive
    runs' differences as the tolerance falls). Measured 2.3e-7 relative; tolerance 1e-4 (issue 42
    item 6). ~3 min of compile and runs: slow."""
    from proleg.analyses.structure import design_gradient
    from proleg.robots import hyq_leg

    kw = dict(t_end=0.15, dt_output=0.05, progress=False, rtol=1e-10)

    def metric(r):
        return r.part("knee_cylinder").position[-1, 2]

    def build(cylinder_length):
        return hyq_leg("rigid", cylinder_length=cylinder_length)

    value, grad = design_gradient(build, {"cylinder_length": 0.2}, metric, **kw)
    h = 1e-4
    fd = (float(metric(_sim(build(0.2 + h), kw))) - float(metric(_sim(build(0.2 - h), kw)))) / (2 * h)
    assert abs(fd) > 0.1  # the cylinder's length moves it
    assert grad["cylinder_length"] == pytest.approx(fd, rel=1e-4)
