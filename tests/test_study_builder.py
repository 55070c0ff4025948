"""Builder studies share compilations: builds that differ only in parameter values (a link
length, a spring stiffness) are one group — one compilation of the vmapped simulation — and
every row equals its own ``simulate``; a build whose Motion captures a builder argument (a
constant of the compiled code) is not merged with the others.

Model: the double pendulum with a tip spring of test_study.py, with the upper link's length
(its inertia, the elbow, the lower part, the tip and the spring's anchor follow) and the
spring's stiffness as builder arguments; 0.1 s.
"""

import logging

import pytest

import proleg as pl
from proleg.study.executors import _shape_key

KW = dict(t_end=0.1, dt_output=0.01)


def pendulum(length, k, amp=None):
    m = pl.Model("builder_pendulum", gravity=(0, 0, -9.81))
    up = m.add_part("upper", mass=1.0, inertia=(0.01, 0.09 * length**2, 0.09 * length**2), position=(0.5 * length, 0, 0))
    lo = m.add_part("lower", mass=1.0, inertia=(0.01, 0.09, 0.09), position=(length + 0.5, 0, 0))
    m.add_joint(pl.Revolute("shoulder", m.ground, up, at=(0, 0, 0), axis=(0, 1, 0)))
    m.add_joint(pl.Revolute("elbow", up, lo, at=(length, 0, 0), axis=(0, 1, 0)))
    tip = m.add_marker(lo, "tip", position=(length + 1, 0, 0))
    anchor = m.add_marker(m.ground, "anchor", position=(length + 1, 0, -1))
    m.add_force(pl.SpringDamper("spring", tip, anchor, stiffness=k, damping=0.5, free_length=1.0))
    if amp is not None:  # the shoulder driven by a law that captures the builder's argument
        m.add_motion(pl.Motion("swing", m.joint("shoulder"), displacement=lambda t: amp * t**2))
    return pl.assemble(m)


OUTPUTS = {"x_tip": lambda r: r.marker("tip").position[-1, 0], "z_tip": lambda r: r.marker("tip").position[-1, 2],
           "f_max": lambda r: abs(r.element("spring").force).max()}


class _Count(logging.Handler):
    def __init__(self):
        super().__init__(logging.DEBUG)
        self.n = 0

    def emit(self, record):
        self.n += record.getMessage().startswith("Compiling jit(one) ")


def count_sweep_compilations(run):
    """Run ``run()`` and count the compilations of proleg.sweep's vmapped simulation (``one``):
    JAX logs "Compiling jit(one) ..." at DEBUG for every compilation request, persistent cache
    hit or not."""
    log = logging.getLogger("jax._src.interpreters.pxla")
    handler, level = _Count(), log.level
    log.addHandler(handler)
    log.setLevel(logging.DEBUG)
    try:
        out = run()
    finally:
        log.removeHandler(handler)
        log.setLevel(level)
    return out, handler.n


def check_rows_equal_their_simulate(tab, build):
    for row in tab.to_dict("records"):
        assert row["status"] == "success", row["reason"]
        ref = pl.simulate(build(row), progress=False, **KW)  # no method named: the study makes simulate's choice
        expected = {k: float(fn(ref)) for k, fn in OUTPUTS.items()}
        for k, v in expected.items():  # vmap batch against one run: the same arithmetic, rounding apart
            assert row[k] == pytest.approx(v, abs=1e-9, rel=1e-9), (k, row)
        assert row["steps"] == ref.stats["steps"]


def test_the_shape_key_sees_captured_constants_not_parameters():
    a, b, c = pendulum(1.0, 50.0, amp=2.0), pendulum(1.0, 50.0, amp=3.0), pendulum(1.25, 120.0, amp=2.0)
    assert _shape_key(a, KW) != _shape_key(b, KW)  # amp is a constant of the compiled law
    assert _shape_key(a, KW) == _shape_key(c, KW)  # length and stiffness are parameters


@pytest.mark.slow  # ~1 min of CPU: six builds, their traces and six reference simulations
def test_builds_differing_in_numbers_share_one_compilation():
    st = pl.study.Study(pendulum, space={"length": [0.8, 1.0, 1.25], "k": [50.0, 120.0]}, outputs=OUTPUTS, simulate=KW)
    tab, n_compiled = count_sweep_compilations(lambda: st.run(design="grid", executor="vmap", workers=1, batch_size=6, progress=False))
    assert len(tab) == 6 and tab["batch"].nunique() == 1
    assert n_compiled == 1
    assert tab["x_tip"].nunique() == 6  # six different simulations
    check_rows_equal_their_simulate(tab, lambda row: pendulum(row["length"], row["k"]))


@pytest.mark.slow  # ~1 min of CPU
def test_a_motion_capturing_a_builder_argument_splits_the_group():
    st = pl.study.Study(pendulum, space={"length": [1.0, 1.25], "k": 50.0, "amp": [2.0, 3.0]}, outputs=OUTPUTS, simulate=KW)
    tab, n_compiled = count_sweep_compilations(lambda: st.run(design="grid", executor="vmap", workers=1, batch_size=4, progress=False))
    assert n_compiled == 2 and tab["batch"].nunique() == 1
    check_rows_equal_their_simulate(tab, lambda row: pendulum(row["length"], row["k"], row["amp"]))



def test_a_builder_of_one_structure_runs_in_this_process_as_one_vmap_batch_by_default():
    # default_executor's CPU rule (issue 42; measured figures in its docstring): a builder whose
    # first and last designs build one structure is "vmap"; where they may not, "processes"
    from proleg.study import executors as ex

    one = [("a", {"length": 0.8, "k": 50.0}), ("b", {"length": 1.25, "k": 120.0})]
    two = [("a", {"length": 1.0, "k": 50.0, "amp": 2.0}), ("b", {"length": 1.0, "k": 50.0, "amp": 3.0})]
    assert ex.builds_share_structure(pendulum, one, KW)
    assert not ex.builds_share_structure(pendulum, two, KW)  # amp is a constant of the compiled law: two structures
    assert not ex.builds_share_structure(lambda length, k: 1 / 0, one, KW)  # a build that fails: not known
    assert ex.default_executor("builder", "cpu", one_structure=True) == "vmap"
    assert ex.default_executor("builder", "cpu", one_structure=lambda: False) == "processes"
    assert ex.default_executor("builder", "cpu") == "processes"  # not known
    assert ex.default_executor("builder", "gpu", one_structure=lambda: 1 / 0) == "vmap"  # asked only where it matters
    st = pl.study.Study(pendulum, space={"length": [0.8, 1.25], "k": 50.0}, outputs=OUTPUTS, simulate=KW)
    tab, n_compiled = count_sweep_compilations(lambda: st.run(design="grid", progress=False))
    assert list(tab["status"]) == ["success", "success"] and tab["x_tip"].nunique() == 2
    assert n_compiled == 1 and set(tab["worker"]) == {ex._worker_name()}  # one compile, in this process


def test_a_batch_whose_values_do_not_reach_the_state_still_reports_its_status():
    # an ``apply`` that keeps the built system (its numbers are constants of the build, as
    # FLEGX's study does) runs the batched simulation untraced: the status must still reach
    # the table (it once failed: "'Result' object has no attribute 'traced_status'")
    st = pl.study.Study(pendulum, space={"length": [1.0], "k": 50.0}, outputs=OUTPUTS, simulate=KW,
                        apply=lambda system, values: system)
    tab = st.run(design="grid", executor="vmap", workers=1, batch_size=1, progress=False)
    assert list(tab["status"]) == ["success"], tab["reason"].tolist()
    ref = pl.simulate(pendulum(1.0, 50.0), progress=False, **KW)  # no method named: the study makes simulate's choice
    assert tab["x_tip"].iloc[0] == pytest.approx(float(OUTPUTS["x_tip"](ref)), rel=1e-9)
    assert tab["steps"].iloc[0] == ref.stats["steps"]
