"""SlideFriction: stick–slip friction in a prismatic joint under its side load (issue 31).

Closed forms:
- a block of mass m on a fixed incline (angle θ), held by a prismatic joint along the slope and
  pulled up it by F(t) = k t, with μ_s > tan θ: it sticks (|v| ≤ v_s) while
  |F − m g sin θ| < μ_s m g cos θ, breaks away at t* = m g (sin θ + μ_s cos θ) / k, and then
  slides with m a = k t − m g sin θ − μ_d m g cos θ, so between two sliding instants
  v(t2) − v(t1) = [k (t2² − t1²)/2 − m g (sin θ + μ_d cos θ)(t2 − t1)] / m;
- a slider on a horizontal rail (no gravity) pushed along the rail by P and sideways by S:
  N = S, m a = P − μ_d S (friction grows linearly with the side load); with an overlap L and
  the side force applied ℓ(t) from the bearing centre, N = S (1 + |ℓ| / L) (Adams FRICTION,
  translational joint).
"""

import numpy as np
import pytest

import proleg as pl
from proleg.errors import ModelError

G = 9.81


def incline(theta, m=2.0, k=10.0, mu_s=0.5, mu_d=0.3, v_s=1e-3, v_d=5e-3):
    d = np.array([np.cos(theta), 0.0, np.sin(theta)])  # up the slope
    mdl = pl.Model("incline", gravity=(0, 0, -G))
    b = mdl.add_part("block", mass=m, inertia=(0.01,) * 3, position=(0, 0, 0))
    j = mdl.add_joint(pl.Prismatic("slide", b, mdl.ground, at=(0, 0, 0), axis=d))
    mdl.add_force(pl.SlideFriction("friction", j, mu_static=mu_s, mu_dynamic=mu_d, v_stiction=v_s, v_friction=v_d))
    mdl.add_force(pl.Force("pull", b, lambda t: k * t * d))
    return mdl


@pytest.fixture(scope="module")
def incline_run():
    th = np.radians(20.0)
    res = pl.simulate(pl.assemble(incline(th)), t_end=2.5, dt_output=1e-3, integrator=pl.GeneralizedAlpha(rtol=1e-8))
    return th, res


def test_block_on_incline_sticks_then_slips(incline_run):
    th, res = incline_run
    m, k, mu_s, mu_d, v_s, v_d = 2.0, 10.0, 0.5, 0.3, 1e-3, 5e-3
    t = res.t
    v = res.element("friction").rate
    t_star = m * G * (np.sin(th) + mu_s * np.cos(th)) / k
    stuck = t < 0.99 * t_star
    assert np.max(np.abs(v[stuck])) <= v_s * (1 + 1e-6)  # creeping within the stiction band
    t_break = t[np.argmax(v > v_s)]
    assert abs(t_break - t_star) < 0.01 * t_star  # breakaway where the pull reaches μ_s N
    # sliding: exact dynamics with μ_d once v > v_d
    slide = np.flatnonzero(v > v_d)
    i1, i2 = slide[5], len(t) - 1
    t1, t2 = t[i1], t[i2]
    dv = (k * (t2**2 - t1**2) / 2 - m * G * (np.sin(th) + mu_d * np.cos(th)) * (t2 - t1)) / m
    np.testing.assert_allclose(v[i2] - v[i1], dv, rtol=1e-5)
    out = res.element("friction")
    np.testing.assert_allclose(out.normal_load, m * G * np.cos(th), rtol=1e-9)  # gravity's normal part


def test_incline_energy_balance(incline_run):
    """Work of the pull = ΔT + ΔV + friction dissipation (the result's bookkeeping)."""
    th, res = incline_run
    e = res.energy
    lhs = e.input[-1] - e.input[0]
    rhs = (e.kinetic[-1] + e.potential[-1]) - (e.kinetic[0] + e.potential[0]) + (e.dissipated[-1] - e.dissipated[0])
    # the result integrates the powers step by step (second order); 305 steps through the
    # stick-slip kink leave ~1e-5 of the work: 1e-4 bounds it, a missing dissipation term is ~0.3
    assert abs(lhs - rhs) < 1e-4 * abs(lhs)
    assert e.dissipated[-1] > 0.2 * lhs


def rail(side, push=20.0, m=1.5, mu=0.2, overlap=None, lever=0.0):
    mdl = pl.Model("rail", gravity=(0, 0, 0))
    b = mdl.add_part("slider", mass=m, inertia=(0.01,) * 3, position=(0, 0, 0))
    j = mdl.add_joint(pl.Prismatic("rail", b, mdl.ground, at=(0, 0, 0), axis=(1, 0, 0)))
    mdl.add_force(pl.SlideFriction("friction", j, mu_static=mu, mu_dynamic=mu, v_stiction=1e-4, v_friction=1e-3, overlap=overlap, bearing_offset=-lever))
    mdl.add_force(pl.Force("push", b, (push, 0.0, 0.0)))
    mdl.add_force(pl.Force("side", b, (0.0, side, 0.0)))
    return mdl


@pytest.mark.parametrize("side", [0.0, 30.0, 60.0])
def test_friction_grows_with_side_load(side):
    m, P, mu = 1.5, 20.0, 0.2
    res = pl.simulate(pl.assemble(rail(side)), t_end=0.5, dt_output=1e-2, integrator=pl.GeneralizedAlpha(rtol=1e-8))
    x = res.joint("rail").translation
    t = res.t
    a = (P - mu * side) / m  # sliding from the start: the push exceeds μ S
    sel = t > 0.1
    # x(t) = a t²/2 up to the sub-millisecond stiction transition at the start
    np.testing.assert_allclose(np.diff(x[sel], 2) / np.diff(t)[0] ** 2, a, rtol=1e-4)
    np.testing.assert_allclose(res.element("friction").normal_load, side, atol=1e-6)


def test_bending_moment_adds_over_overlap():
    S, L, lever = 40.0, 0.05, 0.1
    res = pl.simulate(pl.assemble(rail(S, push=40.0, overlap=L, lever=lever)), t_end=0.3, dt_output=1e-2, integrator=pl.GeneralizedAlpha(rtol=1e-8))
    out = res.element("friction")
    ell = lever + res.joint("rail").translation  # the force point moves with the slider
    np.testing.assert_allclose(out.normal_load, S * (1 + np.abs(ell) / L), rtol=1e-8)
    np.testing.assert_allclose(out.bending_moment, S * np.abs(ell), rtol=1e-8)


def test_slide_friction_errors():
    mdl = pl.Model("bad", gravity=(0, 0, 0))
    b = mdl.add_part("b", mass=1.0, inertia=(1.0,) * 3, position=(0, 0, 0))
    rj = mdl.add_joint(pl.Revolute("pin", b, mdl.ground, at=(0, 0, 0), axis=(0, 0, 1)))
    with pytest.raises(ModelError, match="pin"):
        mdl.add_force(pl.SlideFriction("f", rj, mu_static=0.1))
    with pytest.raises(ModelError, match="mu_dynamic"):
        pl.SlideFriction("f", rj, mu_static=0.1, mu_dynamic=0.2)
    with pytest.raises(ModelError, match="v_stiction"):
        pl.SlideFriction("f", rj, mu_static=0.1, v_stiction=0.1, v_friction=0.01)
