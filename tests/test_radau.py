"""Radau5 (solvers/radau.py): Radau IIA, order 5, on the index-2 (GGL) constrained equations.

A closed loop (the slider-crank of test_planar: a crank driven by a constant torque, a rod, a
slider on a prismatic, under gravity; 1 degree of freedom, redundant rows removed at assembly)
is the smooth DAE: observed order, constraints held at every step, energy balance following
rtol, vmap, agreement with generalized-α in absolute coordinates, a sampled controller, bad input."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from test_planar import slider_crank

import proleg as pl
from proleg.assembly.system import constraints

T_END = 0.2
PARTS = ("crank", "rod", "slider")


@pytest.fixture(scope="module")
def sc():
    with pytest.warns(UserWarning, match="redundant"):
        return pl.assemble(slider_crank())


def _final_positions(r):
    return np.concatenate([np.asarray(r.part(n).position[-1]) for n in PARTS])


def test_observed_order(sc):
    """Constant steps h = 5, 2.5, 1.25 ms over 0.1 s: the final COM positions' error against
    h = 0.3125 ms falls as h^p with p within 0.3 of 5 (Radau IIA keeps order 2s − 1 = 5 in the
    differential variables of an index-2 Hessenberg DAE: Hairer, Lubich & Roche 1989; the
    reference's own error is ~4⁻⁵ of the smallest step's). Measured: 4.6e-9, 1.5e-10, 4.6e-12 m,
    slope 4.98. (At 10 ms the frozen-Jacobian Newton stops converging on this crank.)"""
    run = lambda h: pl.simulate(sc, t_end=0.1, output_times=[0.0, 0.05, 0.1], integrator=pl.Radau5(fixed_step=h, max_newton=30))  # noqa: E731
    ref = _final_positions(run(0.0003125))
    hs = np.array([0.005, 0.0025, 0.00125])
    err = [np.abs(_final_positions(run(h)) - ref).max() for h in hs]
    slope = np.polyfit(np.log(hs), np.log(err), 1)[0]
    assert abs(slope - 5.0) < 0.3, (slope, err)


def _energy_error(r):
    """max |E(t) − E(0)| / max T with E = T + V + dissipated − input work (the drive's)."""
    E, T = np.asarray(r.energy["total"]), np.asarray(r.energy["kinetic"])
    return np.abs(E - E[0]).max() / T.max()


def test_energy_follows_rtol_and_loop_holds(sc):
    """rtol 1e-5 → 1e-8 (atol = rtol/10): the energy-balance error falls at least 100×, and every
    joint equation of the absolute model holds to atol + rtol max|q| at every output (the GGL
    form enforces Φ = 0 and Φ_q v + Φ_t = 0 at each stage, to the Newton tolerance). Measured: 1.7e-6 and
    1.5e-9 (1100×), |Φ| ≤ 1.3e-11."""
    times = np.linspace(0.0, T_END, 21)
    runs = [pl.simulate(sc, t_end=T_END, output_times=times, integrator=pl.Radau5(rtol=rtol, atol=rtol / 10)) for rtol in (1e-5, 1e-8)]
    errs = [_energy_error(r) for r in runs]
    assert errs[0] / errs[1] >= 100.0, errs
    # Radau5 has no constraint tolerance of its own: Φ = 0 is a stage equation, solved by Newton
    # to fnewt·(atol + rtol|y|), fnewt ≤ 0.03 (solvers/radau.py), and an output between the
    # stages lies on the collocation polynomial, within the error control's atol + rtol|q| of the
    # solution. The links are ≤ 1 m long (|Φ_q| ≤ ~1), so |Φ| ≤ atol + rtol max|q| (≥ 1e-9),
    # against 1.3e-11 measured.
    q_max = np.abs(np.asarray(runs[1].q)).max()
    assert np.max(runs[1].constraint_residual()) <= 1e-9 + 1e-8 * q_max  # atol + rtol max|q| of the tight run
    assert runs[1].coordinates == "planar" and runs[1].stats["steps"] > 0


@pytest.mark.slow
def test_vmap_equals_loop(sc):
    """jax.vmap over 4 slider masses equals the loop of single runs within 1e-12 m."""

    def final_x(m):
        r = pl.simulate(sc.with_params({"slider.mass": m}), t_end=0.1, output_times=[0.0, 0.1], integrator=pl.Radau5(rtol=1e-8, atol=1e-9))
        return r.part("slider").position[-1, 0]

    ms = jnp.linspace(0.8, 2.0, 4)
    np.testing.assert_allclose(jax.vmap(final_x)(ms), jnp.array([final_x(m) for m in ms]), rtol=0, atol=1e-12)


@pytest.mark.slow
def test_absolute_coordinates_agree_with_generalized_alpha(sc):
    """In absolute coordinates (7 per part, Euler-parameter rows kept), Radau5 at rtol 1e-10 and
    generalized-α at rtol 1e-10 give the same slider motion within 1e-6 m (GA's global error
    at that tolerance, measured ~1e-7 m), and every constraint row holds to 1e-9."""
    opts = dict(t_end=T_END, dt_output=0.02)
    a = pl.simulate(sc, integrator=pl.GeneralizedAlpha(rtol=1e-10, atol=1e-11), coordinates="absolute", **opts)
    b = pl.simulate(sc, integrator=pl.Radau5(rtol=1e-10, atol=1e-11), coordinates="absolute", **opts)
    assert b.coordinates == "absolute"
    phi = jax.jit(jax.vmap(lambda q, t: constraints(sc, q, t)))(b.q, jnp.asarray(b.t))
    assert np.abs(np.asarray(phi)).max() <= 1e-9
    assert np.abs(a.part("slider").position - b.part("slider").position).max() < 1e-6


@pytest.mark.parametrize("kw, match", [
    (dict(rtol=0.0), "rtol"), (dict(rtol=-1e-6), "rtol"), (dict(atol=float("nan")), "atol"),
    (dict(max_newton=1), "max_newton"), (dict(fixed_step=-1e-3), "fixed_step"), (dict(linear_solver="qr"), "linear_solver"),
])
def test_bad_input(kw, match):
    with pytest.raises(pl.ModelError, match=match):
        pl.Radau5(**kw)


def test_sampled_pid_same_as_generalized_alpha():
    """A rod on a pin driven by a PID sampled every PERIOD (test_controllers.py): Radau5 steps
    land on the sample times with the command held between them, and the joint angle equals
    the generalized-α run's (both at rtol 1e-8) within 5e-6 rad over 0.3 s (the tolerance of
    the Tsit5 twin of this test in test_ode_integrators.py: GA's own error at that rtol)."""
    from test_controllers import SET
    from test_ode_integrators import sampled_servo

    system = sampled_servo()
    opts = dict(t_end=0.3, dt_output=0.01)
    a = pl.simulate(system, integrator=pl.GeneralizedAlpha(rtol=1e-8, atol=1e-9), **opts)
    b = pl.simulate(system, integrator=pl.Radau5(rtol=1e-8, atol=1e-9), **opts)
    angle = lambda r: np.unwrap(np.arctan2(r.part("rod").orientation[:, 1, 0], r.part("rod").orientation[:, 0, 0]))  # noqa: E731
    assert np.abs(angle(b) - SET).min() < 0.5 * abs(SET)  # it moved towards the setpoint
    assert np.abs(angle(a) - angle(b)).max() < 5e-6
    # The controller states (commands) follow the angles through the gains: measured difference
    # 7.8e-5 of a largest value 31.25 (2.5e-6 relative); bound 1e-5 relative.
    np.testing.assert_allclose(b.z, a.z, rtol=0, atol=1e-5 * float(np.abs(a.z).max()))
