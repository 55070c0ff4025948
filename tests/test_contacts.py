"""Contacts in a model: bouncing ball (energy, Hertz impact), IMPACT as a user Force, block on an incline.

Two assembled systems serve the whole module (jit compilation dominates the run time):

``balls``   two identical spheres side by side, m = 1 kg, R = 0.02 m, dropped from 0.02 m:
            ``ball`` on a SphereContact against the ground plane z = 0 (k = 1e6 N/m^1.5,
            e = 1.5, no damping, no friction); ``puck`` on a user Force whose value is
            ``pl.fn.impact(z, ż, R, k, e, 0, d)`` — the same law written by hand.
``block``   a 0.2 × 0.2 × 0.05 m box (1 kg) on four PointContacts at its bottom corners; the
            incline is gravity turned by θ about y (``gravity_on``), so the plane stays z = 0
            and the block slides along ground x.

Closed forms
------------
Undamped Hertz impact of a mass m at normal speed v0 (proleg.contact_law.impact_response):
δ_max = ((e+1) m v0² / (2k))^(1/(e+1)), F_max = k δ_max^e, T = C(e) δ_max / v0.

Block on an incline of angle θ (friction μ_s = 0.8, μ_d = 0.6):
tan θ < μ_s: it stays; the Adams friction law μ(v) = STEP(v, −v_s, −μ_s, v_s, μ_s) for
|v| < v_s is a steep viscous law, not a true stiction, so the block *creeps* at the speed where
μ(v_c) = tan θ, i.e. v_c = v_s (2Δ − 1) with 3Δ² − 2Δ³ = (1 + tan θ/μ_s)/2, about
v_s tan θ / (1.5 μ_s). With v_s = 2e-6 m/s and θ = 20° that is 6.3e-7 m/s, so the block moves
less than 1e-6 m in 1 s (v_s = 1e-5, a common "small" value, would give 3.1e-6 m per second).
tan θ > μ_d (sliding, |v| > v_friction): a = g (sin θ − μ_d cos θ).
"""

import jax.numpy as jnp
import numpy as np
import pytest
from scipy.optimize import brentq

import proleg as pl
from proleg.contact_law import impact_response

G = 9.81
M, R = 1.0, 0.02  # ball mass [kg], radius [m]
K, EXP = 1e6, 1.5  # contact stiffness [N/m^1.5], exponent
D_FULL = 1e-4  # penetration of full damping [m] (damping is 0 here)
H_DROP = 0.02  # drop height of the ball's lowest point [m]
I_BALL = 0.4 * M * R**2

# Tolerances for the ball runs (tighter than the defaults rtol = 1e-6, atol = 1e-7): with the
# defaults the generalized-α solution loses ~3e-4 of the energy over ten bounces; at
# rtol = 1e-10, atol = 1e-11 the measured drift is ~1e-5. dt_max is given explicitly so the
# energy run (outputs every 1 ms) and the Hertz run (every 20 µs) share one compiled solver.
BALL_OPTS = dict(integrator=pl.GeneralizedAlpha(rtol=1e-10, atol=1e-11, dt_max=1e-3))


# ---------------------------------------------------------------------------------------------
# balls
# ---------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def balls():
    model = pl.Model("balls", gravity=(0, 0, -G))
    z0 = R + H_DROP
    ball = model.add_part("ball", M, (I_BALL,) * 3, (0, 0, z0))
    centre = model.add_marker(ball, "ball_centre", (0, 0, z0))
    model.add_contact(
        pl.SphereContact("ball_floor", centre, radius=R, stiffness=K, exponent=EXP, damping=0.0, penetration=D_FULL)
    )
    puck = model.add_part("puck", M, (I_BALL,) * 3, (1.0, 0, z0))

    def floor(t, state):
        z, zd = state.position("puck")[2], state.velocity("puck")[2]
        return jnp.stack([0.0, 0.0, pl.fn.impact(z, zd, R, K, EXP, 0.0, D_FULL)])

    model.add_force(pl.Force("puck_floor", puck, floor))
    return pl.assemble(model)


@pytest.fixture(scope="module")
def bounces(balls):
    return pl.simulate(balls, t_end=1.5, dt_output=1e-3, **BALL_OPTS)


def test_energy_conserved_over_ten_bounces(bounces):
    """No damping, no friction: T + V (V includes the contact's k g^(e+1)/(e+1)) is constant.

    res.energy.total = T + V + dissipated − input; the puck's IMPACT force is a user Force, so
    its work enters as ``input`` — the total is still conserved.
    """
    fn = bounces.contact("ball_floor").normal_force
    n_bounces = int(np.sum(np.diff((fn > 0).astype(int)) == 1))
    assert n_bounces >= 10
    E = bounces.energy.total
    E0 = M * G * (R + H_DROP) * 2  # both bodies at rest, z = R + h
    assert E[0] == pytest.approx(E0, rel=1e-12)
    assert np.max(np.abs(E - E0)) / E0 < 1e-4
    # Each ball on its own: T + m g z (+ contact energy) — the rebound apex stays at the drop height.
    z = bounces.part("ball").position[:, 2]
    late = bounces.t > 1.2
    assert np.max(z[late]) == pytest.approx(R + H_DROP, abs=1e-4 * H_DROP + 1e-6)


def test_impact_force_in_a_user_force_matches_sphere_contact(bounces):
    """The same IMPACT law as a Force (pl.fn.impact) and as a SphereContact give one trajectory;
    the Force is exactly zero out of contact, so the first fall is the free-fall parabola."""
    za = bounces.part("ball").position[:, 2]
    zb = bounces.part("puck").position[:, 2]
    np.testing.assert_allclose(zb, za, rtol=0, atol=1e-9)
    f = bounces.force("puck_floor").force[:, 2]
    np.testing.assert_allclose(f, bounces.contact("ball_floor").normal_force, rtol=1e-6, atol=1e-6 * np.max(f))
    out = zb > R
    assert np.all(f[out] == 0.0)
    assert np.all(f[zb < R - 1e-6] > 0.0)
    t = bounces.t
    t_hit = np.sqrt(2 * H_DROP / G)
    free = t < t_hit - 1e-3
    np.testing.assert_allclose(zb[free], R + H_DROP - 0.5 * G * t[free] ** 2, rtol=0, atol=1e-9)


def test_single_impact_matches_hertz(balls):
    """Without gravity, a ball hitting at v0 = 1 m/s: peak force and contact duration against
    Hertz (impact_response) within 2 %; rebound speed = v0 (no damping)."""
    v0 = 1.0
    q0 = np.array(balls.params["q_init"])
    v_init = np.zeros_like(q0)
    for b in (0, 1):  # both bodies: 1 mm above the ground, moving down at v0
        q0[7 * b + 2] = R + 1e-3
        v_init[7 * b + 2] = -v0
    res = pl.simulate(balls.with_params(gravity=np.zeros(3)), t_end=0.02, dt_output=2e-5, q0=q0, v0=v_init, **BALL_OPTS)
    c = res.contact("ball_floor")
    hz = impact_response(M, v0, K, EXP)
    g, t = c.penetration, res.t
    edges = np.nonzero(np.diff((g > 0).astype(int)))[0]
    assert len(edges) == 2  # one contact phase

    def crossing(i):  # linear interpolation of g = 0 between samples (20 µs apart)
        return t[i] - g[i] * (t[i + 1] - t[i]) / (g[i + 1] - g[i])

    duration = crossing(edges[1]) - crossing(edges[0])
    assert np.max(c.normal_force) == pytest.approx(float(hz.peak_force), rel=0.02)
    assert duration == pytest.approx(float(hz.duration), rel=0.02)
    assert np.max(g) == pytest.approx(float(hz.max_penetration), rel=0.02)
    assert res.part("ball").velocity[-1, 2] == pytest.approx(v0, rel=1e-5)
    # measured: all three within 2e-5 of the closed form; rebound 1 − 3e-7


# ---------------------------------------------------------------------------------------------
# block on an incline
# ---------------------------------------------------------------------------------------------
MU_S, MU_D = 0.8, 0.6
V_STICTION = 2e-6  # [m/s] see the module docstring: creep speed ≈ v_s tan θ / (1.5 μ_s)
HALF, HZ, MB = 0.1, 0.025, 1.0  # half width, half height [m], mass [kg]


def gravity_on(theta):
    """Gravity for an incline of angle θ that descends towards +x (the plane stays z = 0)."""
    return np.array([G * np.sin(theta), 0.0, -G * np.cos(theta)])


@pytest.fixture(scope="module")
def block():
    model = pl.Model("block", gravity=(0, 0, -G))
    k, e = 1e6, 1.5
    sink = (MB * G / 4 / k) ** (1 / e)  # static penetration of each corner on flat ground
    zc = HZ - sink
    ixx = MB * ((2 * HALF) ** 2 + (2 * HZ) ** 2) / 12
    izz = MB * (2 * (2 * HALF) ** 2) / 12
    box = model.add_part("box", MB, (ixx, ixx, izz), (0, 0, zc))
    for n, (sx, sy) in enumerate([(1, 1), (1, -1), (-1, 1), (-1, -1)]):
        corner = model.add_marker(box, f"corner{n}", (sx * HALF, sy * HALF, zc - HZ))
        model.add_contact(
            pl.PointContact(
                f"corner{n}", corner, stiffness=k, exponent=e, damping=100.0, penetration=1e-4,
                mu_static=MU_S, mu_dynamic=MU_D, v_stiction=V_STICTION, v_friction=2 * V_STICTION,
            )
        )
    return pl.assemble(model)


def creep_speed(theta):
    """v_c with μ(v_c) = tan θ on the stiction branch μ = μ_s (2 S(Δ) − 1), S = 3Δ² − 2Δ³."""
    target = 0.5 * (1 + np.tan(theta) / MU_S)
    d = brentq(lambda x: 3 * x**2 - 2 * x**3 - target, 0.5, 1.0, xtol=1e-15)
    return V_STICTION * (2 * d - 1)


def run_incline(block, theta):
    return pl.simulate(block.with_params(gravity=gravity_on(theta)), t_end=1.2, dt_output=1e-3)


def test_block_stays_below_static_friction(block):
    """θ = 20° (tan θ = 0.364 < μ_s = 0.8): after the 0.2 s settling of the normal contact the
    block moves less than 1e-6 m in 1 s, and creeps at the closed-form speed v_c (6.3e-7 m/s)."""
    theta = np.radians(20.0)
    res = run_incline(block, theta)
    x = res.part("box").position[:, 0]
    i0 = np.searchsorted(res.t, 0.2)
    moved = x[-1] - x[i0]
    assert abs(moved) < 1e-6  # measured 6.27e-7 m
    assert res.part("box").velocity[-1, 0] == pytest.approx(creep_speed(theta), rel=1e-3)
    # the friction force holds the weight component: Σ F_t = m g sin θ
    ft = sum(res.contact(f"corner{n}").friction_force[-1, 0] for n in range(4))
    assert ft == pytest.approx(-MB * G * np.sin(theta), rel=1e-6)


def test_block_slides_with_dynamic_friction(block):
    """θ = 40° (tan θ = 0.839 > μ_s): a = g (sin θ − μ_d cos θ) within 1 %, from the slope of
    the COM velocity after t = 0.4 s."""
    theta = np.radians(40.0)
    res = run_incline(block, theta)
    t, v = res.t, res.part("box").velocity[:, 0]
    late = t > 0.4
    a = np.polyfit(t[late], v[late], 1)[0]
    a_exact = G * (np.sin(theta) - MU_D * np.cos(theta))
    assert a == pytest.approx(a_exact, rel=0.01)  # measured agreement ~1e-11
