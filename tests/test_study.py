"""``proleg.study``: designs have their documented properties, a grid study equals a loop of
``simulate`` calls, the store resumes without recomputing or duplicating, a changed study is
refused with the difference named, failures are rows, and bad input is refused up front.

Model: the double pendulum with a tip spring of test_sweep.py, 0.1 s (tiny and fast).
"""

import math

import numpy as np
import pandas as pd
import pytest

import proleg as pl
from proleg.study.design import make_design
from models import spring_pendulum

KW = dict(t_end=0.1, dt_output=0.01)


def pendulum():
    return spring_pendulum("study_pendulum")


@pytest.fixture(scope="module")
def system():
    return pendulum()


def x_end(r):
    return r.part("lower").position[-1, 0]


def make_study(system, **kw):
    space = kw.pop("space", {"spring.stiffness": (10.0, 1000.0), "spring.damping": [0.1, 1.0]})
    outputs = kw.pop("outputs", {"x_end": x_end})
    return pl.study.Study(system, space=space, outputs=outputs, simulate=KW, **kw)


# -- designs ----------------------------------------------------------------------------------
def test_lhs_is_stratified_and_sobol_balanced():
    space = pl.study.Space({"a": (0.0, 1.0), "b": (0.0, 1.0), "c": (0.0, 1.0)})
    n = 20
    lhs = make_design(space, "lhs", n, seed=3)
    for k in "abc":  # one point in each of the n strata of every dimension
        assert sorted(np.floor(lhs[k].to_numpy() * n).astype(int)) == list(range(n))
    sob = make_design(space, "sobol", 16, seed=3)
    for k in "abc":  # a power-of-two Sobol' set puts 2^(m-j) points in each of the 2^j dyadic intervals
        for j in (1, 2, 3):
            counts = np.bincount(np.floor(sob[k].to_numpy() * 2**j).astype(int), minlength=2**j)
            assert (counts == 16 // 2**j).all()
    # choices under LHS stay balanced; a log range spans decades evenly; seeds reproduce
    sp2 = pl.study.Space({"k": pl.study.LogRange(1e2, 1e6), "c": [1.0, 2.0, 3.0], "m": 5.0})
    d = make_design(sp2, "lhs", 12, seed=0)
    assert d["c"].value_counts().to_dict() == {1.0: 4, 2.0: 4, 3.0: 4}
    assert sorted(np.floor(np.log10(d["k"]) - 2).astype(int)) == [0] * 3 + [1] * 3 + [2] * 3 + [3] * 3
    assert (d["m"] == 5.0).all()
    pd.testing.assert_frame_equal(d, make_design(sp2, "lhs", 12, seed=0))
    g = make_design(sp2, "grid", 3)
    assert len(g) == 9 and sorted(set(g["k"])) == pytest.approx([1e2, 1e4, 1e6])


def test_a_design_too_large_is_refused_before_any_array(monkeypatch):
    """A design size that would exhaust the memory (a typo'd n, too many grid levels) is a
    ModelError naming the size and the limit, at once: the fuzzing of study files found
    n = 2.8e16 raising numpy's MemoryError (201 PiB) instead."""
    sp = pl.study.Space({"a": (0.0, 1.0), "b": (0.0, 1.0), "c": [1.0, 2.0]})
    for design in ("lhs", "sobol", "grid"):
        with pytest.raises(pl.ModelError, match="PROLEG_MAX_DESIGN_ROWS"):
            make_design(sp, design, 2.82834477918851e16)
    with pytest.raises(pl.ModelError, match=r"2,000,000 variants \(a grid of 1000 x 1000 x 2\)"):
        monkeypatch.setenv("PROLEG_MAX_DESIGN_ROWS", "1000000")
        make_design(sp, "grid", 1000)  # 2e6 rows: refused without building them
    for bad in (float("nan"), float("inf"), 2.5, 0, True, "3"):
        with pytest.raises(pl.ModelError, match="≥ 1 and an integer"):
            make_design(sp, "lhs", bad)
    assert len(make_design(sp, "grid", 3.0)) == 18 and len(make_design(sp, "lhs", np.int64(4))) == 4


# -- running and the store --------------------------------------------------------------------
def test_grid_study_equals_a_loop_of_simulate(system, tmp_path):
    st = make_study(system)
    tab = st.run(design="grid", n=2, executor="vmap", store=tmp_path / "s", workers=1, progress=False)
    assert len(tab) == 4 and (tab["status"] == "success").all()
    for row in tab.to_dict("records"):
        # a study's batches run generalized-alpha when no integrator is named (analyses/sweep.py)
        ref = pl.simulate(system.with_params({"spring.stiffness": row["spring.stiffness"], "spring.damping": row["spring.damping"]}), progress=False,
                          integrator=pl.GeneralizedAlpha(), **KW)
        assert row["x_end"] == pytest.approx(float(ref.part("lower").position[-1, 0]), abs=1e-10)
        assert row["steps"] == ref.stats["steps"]
    assert {"wall_s", "worker", "batch", "key"} <= set(tab.columns)
    # one variant per compiled call (lanes=1): the same rows
    one = st.run(design="grid", n=2, executor="vmap", workers=1, lanes=1, progress=False)
    np.testing.assert_allclose(one["x_end"], tab["x_end"], rtol=0, atol=1e-10)
    assert list(one["steps"]) == list(tab["steps"])
    with pytest.raises(pl.ModelError, match="lanes"):
        st.run(design="grid", n=2, executor="vmap", lanes=0, progress=False)
    # the store holds the rows with the definition and the versions in the file metadata
    import pyarrow.parquet as pq

    f = next((tmp_path / "s" / "rows").glob("part-*.parquet"))
    assert b"proleg.study" in pq.read_schema(f).metadata and b'"jax"' in pq.read_schema(f).metadata[b"proleg.study"]


class Interrupt(Exception):
    pass


def test_resume_after_an_interruption_recomputes_nothing(system, tmp_path):
    st = make_study(system)
    store = tmp_path / "s"
    seen = []

    def stop_after_first(rows):
        seen.append(len(rows))
        raise Interrupt

    with pytest.raises(Interrupt):
        st.run(design="lhs", n=8, seed=1, store=store, batch_size=4, workers=1, progress=False, on_batch=stop_after_first)
    first = pl.study.Store(store).read()
    assert len(first) == 4 and pl.study.Store(store).status()["pending"] == 4
    counts = []
    tab = st.run(design="lhs", n=8, seed=1, store=store, batch_size=4, workers=1, progress=False, on_batch=lambda r: counts.append(len(r)))
    assert counts == [4]  # only the missing batch ran
    allrows = pl.study.Store(store).read()
    assert len(allrows) == 8 and allrows["key"].is_unique and len(tab) == 8
    again = []
    st.run(design="lhs", n=8, seed=1, store=store, progress=False, on_batch=lambda r: again.append(r))
    assert again == [] and len(pl.study.Store(store).read()) == 8
    assert pl.study.Store(store).status() == {"rows": 8, "done": 8, "failed": 0, "pending": 0, "duplicates": 0, "by_status": {"success": 8}}
    # a changed definition is refused, naming what changed
    changed = make_study(system, space={"spring.stiffness": (10.0, 2000.0), "spring.damping": [0.1, 1.0]})
    with pytest.raises(pl.ModelError, match=r"space\.spring\.stiffness: stored \[\"range\", 10\.0, 1000\.0\], now \[\"range\", 10\.0, 2000\.0\]"):
        changed.run(design="lhs", n=8, seed=1, store=store, progress=False)
    other = make_study(system.with_params({"upper.mass": 2.0}))
    with pytest.raises(pl.ModelError, match="target.params_sha1"):
        other.run(design="lhs", n=8, seed=1, store=store, progress=False)


def test_failures_are_rows_and_the_study_goes_on(system):
    def bad(r):
        raise RuntimeError("no such sensor")

    # 1e9 N/m pre-stretched by 2 cm rings faster than dt_min = 1e-5 s can follow (test_sweep.py)
    st = pl.study.Study(system, space={"spring.stiffness": [20.0, 1e9], "spring.free_length": 0.98},
                        outputs={"x_end": x_end, "bad": bad}, simulate=dict(KW, dt_min=1e-5))
    tab = st.run(design="grid", n=1, workers=1, progress=False)
    ok, stiff = tab.iloc[0], tab.iloc[1]
    assert ok["status"] == "output_error" and "bad: RuntimeError: no such sensor" in ok["reason"]
    assert math.isfinite(ok["x_end"]) and math.isnan(ok["bad"])
    assert stiff["status"] == "step_too_small" and "t =" in stiff["reason"] and math.isnan(stiff["x_end"])


def test_a_builder_study_groups_variants_by_shape():
    def build(links, k):
        m = pl.Model(f"chain{int(links)}", gravity=(0, 0, -9.81))
        prev = m.ground
        for i in range(int(links)):
            p = m.add_part(f"p{i}", mass=1.0, inertia=(0.01, 0.09, 0.09), position=(i + 0.5, 0, 0))
            m.add_joint(pl.Revolute(f"j{i}", prev, p, at=(i, 0, 0), axis=(0, 1, 0)))
            prev = p
        tip = m.add_marker(prev, "tip", position=(int(links), 0, 0))
        anchor = m.add_marker(m.ground, "anchor", position=(int(links), 0, -1))
        m.add_force(pl.SpringDamper("spring", tip, anchor, stiffness=k, damping=0.5, free_length=1.0))
        return pl.assemble(m)

    st = pl.study.Study(build, space={"links": [1.0, 2.0], "k": [50.0, 100.0]}, outputs={"z_tip": lambda r: r.marker("tip").position[-1, 2]}, simulate=KW)
    tab = st.run(design="grid", n=1, executor="vmap", workers=1, progress=False)
    assert (tab["status"] == "success").all() and len(tab) == 4
    for row in tab.to_dict("records"):
        ref = pl.simulate(build(row["links"], row["k"]), progress=False, integrator=pl.GeneralizedAlpha(), **KW)
        assert row["z_tip"] == pytest.approx(float(ref.marker("tip").position[-1, 2]), abs=1e-10)
    assert tab.groupby("links")["batch"].nunique().max() == 1  # one batch, one sweep per shape


# -- bad input --------------------------------------------------------------------------------
def test_bad_input_is_refused(system):
    with pytest.raises(pl.ModelError, match=r"spring\.stifness.*Close matches: \['spring\.stiffness'"):
        make_study(system, space={"spring.stifness": (1.0, 2.0)})
    with pytest.raises(pl.ModelError, match=r"range of 'spring\.stiffness' is empty"):
        make_study(system, space={"spring.stiffness": (5.0, 5.0)})
    with pytest.raises(pl.ModelError, match="log range .* lo > 0"):
        make_study(system, space={"spring.stiffness": pl.study.LogRange(0.0, 5.0)})
    st = make_study(system)
    with pytest.raises(pl.ModelError, match="design size n must be ≥ 1"):
        st.run(design="lhs", n=0)
    with pytest.raises(pl.ModelError, match="unknown design 'latin'"):
        st.run(design="latin", n=4)
    with pytest.raises(pl.ModelError, match="unknown executor 'gpu'"):
        st.run(design="lhs", n=4, executor="gpu")
    with pytest.raises(pl.ModelError, match="output 'x'.*not a function"):
        make_study(system, outputs={"x": 3.0})
    with pytest.raises(pl.ModelError, match="t_end"):
        pl.study.Study(system, space={"spring.stiffness": (1.0, 2.0)}, outputs={"x": x_end})


def test_a_scheduler_that_does_not_answer_is_a_clear_error_in_seconds(system, tmp_path):
    import socket
    import time

    from proleg.study.executors import connect

    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()  # nothing listens on this port
    t0 = time.perf_counter()
    with pytest.raises(pl.ModelError, match=f"no Dask scheduler answered at 'tcp://127.0.0.1:{port}' within 2 s"):
        connect(f"tcp://127.0.0.1:{port}", timeout_s=2.0)
    assert time.perf_counter() - t0 < 15.0


def test_the_default_executor(monkeypatch):
    from proleg.study import executors
    from proleg.study.executors import default_executor

    # the rule of default_executor's docstring (measured figures there)
    assert default_executor("system", "cpu") == "vmap" and default_executor("builder", "cpu") == "processes"
    assert default_executor("system", "gpu") == "vmap" and default_executor("builder", "cuda") == "vmap"  # one process holds the device
    assert default_executor("function", "gpu") == "processes"
    # executor=None and "auto" both take it
    seen = []
    monkeypatch.setattr(executors, "default_executor", lambda kind: seen.append(kind) or "local")
    st = pl.study.Study.function(lambda x: {"y": 2 * x}, {"x": [1.0, 2.0]}, ["y"])
    assert st.run(design="grid", executor="auto", progress=False)["y"].tolist() == [2.0, 4.0]
    st.run(design="grid", progress=False)
    assert seen == ["function", "function"]
