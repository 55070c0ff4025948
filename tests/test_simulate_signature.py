"""simulate()'s grouped options: the integrator object carries tolerances and step limits,
SaveAt the output request, RunOptions how the run goes; the old flat keywords still work for one
release with a DeprecationWarning that names the new place, and give the same numbers.

Model: a uniform rod (1 kg, 1 m) on a pin, released from 60°; 0.1 s.
"""

import warnings

import numpy as np
import pytest

import proleg as pl


@pytest.fixture(scope="module")
def system():
    model = pl.Model("signature_rod", gravity=(0, 0, -9.81))
    rod = model.add_part("rod", mass=1.0, inertia=(1 / 12, 1 / 12, 1e-3), position=(0.5 * np.sin(np.pi / 3), 0, -0.25))
    model.add_joint(pl.Revolute("pin", model.ground, rod, at=(0, 0, 0), axis=(0, 1, 0)))
    return pl.assemble(model)


@pytest.mark.parametrize(
    "old, new, place",
    [
        (dict(rtol=1e-8, atol=1e-9), dict(integrator=pl.GeneralizedAlpha(rtol=1e-8, atol=1e-9)), "GeneralizedAlpha(rtol"),
        (dict(dt_max=1e-3), dict(integrator=pl.GeneralizedAlpha(dt_max=1e-3)), "GeneralizedAlpha(dt_max"),
        (dict(chunk=4), dict(integrator=pl.GeneralizedAlpha(), run=pl.RunOptions(chunk=4)), "RunOptions(chunk"),
    ],
)
def test_old_keywords_warn_and_give_the_same_run(system, old, new, place):
    """Flat options beside a NAMED integrator are deprecated (they belong to the object)."""
    with pytest.warns(DeprecationWarning, match=place.replace("(", r"\(")):
        a = pl.simulate(system, 0.1, 0.01, progress=False, integrator=pl.GeneralizedAlpha(), **old)
    with warnings.catch_warnings():
        warnings.simplefilter("error", DeprecationWarning)
        b = pl.simulate(system, 0.1, 0.01, progress=False, **new)
    assert a.stats == b.stats
    # bitwise: both spellings build the same integrator, so the same executable runs twice in one
    # process; identity is what is tested
    np.testing.assert_array_equal(np.asarray(a.q), np.asarray(b.q))
    assert a.integrator == b.integrator


def test_flat_tolerances_without_an_integrator_go_to_auto(system):
    """simulate(rtol=...) with no integrator named is the tolerance request of "auto": no
    warning, the method chosen carries it (a pin: Tsit5), the same run as Auto(rtol=...)."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", DeprecationWarning)
        a = pl.simulate(system, 0.1, 0.01, progress=False, rtol=1e-9, atol=1e-10)
        b = pl.simulate(system, 0.1, 0.01, progress=False, integrator=pl.Auto(rtol=1e-9, atol=1e-10))
    assert isinstance(a.integrator, pl.Tsit5) and a.integrator.rtol == 1e-9 and a.integrator.atol == 1e-10
    np.testing.assert_array_equal(np.asarray(a.q), np.asarray(b.q))


def test_hht_carries_its_options_and_saveat_equals_output_times(system):
    """HHT(α, rtol=...) takes the same options; SaveAt(times=...) is output_times=."""
    times = np.array([0.0, 0.013, 0.05, 0.1])
    a = pl.simulate(system, 0.1, saveat=pl.SaveAt(times=times), integrator=pl.HHT(-0.1, rtol=1e-7))
    b = pl.simulate(system, 0.1, output_times=times, integrator=pl.HHT(-0.1, rtol=1e-7))
    np.testing.assert_array_equal(a.t, times)
    np.testing.assert_array_equal(np.asarray(a.q), np.asarray(b.q))
    assert a.integrator.rtol == 1e-7 and a.integrator.alpha == -0.1


def test_bad_options_name_the_integrator():
    with pytest.raises(pl.ModelError, match="GeneralizedAlpha rtol"):
        pl.GeneralizedAlpha(rtol=0.0)
    with pytest.raises(pl.ModelError, match="HHT dt_max"):
        pl.HHT(dt_max=-1.0)
    with pytest.raises(pl.ModelError, match="SaveAt times"):
        pl.SaveAt(times=[0.0, 0.2, 0.1]).output_times(0.0, 1.0)


def test_simulate_kwargs_groups_flat_options_without_warning(system):
    from proleg.analyses.simulate import simulate_kwargs

    with warnings.catch_warnings():
        warnings.simplefilter("error", DeprecationWarning)
        kw = simulate_kwargs({"t_end": 1.0, "rtol": 1e-5, "free_running": True})
    assert kw["t_end"] == 1.0
    assert kw["integrator"].rtol == 1e-5 and kw["run"].free_running
    with pytest.raises(TypeError, match="not_an_option"):
        pl.simulate(system, 0.1, 0.01, **simulate_kwargs({"rtol": 1e-5, "not_an_option": 1}))


def test_the_old_keywords_fail_the_suite_outside_pytest_warns(system):
    """pyproject.toml's filterwarnings makes proleg's own deprecations errors in the test suite, so
    that no test slips back to the old spellings (the run stops before anything is compiled)."""
    with pytest.raises(DeprecationWarning, match="simulate\\(rtol=...\\) is deprecated and will be removed in the next release"):
        pl.simulate(system, 0.1, 0.01, progress=False, integrator=pl.GeneralizedAlpha(), rtol=1e-7)
