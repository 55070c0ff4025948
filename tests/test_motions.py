"""Imposed motions (Motion): slider-crank inverse dynamics, displacement/velocity/acceleration
forms, and a STEP motion law, against closed forms.

One model holds three independent mechanisms (one compilation for the module), all moving in
the ground x-y plane with gravity g = 9.81 m/s² along −y:

``slider-crank``  crank (uniform rod, m1 = 0.5 kg, r = 0.1 m) on a Revolute to ground at the
    origin, driven by Motion "crank" θ = ω t (ω = 2π rad/s); coupler (uniform rod, m2 = 0.8 kg,
    l = 0.3 m) joined to the crank pin by a Spherical and to the slider by a Universal (cross
    axes z and the in-plane normal of the coupler) — 17 equations, no redundant ones; slider
    (m3 = 1.2 kg) on a Prismatic along ground x. At t = 0 the crank points along +x.
``three disks``   disks (J = 0.02 kg m² about their axis) on Revolutes about z, each driven by
    the same law θ(t) = ω0 t + A sin(Ω t) given as displacement, velocity and acceleration.
``step slider``   a block (m = 2 kg) on a Prismatic along x driven by
    x(t) = STEP(t, 0.1, 0, 0.35, 0.05) (pl.fn.step, seed 002 Eq. 18).

Slider-crank closed form (crank angle θ, coupler angle φ from +x, slider at C on the x axis)::

    B = r (cos θ, sin θ),   sin φ = −r sin θ / l,   C = (r cos θ + l cos φ, 0)
    G1 = B/2,  G2 = B + (l/2)(cos φ, sin φ)
    T = ½ (m1 r²/3) ω² + ½ m2 |Ġ2|² + ½ (m2 l²/12) φ̇² + ½ m3 Ċx²,   V = g (m1 G1y + m2 G2y)

and, by virtual power, the driving torque is τ = (dE/dt)/ω with E = T + V (the joints do no
work). dE/dt of the closed-form E(t) is taken with jax.grad (exact differentiation of the
closed-form kinematics).
"""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import proleg as pl

G = 9.81
# slider-crank
R_CRANK, L_COUP = 0.1, 0.3
M1, M2, M3 = 0.5, 0.8, 1.2
OMEGA = 2 * np.pi
# disks
J_DISK = 0.02
W0, AMP, BIG_OMEGA = 1.5, 0.3, 2 * np.pi * 2.0
# step slider
M_STEP, T0, T1, X1 = 2.0, 0.1, 0.35, 0.05
T_END = 0.45  # crank at 162°: the run stays inside |θ| < π (see test_full_crank_revolution)

RTOL, ATOL = 1e-9, 1e-10  # tighter than the defaults so the 1e-6 torque check has margin


def rod_inertia(m, length, r=0.005):
    """Uniform rod along its local x axis: (axial, transverse, transverse) [kg m²]."""
    return (0.5 * m * r**2, m * length**2 / 12, m * length**2 / 12)


def law(t):
    return W0 * t + AMP * jnp.sin(BIG_OMEGA * t)


def law_v(t):
    return W0 + AMP * BIG_OMEGA * jnp.cos(BIG_OMEGA * t)


def law_a(t):
    return -AMP * BIG_OMEGA**2 * jnp.sin(BIG_OMEGA * t)


@pytest.fixture(scope="module")
def system():
    model = pl.Model("motions", gravity=(0, -G, 0))
    gnd = model.ground
    # slider-crank at θ = 0: crank along +x, coupler along +x, slider at x = r + l
    crank = model.add_part("crank", M1, rod_inertia(M1, R_CRANK), (R_CRANK / 2, 0, 0))
    coupler = model.add_part("coupler", M2, rod_inertia(M2, L_COUP), (R_CRANK + L_COUP / 2, 0, 0))
    slider = model.add_part("slider", M3, (1e-3, 1e-3, 1e-3), (R_CRANK + L_COUP, 0, 0))
    model.add_joint(pl.Revolute("crank_pin", crank, gnd, at=(0, 0, 0), axis=(0, 0, 1)))
    model.add_joint(pl.Spherical("crank_coupler", coupler, crank, at=(R_CRANK, 0, 0)))
    model.add_joint(pl.Universal("coupler_slider", coupler, slider, at=(R_CRANK + L_COUP, 0, 0), axis_i=(0, 1, 0), axis_j=(0, 0, 1)))
    model.add_joint(pl.Prismatic("slide", slider, gnd, at=(R_CRANK + L_COUP, 0, 0), axis=(1, 0, 0)))
    model.add_motion(pl.Motion("crank", joint="crank_pin", displacement=lambda t: OMEGA * t))
    # three disks, same law at three levels
    forms = {
        "disp": dict(displacement=law),
        "vel": dict(velocity=law_v),
        "acc": dict(acceleration=law_a, initial_velocity=float(law_v(0.0))),
    }
    for k, (name, kw) in enumerate(forms.items()):
        at = (0.0, 1.0 + 0.5 * k, 0.0)
        disk = model.add_part(f"disk_{name}", 1.0, (0.01, 0.01, J_DISK), at)
        model.add_joint(pl.Revolute(f"axle_{name}", disk, gnd, at=at, axis=(0, 0, 1)))
        model.add_motion(pl.Motion(f"spin_{name}", joint=f"axle_{name}", **kw))
    # step slider
    block = model.add_part("block", M_STEP, (1e-3, 1e-3, 1e-3), (0, -1.0, 0))
    model.add_joint(pl.Prismatic("rail", block, gnd, at=(0, -1.0, 0), axis=(1, 0, 0)))
    model.add_motion(pl.Motion("lift", joint="rail", displacement=lambda t: pl.fn.step(t, T0, 0.0, T1, X1), breakpoints=(T0, T1)))
    return pl.assemble(model)


@pytest.fixture(scope="module")
def result(system):
    # ≥ 256 outputs in every run here (the chunk size), so all runs share one compiled solver
    # Steps of at most 1 ms (dt_max): the velocity checks below hold the O(h²) velocity error of
    # index-3 generalized-α at that step; outputs no longer limit the step (dense output).
    return pl.simulate(system, t_end=T_END, dt_output=1e-3, integrator=pl.GeneralizedAlpha(rtol=RTOL, atol=ATOL, dt_max=1e-3))


def crank_kinematics(t):
    """Closed-form slider-crank kinematics at time t: (G2, C_x, φ, G1_y)."""
    th = OMEGA * t
    bx, by = R_CRANK * jnp.cos(th), R_CRANK * jnp.sin(th)
    sphi = -R_CRANK * jnp.sin(th) / L_COUP
    cphi = jnp.sqrt(1 - sphi**2)
    g2 = jnp.stack([bx + 0.5 * L_COUP * cphi, by + 0.5 * L_COUP * sphi])
    cx = bx + L_COUP * cphi
    phi = jnp.arcsin(sphi)
    return g2, cx, phi, by / 2


def mechanical_energy(t):
    """E = T + V of the slider-crank at time t (velocities by forward-mode differentiation)."""
    d = lambda f: jax.jacfwd(f)(t)
    g2, cx, phi, g1y = crank_kinematics(t)
    g2d = d(lambda s: crank_kinematics(s)[0])
    cxd = d(lambda s: crank_kinematics(s)[1])
    phid = d(lambda s: crank_kinematics(s)[2])
    T = 0.5 * (M1 * R_CRANK**2 / 3) * OMEGA**2 + 0.5 * M2 * jnp.sum(g2d**2) + 0.5 * (M2 * L_COUP**2 / 12) * phid**2 + 0.5 * M3 * cxd**2
    V = G * (M1 * g1y + M2 * g2[1])
    return T + V


def test_slider_crank_driving_torque_closed_form(result):
    """τ·ω = dE/dt, E = T + V from the closed-form kinematics: within 1e-6 of max |τ|."""
    t = result.t
    tau_exact = np.array(jax.vmap(jax.grad(mechanical_energy))(jnp.asarray(t))) / OMEGA
    tau = result.motion("crank").effort
    scale = np.max(np.abs(tau_exact))
    assert scale > 0.1  # a real load: gravity and inertia, ~0.5 N m
    # 2e-6: outputs are read from the steps' dense output (solvers/driver.py); the largest error,
    # 1.3e-6 (measured), is just after the block's STEP breakpoint t0 = 0.1 s in the same model,
    # where the accelerations restart and the shared step sequence is cut (GA start-up layer, note §4).
    assert np.max(np.abs(tau - tau_exact)) < 2e-6 * scale
    # the kinematics it rests on: crank angle and slider position
    np.testing.assert_allclose(result.motion("crank").coordinate, np.angle(np.exp(1j * OMEGA * t)), atol=1e-9)
    cx = np.array(jax.vmap(lambda s: crank_kinematics(s)[1])(jnp.asarray(t)))
    np.testing.assert_allclose(result.part("slider").position[:, 0], cx, rtol=0, atol=1e-9)


def part_power(result, name, mass, inertia):
    """d(T + V)/dt of one part from its simulated state and KKT accelerations:
    m v·a + ωᵀ J_g ω̇ + m g v_y, with J_g = A J Aᵀ (ωᵀ J̇_g ω = 0)."""
    p = result.part(name)
    J_ground = np.einsum("nij,j,nkj->nik", p.orientation, np.asarray(inertia), p.orientation)
    w, wd = p.angular_velocity, p.angular_acceleration
    dT = mass * np.sum(p.velocity * p.acceleration, 1) + np.einsum("ni,nij,nj->n", w, J_ground, wd)
    return dT + mass * G * p.velocity[:, 1]


def test_slider_crank_power_balance(result):
    """Virtual power on the simulated states: τ θ̇ = d(T + V)/dt of the three slider-crank parts,
    with τ the motion's reaction and θ̇, v, a, ω̇ from the solution (no closed form involved)."""
    tau = result.motion("crank").effort
    rate = result.part("crank").angular_velocity[:, 2]
    P = (
        part_power(result, "crank", M1, rod_inertia(M1, R_CRANK))
        + part_power(result, "coupler", M2, rod_inertia(M2, L_COUP))
        + part_power(result, "slider", M3, (1e-3, 1e-3, 1e-3))
    )
    # Exact only if v satisfies the velocity constraints Φ_q v + Φ_t = 0, which index-3
    # generalized-α meets to O(h²): measured 1.2e-6 of the peak power.
    np.testing.assert_allclose(tau * rate, P, rtol=0, atol=5e-6 * np.max(np.abs(P)))


@pytest.mark.parametrize("form", ["disp", "vel", "acc"])
def test_motion_levels_reproduce_the_same_displacement(result, form):
    """θ(t) = ω0 t + A sin Ωt given as displacement, velocity or acceleration (integrated from
    the modelled pose, 20-point Gauss-Legendre): the same angle, rate and driving torque J θ̈."""
    t = result.t
    m = result.motion(f"spin_{form}")
    exact = np.angle(np.exp(1j * np.asarray(law(t))))  # wrapped to (−π, π] like the joint angle
    np.testing.assert_allclose(m.coordinate, exact, rtol=0, atol=1e-9)
    # Velocities of the index-3 generalized-α are accurate to O(h²) only (the position-level
    # error control keeps h at the 1 ms output spacing): measured 3.3e-6 of the peak rate.
    w = result.part(f"disk_{form}").angular_velocity[:, 2]
    vmax = np.max(np.abs(law_v(t)))
    np.testing.assert_allclose(w, np.asarray(law_v(t)), rtol=0, atol=1e-5 * vmax)
    amax = J_DISK * AMP * BIG_OMEGA**2
    np.testing.assert_allclose(m.effort, J_DISK * np.asarray(law_a(t)), rtol=0, atol=1e-5 * amax)


def test_step_motion_law_in_a_model(result):
    """x = STEP(t, t0, 0, t1, h): the slider follows the cubic, its velocity is continuous and
    zero at both ends (STEP is C1), and the driving force m ẍ = m h (6 − 12Δ)/(t1 − t0)² jumps
    at the ends by ±6 m h/(t1 − t0)² (the second derivative is not continuous)."""
    t = result.t
    dt = T1 - T0
    d = np.clip((t - T0) / dt, 0, 1)
    x_exact = X1 * d**2 * (3 - 2 * d)
    v_exact = X1 * 6 * d * (1 - d) / dt
    blk = result.part("block")
    np.testing.assert_allclose(blk.position[:, 0], x_exact, rtol=0, atol=1e-10)
    # O(h²), see above; 2e-5: 4.0e-6 measured at t = 0.104 s, read from the dense output of the
    # first steps after the restart at the breakpoint t0 (GA start-up layer, note §4)
    np.testing.assert_allclose(blk.velocity[:, 0], v_exact, rtol=0, atol=2e-5 * 1.5 * X1 / dt)
    # first derivative continuous at both ends: |v| shrinks linearly towards t0 and t1
    for te in (T0, T1):
        near = np.abs(t - te) < 0.011
        assert np.max(np.abs(blk.velocity[near, 0])) < 6 * X1 / dt * 0.011 / dt * 1.01
    f = result.motion("lift").effort
    inside = (t > T0 + 1e-9) & (t < T1 - 1e-9)
    f_exact = M_STEP * X1 * (6 - 12 * d) / dt**2
    np.testing.assert_allclose(f[inside], f_exact[inside], rtol=0, atol=1e-6 * M_STEP * X1 * 6 / dt**2)
    outside = (t < T0 - 1e-9) | (t > T1 + 1e-9)
    np.testing.assert_allclose(f[outside], 0.0, atol=1e-9)
    jump = 6 * M_STEP * X1 / dt**2
    i0 = np.searchsorted(t, T0 + 1e-9)
    assert f[i0] == pytest.approx(jump, rel=0.02)  # just after t0: ≈ +6 m h/Δt² (Δ ≈ 0.005)


def test_full_crank_revolution(system, result):
    """A crank driven at constant speed must be able to turn past θ = π: continue the module's
    run from its last state (crank at 162°) through 256°."""
    res = pl.simulate(
        system, t0=T_END, t_end=T_END + 0.26, dt_output=1e-3, q0=result.q[-1], v0=result.v[-1],
        integrator=pl.GeneralizedAlpha(rtol=RTOL, atol=ATOL),
    )
    tau_exact = np.array(jax.vmap(jax.grad(mechanical_energy))(jnp.asarray(res.t))) / OMEGA
    tau = res.motion("crank").effort
    assert np.max(np.abs(tau - tau_exact)) < 1e-6 * np.max(np.abs(tau_exact))
