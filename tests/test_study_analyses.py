"""``proleg.study`` analyses: Sobol' indices of the Ishigami function against the closed
form, local sensitivities (jacfwd through the simulation) against central differences,
optuna finding a known optimum (checked on a dense grid) and resuming from its storage, and
the gradient refinement improving on its start.
"""

import numpy as np
import pytest

import proleg as pl
from proleg.analyses.simulate import simulate_kwargs
from proleg.study.sensitivity import saltelli_unit, sobol_indices

from test_study import KW, pendulum, x_end


def test_sobol_indices_of_ishigami_match_the_closed_form():
    # Ishigami (a = 7, b = 0.1) on [-π, π]^3: V = a²/8 + b π⁴/5 + b² π⁸/18 + 1/2,
    # V1 = (1 + b π⁴/5)²/2, V2 = a²/8, V13 = b² π⁸ (1/18 - 1/50); S3 = 0.
    a, b = 7.0, 0.1
    V = a**2 / 8 + b * np.pi**4 / 5 + b**2 * np.pi**8 / 18 + 0.5
    V1, V2, V13 = 0.5 * (1 + b * np.pi**4 / 5) ** 2, a**2 / 8, b**2 * np.pi**8 * (1 / 18 - 1 / 50)
    S1 = np.array([V1, V2, 0.0]) / V
    ST = np.array([V1 + V13, V2, V13]) / V
    x = -np.pi + 2 * np.pi * saltelli_unit(3, 4096, seed=2)
    y = np.sin(x[:, 0]) + a * np.sin(x[:, 1]) ** 2 + b * x[:, 2] ** 4 * np.sin(x[:, 0])
    si = sobol_indices(["x1", "x2", "x3"], y, seed=2)
    np.testing.assert_allclose(si["S1"], S1, atol=0.05)
    np.testing.assert_allclose(si["ST"], ST, atol=0.05)
    with pytest.raises(pl.ModelError, match="power of two"):
        saltelli_unit(3, 100)


@pytest.fixture(scope="module")
def system():
    return pendulum()


@pytest.mark.slow
def test_local_sensitivities_match_central_differences(system):
    kw = dict(KW, fixed_step=1e-3)  # fixed steps: the finite differences see no step-size changes
    st = pl.study.Study(system, space={"spring.stiffness": (10.0, 1000.0), "spring.damping": (0.1, 1.0)},
                        outputs={"x_end": x_end, "z_end": lambda r: r.part("lower").position[-1, 2]}, simulate=kw)
    at = {"spring.stiffness": 300.0, "spring.damping": 0.4}
    ls = st.local_sensitivity(at).set_index(["output", "parameter"])

    def out(p):
        # the study's flat keys (fixed_step) go into the integrator as the study does, without
        # the flat-keyword DeprecationWarning (an error in this suite)
        r = pl.simulate(system.with_params(p), progress=False, **simulate_kwargs(kw))
        return np.array([x_end(r), r.part("lower").position[-1, 2]])

    for name, h in (("spring.stiffness", 1e-3), ("spring.damping", 1e-6)):
        fd = (out({**at, name: at[name] + h}) - out({**at, name: at[name] - h})) / (2 * h)
        for i, o in enumerate(("x_end", "z_end")):
            d = ls.loc[(o, name), "derivative"]
            assert d == pytest.approx(fd[i], rel=1e-5, abs=1e-9), (o, name)
    assert ls.loc[("x_end", "spring.stiffness"), "derivative"] != 0.0


@pytest.mark.slow
def test_optuna_finds_a_known_optimum_and_resumes(system, tmp_path):
    # Objective: the squared miss of the x_end of k* = 400 N/m; its optimum is k* (checked on a
    # dense grid), optuna (TPE) must land within the grid's spacing.
    target = float(x_end(pl.simulate(system.with_params({"spring.stiffness": 400.0}), progress=False, **KW)))
    st = pl.study.Study(system, space={"spring.stiffness": (10.0, 1000.0)},
                        outputs={"x_end": x_end, "miss": lambda r: 1e6 * (x_end(r) - target) ** 2}, simulate=KW)
    grid = st.run(design="grid", n=34, workers=1, progress=False)  # spacing 30 N/m
    spacing = 990.0 / 33
    k_grid = grid.loc[grid["miss"].idxmin(), "spring.stiffness"]
    assert abs(k_grid - 400.0) <= spacing
    store = tmp_path / "opt"
    res = st.optimize("miss", n_trials=8, batch=4, sampler="tpe", seed=1, store=store, workers=1)
    assert len(res.trials) == 8
    res = st.optimize("miss", n_trials=24, batch=4, sampler="tpe", seed=1, store=store, workers=1)  # resumes: 16 more
    assert len(res.trials) == 24 and (res.trials["state"] == "COMPLETE").all()
    assert abs(res.best_params["spring.stiffness"] - k_grid) <= spacing
    rows = pl.study.Store(store).read()
    # every trial a stored row, once (TPE may propose a point twice: it is run once)
    assert rows["key"].is_unique and set(rows["key"]) == set(res.trials["user_attrs_key"])
    # with the constraint x_end <= the x_end of k = 700 N/m the optimum moves to the boundary:
    # checked against the best feasible point of the dense grid
    x700 = float(x_end(pl.simulate(system.with_params({"spring.stiffness": 700.0}), progress=False, **KW)))
    feasible = grid[grid["x_end"] <= x700]
    k_c = feasible.loc[feasible["miss"].idxmin(), "spring.stiffness"]
    assert abs(k_c - 400.0) > 2 * spacing  # the constraint is active
    res_c = st.optimize("miss", {"x_end": ("<=", x700)}, n_trials=24, batch=4, seed=2, workers=1)
    assert res_c.best_params["spring.stiffness"] == pytest.approx(k_c, abs=spacing)
    assert max(res_c.optuna_study.best_trial.user_attrs["constraints"]) <= 0.0


@pytest.mark.slow
def test_gradient_refinement_improves_on_its_start(system):
    target = float(x_end(pl.simulate(system.with_params({"spring.stiffness": 400.0}), progress=False, **KW)))
    st = pl.study.Study(system, space={"spring.stiffness": (10.0, 1000.0)},
                        outputs={"miss": lambda r: 1e6 * (x_end(r) - target) ** 2}, simulate=dict(KW, fixed_step=1e-3))
    ref = st.refine({"spring.stiffness": 550.0}, "miss", maxiter=15)
    assert ref["value"] < 1e-3 * ref["start_value"]
    assert ref["params"]["spring.stiffness"] == pytest.approx(400.0, rel=2e-2)
    # from the best trial of an optimisation: four random trials (one vmap batch), then gradients
    opt = st.optimize("miss", n_trials=4, batch=4, seed=4, workers=1, progress=False)
    ref = st.refine(opt, "miss", maxiter=15)
    assert ref["start_value"] == pytest.approx(opt.best_value, rel=1e-9)
    assert ref["value"] < 1e-3 * opt.best_value and ref["params"]["spring.stiffness"] == pytest.approx(400.0, rel=2e-2)


@pytest.mark.slow
def test_study_sobol_runs_through_the_store_and_the_report(system, tmp_path):
    # damping over a 2e-5 wide range cannot move x_end: all the variance is the stiffness's
    st = pl.study.Study(system, space={"spring.stiffness": (10.0, 1000.0), "spring.damping": (0.5, 0.50001)},
                        outputs={"x_end": x_end}, simulate=KW)
    si = st.sobol(16, seed=1, store=tmp_path / "s", workers=1).set_index("parameter")
    assert si.loc["spring.damping", "ST"] < 1e-3 and abs(si.loc["spring.damping", "S1"]) < 1e-3
    assert si.loc["spring.stiffness", "ST"] == pytest.approx(1.0, abs=0.2)
    assert len(pl.study.Store(tmp_path / "s").read()) == 16 * 4
    from proleg.study.report import study_report

    html = study_report(tmp_path / "s").read_text()
    assert "Sobol" in html and html.count("<img") >= 3
