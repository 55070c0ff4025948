"""``Study.function``: a study of a plain function (an FE solve, a closed form) with the
designs, executors, store, resume, optimisation and Sobol indices of a simulation study."""

import math

import numpy as np
import pytest

import proleg as pl


def branin(x1, x2):
    """Branin–Hoo: three global minima of 0.397887 (at (-π, 12.275), (π, 2.275), (9.42478, 2.475))."""
    a, b, c, r, s, t = 1.0, 5.1 / (4 * math.pi**2), 5 / math.pi, 6.0, 10.0, 1 / (8 * math.pi)
    return {"f": a * (x2 - b * x1**2 + c * x1 - r) ** 2 + s * (1 - t) * math.cos(x1) + s, "g": x1 + x2}


def failing(x):
    if x > 0.5:
        raise RuntimeError("mesh generation failed")
    return {"y": x**2}


def test_a_grid_of_a_function_equals_the_calls_and_resumes(tmp_path):
    st = pl.study.Study.function(branin, {"x1": (-5.0, 10.0), "x2": (0.0, 15.0)}, ["f", "g"])
    tab = st.run(design="grid", n=4, executor="local", store=tmp_path / "s", progress=False)
    assert len(tab) == 16 and (tab["status"] == "success").all()
    for row in tab.to_dict("records"):
        assert row["f"] == pytest.approx(branin(row["x1"], row["x2"])["f"], rel=1e-14)
    ran = []
    tab2 = st.run(design="grid", n=4, executor="local", store=tmp_path / "s", progress=False, on_batch=ran.extend)
    assert not ran and tab2["f"].tolist() == tab["f"].tolist()  # resumed: nothing recomputed


def test_a_raising_call_is_a_row_with_its_reason():
    st = pl.study.Study.function(failing, {"x": [0.25, 0.75]}, {"y": lambda v: v["y"]})
    tab = st.run(design="grid", n=1, executor="local", progress=False)
    ok, bad = tab.iloc[0], tab.iloc[1]
    assert ok["status"] == "success" and ok["y"] == 0.0625
    assert bad["status"] == "error" and "RuntimeError: mesh generation failed" in bad["reason"] and math.isnan(bad["y"])


def test_optuna_on_a_function_finds_a_constrained_minimum(tmp_path):
    # min f on the box subject to x1 + x2 >= 8: the minimum at (π, 2.275) is cut off (sum 5.42);
    # the constrained optimum, from a dense grid, lies on or near the line x1 + x2 = 8.
    st = pl.study.Study.function(branin, {"x1": (-5.0, 10.0), "x2": (0.0, 15.0)}, ["f", "g"])
    opt = st.optimize("f", {"g": (">=", 8.0)}, n_trials=60, batch=6, executor="local", store=tmp_path / "o", seed=3, progress=False)
    x1, x2 = np.meshgrid(np.linspace(-5, 10, 301), np.linspace(0, 15, 301))
    f = np.vectorize(lambda a, b: branin(a, b)["f"])(x1, x2)
    fmin = f[x1 + x2 >= 8.0].min()
    assert opt.best_params["x1"] + opt.best_params["x2"] >= 8.0 - 1e-12
    assert opt.best_value < fmin + 1.0  # TPE in 60 trials: within 1 of the grid optimum (f spans 0–300)
    # resumable: the same call continues the optuna study instead of starting over
    again = st.optimize("f", {"g": (">=", 8.0)}, n_trials=60, batch=6, executor="local", store=tmp_path / "o", seed=3, progress=False)
    assert len(again.trials) == 60 and again.best_value == opt.best_value


def test_function_study_bad_input():
    with pytest.raises(pl.ModelError, match="expected a function"):
        pl.study.Study.function(3.0, {"x": (0.0, 1.0)}, ["y"])
    with pytest.raises(pl.ModelError, match="outputs must be names"):
        pl.study.Study.function(failing, {"x": (0.0, 1.0)}, [1])
    with pytest.raises(pl.ModelError, match="clashes"):
        pl.study.Study.function(failing, {"x": (0.0, 1.0)}, ["status"])
    st = pl.study.Study.function(failing, {"x": (0.0, 1.0)}, ["y"])
    with pytest.raises(pl.ModelError, match="refine needs a System study"):
        st.refine({"x": 0.2}, "y")
