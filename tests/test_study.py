"""``proleg.study``: designs have their documented properties, a grid study equals a loop of
``simulate`` calls, the store resumes without recomputing or duplicating, a changed study is
refused with the difference named, failures are rows, and bad input is refused up front.

Model: the double pendulum with a tip spring of test_sweep.py, 0.1 s (tiny and fast).
"""

import dataclasses
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
def check_rows_are_simulates(system, tab, method, **simulate_kw):
    """Each row is ``simulate(system.with_params(row))``: the same method and steps, and its
    output to round-off (issue 42's target, 1e-9 relative; the batch is the single run's
    arithmetic, vectorised)."""
    for row in tab.to_dict("records"):
        ref = pl.simulate(system.with_params({"spring.stiffness": row["spring.stiffness"], "spring.damping": row["spring.damping"]}),
                          progress=False, **KW, **simulate_kw)
        assert row["integrator"] == ref.stats["integrator"] and row["integrator"].startswith(method)
        assert row["steps"] == ref.stats["steps"]
        assert row["x_end"] == pytest.approx(float(ref.part("lower").position[-1, 0]), rel=1e-9, abs=0)
    assert tab.attrs["integrators"] == {tab["integrator"].iloc[0]: len(tab)} and tab.attrs["integrator_notes"] == []


def test_grid_study_equals_a_loop_of_simulate(system, tmp_path):
    # no integrator named: simulate's own choice (Tsit5 for this smooth tree), not another
    # method (studies ran generalized-alpha before: 4.6e-4 m off on the README pendulum, issue 42)
    st = make_study(system)
    tab = st.run(design="grid", n=2, executor="vmap", store=tmp_path / "s", workers=1, progress=False)
    assert len(tab) == 4 and (tab["status"] == "success").all()
    check_rows_are_simulates(system, tab, "Tsit5")
    assert {"wall_s", "batch_wall_s", "worker", "batch", "key"} <= set(tab.columns)
    # one variant per compiled call (lanes=1): the same rows
    one = st.run(design="grid", n=2, executor="vmap", workers=1, lanes=1, progress=False)
    np.testing.assert_allclose(one["x_end"], tab["x_end"], rtol=1e-12, atol=0)
    assert list(one["steps"]) == list(tab["steps"])
    with pytest.raises(pl.ModelError, match="lanes"):
        st.run(design="grid", n=2, executor="vmap", lanes=0, progress=False)
    # the store holds the rows with the definition and the versions in the file metadata
    import pyarrow.parquet as pq

    f = next((tmp_path / "s" / "rows").glob("part-*.parquet"))
    assert b"proleg.study" in pq.read_schema(f).metadata and b'"jax"' in pq.read_schema(f).metadata[b"proleg.study"]


def test_rows_with_an_integrator_named_are_simulates(system):
    st = pl.study.Study(system, space={"spring.stiffness": [20.0, 200.0], "spring.damping": 0.5}, outputs={"x_end": x_end},
                        simulate=dict(KW, integrator=pl.GeneralizedAlpha()))
    tab = st.run(design="grid", executor="vmap", workers=1, progress=False)
    check_rows_are_simulates(system, tab, "GeneralizedAlpha", integrator=pl.GeneralizedAlpha())


@dataclasses.dataclass(frozen=True)
class Unbatchable(pl.Tsit5):
    """A method that declares it cannot run under ``jax.vmap`` (``batches = False``)."""

    batches = False


def test_a_batch_that_runs_another_method_says_so(system):
    """Rows that are not simulate's answer are never silent: a warning, the ``integrator`` and
    ``integrator_note`` columns, and the table's ``attrs``."""
    st = pl.study.Study(system, space={"spring.stiffness": [20.0, 200.0], "spring.damping": 0.5}, outputs={"x_end": x_end},
                        simulate=dict(KW, integrator=Unbatchable()))
    with pytest.warns(pl.ProlegWarning, match=r"2 row\(s\) ran another method than simulate\(\) would: Unbatchable"):
        tab = st.run(design="grid", executor="vmap", workers=1, progress=False)
    assert (tab["status"] == "success").all() and tab["integrator"].str.startswith("GeneralizedAlpha(").all()
    assert tab["integrator_note"].str.contains("differ from simulate").all()
    assert len(tab.attrs["integrator_notes"]) == 1 and "Unbatchable" in tab.attrs["integrator_notes"][0]
    ref = pl.simulate(system.with_params({"spring.stiffness": 200.0}), progress=False, integrator=pl.GeneralizedAlpha(rtol=1e-8, atol=1e-9), **KW)
    assert tab["x_end"].iloc[1] == pytest.approx(float(ref.part("lower").position[-1, 0]), rel=1e-9)


def test_stored_rows_without_their_method_are_flagged(system, tmp_path):
    """A store written before rows recorded their method (its batches ran generalized-alpha,
    not simulate's choice) resumed now would mix methods: a warning says so."""
    import pyarrow.parquet as pq

    st = make_study(system)
    st.run(design="grid", n=2, executor="vmap", workers=1, store=tmp_path / "s", progress=False)
    for f in (tmp_path / "s" / "rows").glob("part-*.parquet"):  # as an earlier proleg wrote it
        t = pq.read_table(f)
        pq.write_table(t.drop(["integrator", "integrator_note", "batch_wall_s"]), f)
    with pytest.warns(pl.ProlegWarning, match=r"4 stored row\(s\) do not record their method.*new store"):
        tab = st.run(design="grid", n=3, executor="vmap", workers=1, store=tmp_path / "s", progress=False)
    recorded = tab["integrator"].dropna()
    assert len(tab) == 6 and len(recorded) == 2 and tab.attrs["integrators"] == {recorded.iloc[0]: 2}


def test_local_batches_are_batch_size_designs(system):
    """``executor="local", batch_size=1``: one design per batch (it gave two: "local" ran its
    default two workers' batches in one call). ``wall_s`` is the design's share of its batch's
    wall time, ``batch_wall_s`` the batch's (docs/guide/studies.md)."""
    st = make_study(system)
    tab = st.run(design="grid", n=2, executor="local", batch_size=1, progress=False)
    assert tab["batch"].nunique() == 4
    np.testing.assert_allclose(tab["wall_s"], tab["batch_wall_s"])
    two = st.run(design="grid", n=2, executor="vmap", batch_size=2, workers=2, progress=False)
    assert sorted(two.groupby("batch").size()) == [2, 2]  # two batches of 2, even when run in one call
    for _, b in two.groupby("batch"):
        np.testing.assert_allclose(b["wall_s"] * len(two[two["batch_wall_s"] == b["batch_wall_s"].iloc[0]]), b["batch_wall_s"])


def test_a_builder_space_is_checked_against_its_signature():
    """A typo in a builder study's space is refused at once, with the close matches, as for a
    System study (it ran every row and failed each with build_error); so is a required
    argument the space leaves out. A builder taking **kwargs accepts any name."""
    def leg(L1, L2, mass=6.0):
        raise AssertionError("never built: the space is checked first")

    with pytest.raises(pl.ModelError, match=r"'L3' is not a parameter of Study's builder 'leg' \(its keyword arguments: L1, L2, mass\)\. Close matches: \['L2', 'L1'\]"):
        pl.study.Study(leg, space={"L1": (0.18, 0.3), "L3": (0.18, 0.3)}, outputs={"x": x_end}, simulate=KW)
    with pytest.raises(pl.ModelError, match=r"needs 'L2', which the space does not give.*\{'L2': 0.25\}"):
        pl.study.Study(leg, space={"L1": (0.18, 0.3)}, outputs={"x": x_end}, simulate=KW)
    pl.study.Study(leg, space={"L1": (0.18, 0.3), "L2": 0.25}, outputs={"x": x_end}, simulate=KW)

    def any_leg(L1, **geometry):
        raise AssertionError

    pl.study.Study(any_leg, space={"L1": (0.18, 0.3), "L3": (0.18, 0.3)}, outputs={"x": x_end}, simulate=KW)
    with pytest.raises(pl.ModelError, match="needs 'L1'"):
        pl.study.Study(any_leg, space={"L3": (0.18, 0.3)}, outputs={"x": x_end}, simulate=KW)
    with pytest.raises(pl.ModelError, match=r"'b' is not a parameter of Study.function's function '<lambda>'"):
        pl.study.Study.function(lambda a: {"y": a}, {"a": [1.0], "b": [2.0]}, ["y"])


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

    # 1e9 N/m pre-stretched by 2 cm rings faster than dt_min = 1e-5 s can follow (test_sweep.py;
    # generalized-alpha named: the explicit Tsit5 that simulate picks for this model has no dt_min)
    st = pl.study.Study(system, space={"spring.stiffness": [20.0, 1e9], "spring.free_length": 0.98},
                        outputs={"x_end": x_end, "bad": bad}, simulate=dict(KW, integrator=pl.GeneralizedAlpha(dt_min=1e-5)))
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
        ref = pl.simulate(build(row["links"], row["k"]), progress=False, **KW)  # no method named: simulate's choice
        assert row["z_tip"] == pytest.approx(float(ref.marker("tip").position[-1, 2]), rel=1e-9, abs=1e-12)
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
    assert default_executor("system", "cpu") == "vmap" and default_executor("builder", "cpu") == "processes"  # one structure not known
    assert default_executor("system", "gpu") == "vmap" and default_executor("builder", "cuda") == "vmap"  # one process holds the device
    assert default_executor("function", "gpu") == "processes"
    # executor=None and "auto" both take it
    seen = []
    monkeypatch.setattr(executors, "default_executor", lambda kind, **kw: seen.append(kind) or "local")
    st = pl.study.Study.function(lambda x: {"y": 2 * x}, {"x": [1.0, 2.0]}, ["y"])
    assert st.run(design="grid", executor="auto", progress=False)["y"].tolist() == [2.0, 4.0]
    st.run(design="grid", progress=False)
    assert seen == ["function", "function"]
