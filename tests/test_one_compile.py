"""One compile from model to table (issue 20): simulate() compiles the outputs' post-processing
(accelerations, multipliers, joint reactions, element outputs, energies) with the run, so the
first ``to_frame()`` compiles nothing. Compilations are counted with JAX's own monitoring event
for backend compiles (``/jax/core/compile/backend_compile_duration``).

Model: a rod (m = 2 kg, 1 m) hanging at rest on a pin along y, with a vertical spring (k = 100
N/m) from its tip to a ground anchor at its free length: it stays at rest, so the pin reaction
is m g and the spring force is zero, closed forms for the table's columns.
"""

import numpy as np
import pytest

import proleg as pl

M, L, G = 2.0, 1.0, 9.81


@pytest.fixture(scope="module")
def system():
    model = pl.Model("one_compile", gravity=(0, 0, -G))
    rod = model.add_part("rod", mass=M, inertia=(M * L**2 / 12, M * L**2 / 12, 1e-3), position=(0, 0, -L / 2))
    model.add_joint(pl.Revolute("pin", model.ground, rod, at=(0, 0, 0), axis=(0, 1, 0)))
    tip, anchor = model.add_marker(rod, "tip", (0, 0, -L)), model.add_marker(model.ground, "anchor", (0, 0, -1.5 * L))
    model.add_force(pl.SpringDamper("spring", tip, anchor, stiffness=100.0, damping=0.0, free_length=0.5 * L))
    return pl.assemble(model)


def test_to_frame_after_simulate_compiles_nothing(system, jax_events):
    res = pl.simulate(system, t_end=0.05, dt_output=1e-3)
    # the post-processing compiles beside the run, in a thread; with a cold cache this short run
    # can end first: wait for that compile, so only what to_frame itself would compile is counted
    # (JAX's compile events are process-wide)
    if hasattr(res._compiled_post, "result"):
        res._compiled_post.result()
    with jax_events("/jax/core/compile/backend_compile_duration") as c:
        df = res.to_frame()
        res.joint("pin"), res.element("spring"), res.energy, res.part("rod").acceleration
    assert c.names == []
    # the table's physics: at rest the pin carries the weight; the reaction is reported on the
    # joint's part I, here the ground, which the rod pulls down with m g
    np.testing.assert_allclose(df["pin.Fz [N]"], -M * G, rtol=1e-9)
    np.testing.assert_allclose(df["pin.Fx [N]"], 0.0, atol=1e-9)
    np.testing.assert_allclose(df["rod.z [m]"], -L / 2, atol=1e-12)
    np.testing.assert_allclose(df["energy.total [J]"], df["energy.total [J]"][0], atol=1e-9)


def test_lazy_outputs_give_the_same_table(system):
    """RunOptions(prepare_outputs=False): the post-processing compiles on first access instead,
    with the same numbers."""
    a = pl.simulate(system, t_end=0.05, dt_output=1e-3).to_frame()
    lazy = pl.simulate(system, t_end=0.05, dt_output=1e-3, run=pl.RunOptions(prepare_outputs=False))
    assert lazy._compiled_post is None
    b = lazy.to_frame()
    assert list(a.columns) == list(b.columns)
    # bitwise: the same run executable, and the same post-processing program (post_batch),
    # compiled ahead or on first access; identity is what is tested
    np.testing.assert_array_equal(a.to_numpy(), b.to_numpy())
