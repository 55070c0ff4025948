"""Planar coordinates (assembly/coordinates.py): detection, and the same motion and reactions
as the absolute coordinates, which every other test runs through ``coordinates="auto"``."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import proleg as pl
from proleg.assembly.coordinates import Absolute, Planar, coordinate_set
from proleg.solvers.initial import kkt_accelerations
from tolerances import CONSTRAINT_RESIDUAL

G = 9.81
# A rotation with no axis along y: the parts' principal axes are not aligned with the plane
# normal, so the revolute joints carry out-of-plane reaction torques (products of inertia).
R_TILT = np.array(
    [[0.8660254037844387, -0.3535533905932738, 0.3535533905932738],
     [0.5, 0.6123724356957945, -0.6123724356957945],
     [0.0, 0.7071067811865476, 0.7071067811865476]]
)


def chain(n=3, tilt=True, spring=None):
    """n rods (0.3 m, 1 kg) hinged about ground y, released 20° below the horizontal."""
    model = pl.Model("planar_chain", gravity=(0, 0, -G))
    th = np.radians(20.0)
    d = np.array([np.cos(th), 0.0, -np.sin(th)])
    prev = model.ground
    for k in range(n):
        part = model.add_part(
            f"link{k + 1}", mass=1.0, inertia=(0.004, 0.008, 0.009), position=(k + 0.5) * 0.3 * d,
            orientation=R_TILT if tilt else np.eye(3),
        )
        model.add_joint(pl.Revolute(f"hinge{k + 1}", prev, part, at=k * 0.3 * d + np.array([0, 0.05 * k, 0]), axis=(0, 1, 0)))
        prev = part
    if spring is not None:
        tip = model.add_marker(prev, "tip", position=n * 0.3 * d)
        top = model.add_marker(model.ground, "top", position=(0.0, 0.0, 0.2))
        model.add_force(pl.SpringDamper("spring", tip, top, stiffness=spring, damping=0.1, free_length=0.3))
    return model


def slider_crank():
    """Crank on ground (revolute, driven by a constant torque), rod, slider on a prismatic along x."""
    model = pl.Model("slider_crank", gravity=(0, 0, -G))
    crank = model.add_part("crank", mass=0.5, inertia=(1e-3, 2e-3, 2e-3), position=(0.05, 0, 0))
    rod = model.add_part("rod", mass=0.8, inertia=(1e-3, 6e-3, 6e-3), position=(0.25, 0, 0), orientation=R_TILT)
    slider = model.add_part("slider", mass=1.2, inertia=(1e-3, 1e-3, 1e-3), position=(0.4, 0, 0))
    model.add_joint(pl.Revolute("main", crank, model.ground, at=(0, 0, 0), axis=(0, 1, 0)))
    model.add_joint(pl.Revolute("crank_pin", rod, crank, at=(0.1, 0, 0), axis=(0, 1, 0)))
    model.add_joint(pl.Revolute("wrist", slider, rod, at=(0.4, 0, 0), axis=(0, 1, 0)))
    model.add_joint(pl.Prismatic("guide", slider, model.ground, at=(0.4, 0, 0), axis=(1, 0, 0)))
    model.add_force(pl.Torque("drive", crank, value=(0.0, 2.0, 0.0)))
    return model


def run_both(system, **kw):
    opts = dict(t_end=0.5, dt_output=0.01, integrator=pl.GeneralizedAlpha(rtol=1e-10, atol=1e-11), progress=False) | kw
    return pl.simulate(system, coordinates="absolute", **opts), pl.simulate(system, coordinates="planar", **opts)


@pytest.fixture(scope="module")
def chain3():
    return pl.assemble(chain())


def test_detection(chain3):
    """A chain of parallel revolutes is planar; the planar set keeps 2 rows per hinge, 3 per part."""
    basis, why = chain3.topo.planar
    assert why == "planar"
    np.testing.assert_allclose(np.abs(basis.normal), [0, 1, 0], atol=1e-12)
    dyn = coordinate_set(chain3, chain3.params["q_init"])
    assert isinstance(dyn, Planar) and dyn.nq == 9 and dyn.nc == 6
    assert isinstance(coordinate_set(chain3, chain3.params["q_init"], "absolute"), Absolute)


def test_same_motion_and_reactions(chain3):
    """Planar and absolute runs agree to the integration tolerance (rtol 1e-10): positions 1e-6 m,
    velocities 1e-5 m/s, in-plane reactions 1e-5 of their size, and the out-of-plane reaction
    torques (from products of inertia, reconstructed in absolute coordinates) alike."""
    ra, rp = run_both(chain3)
    assert ra.coordinates == "absolute" and rp.coordinates == "planar"
    np.testing.assert_allclose(rp.q, ra.q, atol=1e-6)
    np.testing.assert_allclose(rp.v, ra.v, atol=1e-5)
    for j in ("hinge1", "hinge2", "hinge3"):
        Fa, Fp = ra.joint(j).force, rp.joint(j).force
        Ta, Tp = ra.joint(j).torque, rp.joint(j).torque
        np.testing.assert_allclose(Fp, Fa, atol=1e-5 * np.max(np.abs(Fa)))
        assert np.max(np.abs(Ta[:, [0, 2]])) > 1e-2  # real out-of-plane torques
        np.testing.assert_allclose(Tp, Ta, atol=1e-5 * np.max(np.abs(Ta)))
    assert np.max(rp.constraint_residual()) < CONSTRAINT_RESIDUAL  # tests/tolerances.py: 50 phi_tol
    # parts stay in their planes: y of every COM is constant
    for k in range(3):
        y = rp.part(f"link{k + 1}").position[:, 1]
        np.testing.assert_allclose(y, y[0], atol=1e-12)


def test_energy_conserved(chain3):
    """No dissipation: kinetic + potential energy constant within 1e-6 of the kinetic energy
    (rtol 1e-10; the absolute run's numerical dissipation from ρ∞ = 0.8 is of the same size)."""
    ra, rp = run_both(chain3, t_end=1.0)
    drift = {}
    for r in (ra, rp):
        e = r.energy
        total = e.kinetic + e.potential
        drift[r.coordinates] = np.max(np.abs(total - total[0])) / np.max(np.abs(e.kinetic))
    assert drift["planar"] < 1e-6, drift
    assert drift["planar"] < 3 * drift["absolute"], drift


def test_pendulum_period_closed_form():
    """Small-amplitude pendulum in planar coordinates: period 2π√(I_O/(m g ℓ)) within 1e-4."""
    L = 0.5
    model = pl.Model("pendulum", gravity=(0, 0, -G))
    bob = model.add_part("bob", mass=1.0, inertia=(1e-6, 1e-6, 1e-6), position=(L * np.sin(0.01), 0, -L * np.cos(0.01)))
    model.add_joint(pl.Revolute("pivot", bob, model.ground, at=(0, 0, 0), axis=(0, 1, 0)))
    system = pl.assemble(model)
    r = pl.simulate(system, t_end=3.0, dt_output=1e-3, integrator=pl.GeneralizedAlpha(rtol=1e-10, atol=1e-12), progress=False)
    assert r.coordinates == "planar"
    x = r.part("bob").position[:, 0]
    s = np.flatnonzero((x[:-1] > 0) & (x[1:] <= 0))
    tc = [r.t[i] + x[i] / (x[i] - x[i + 1]) * (r.t[i + 1] - r.t[i]) for i in s]
    T = np.mean(np.diff(tc)) if len(tc) > 1 else None
    T_exact = 2 * np.pi * np.sqrt((1e-6 + L**2) / (G * L))
    assert T is not None and abs(T / T_exact - 1) < 1e-4


def test_prismatic_and_torque_slider_crank():
    """A slider-crank (revolutes + prismatic) is planar and runs like the absolute model."""
    with pytest.warns(UserWarning, match="redundant"):  # the guide's out-of-plane rows
        system = pl.assemble(slider_crank())
    assert system.topo.planar[1] == "planar"
    ra, rp = run_both(system)
    np.testing.assert_allclose(rp.part("slider").position, ra.part("slider").position, atol=1e-6)
    # the guide force peaks (94 N) as the crank passes its dead point: 1e-4 of the peak
    Fa = ra.joint("guide").force
    np.testing.assert_allclose(rp.joint("guide").force, Fa, atol=1e-4 * np.max(np.abs(Fa)))


def test_not_planar():
    """Bushing hinges leave out-of-plane freedom; crossed revolute axes make a spatial chain: both
    run in absolute coordinates, and asking for planar ones says why, naming the model."""
    model = pl.Model("bushing_hinge", gravity=(0, 0, -G))
    part = model.add_part("link", mass=1.0, inertia=(0.01, 0.02, 0.02), position=(0.2, 0, 0))
    mi = model.add_marker(part, "i", position=(0, 0, 0))
    mj = model.add_marker(model.ground, "j", position=(0, 0, 0))
    model.add_force(pl.Bushing("hinge", mi, mj, stiffness=(1e6, 1e6, 1e6, 1e3, 0.0, 1e3)))
    system = pl.assemble(model)
    assert system.topo.planar[0] is None
    assert pl.simulate(system, t_end=0.01, progress=False).coordinates == "absolute"
    with pytest.raises(ValueError, match="bushing_hinge"):
        pl.simulate(system, t_end=0.01, coordinates="planar", progress=False)

    model = pl.Model("crossed", gravity=(0, 0, -G))
    a = model.add_part("a", mass=1.0, inertia=(0.01, 0.02, 0.02), position=(0.2, 0, 0))
    b = model.add_part("b", mass=1.0, inertia=(0.01, 0.02, 0.02), position=(0.6, 0, 0))
    model.add_joint(pl.Revolute("j1", a, model.ground, at=(0, 0, 0), axis=(0, 1, 0)))
    model.add_joint(pl.Revolute("j2", b, a, at=(0.4, 0, 0), axis=(1, 0, 0)))
    system = pl.assemble(model)
    assert system.topo.planar[0] is None and "revolute" in system.topo.planar[1]


def test_rotation_composition():
    """The map's Euler-parameter product composes rotations: A(a ⊗ b) = A(a) A(b)."""
    from proleg.spatial.rotation import A_of_p, quat_mul

    rng = np.random.default_rng(1)
    a, b = rng.normal(size=(2, 5, 4))
    a /= np.linalg.norm(a, axis=1, keepdims=True)
    b /= np.linalg.norm(b, axis=1, keepdims=True)
    # unit quaternions and rotation matrices: ~30 flops on O(1) entries, 64 eps
    np.testing.assert_allclose(A_of_p(quat_mul(a, b)), A_of_p(jnp.asarray(a)) @ A_of_p(jnp.asarray(b)), atol=64 * np.finfo(float).eps)


def test_reduced_multipliers_and_accelerations(chain3):
    """The start maps absolute (q̈, λ) to planar ones exactly: they solve the planar KKT system."""
    q, v = chain3.params["q_init"], jnp.zeros(chain3.nq)
    dyn = coordinate_set(chain3, q)
    kkt = jax.jit(kkt_accelerations)
    qdd, lam = kkt(chain3, q, v, 0.0)
    x, xd = dyn.reduce(q, v)
    xdd_ref, lam_ref = kkt(dyn, x, xd, 0.0)
    np.testing.assert_allclose(dyn.reduce_acceleration(x, xd, qdd), xdd_ref, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(dyn.reduce_multipliers(lam), lam_ref, rtol=1e-9, atol=1e-9)
    q_back, v_back = dyn.absolute(x, xd)
    # round trip through angles (atan2, sin, cos: 1 ulp each in any libm or XLA): 64 eps × the
    # scale of q (positions in m, unit quaternions)
    np.testing.assert_allclose(q_back, q, atol=64 * np.finfo(float).eps * max(1.0, float(np.max(np.abs(q)))))


def test_vmap_and_jacfwd_through_planar():
    """Sweeps and sensitivities work in planar coordinates: vmap equals the loop; d(final x)/dk by
    jacfwd equals central differences within 1e-5 relative."""
    system = pl.assemble(chain(2, tilt=False, spring=50.0))
    assert system.topo.planar[1] == "planar"

    def final_x(k):
        r = pl.simulate(system.with_params({"spring.stiffness": k}), t_end=0.2, dt_output=0.05, integrator=pl.GeneralizedAlpha(fixed_step=1e-3),
                        progress=False)
        return r.part("link2").position[-1, 0]

    check_vmap_and_jacfwd(final_x, jnp.array([30.0, 60.0]))


def check_vmap_and_jacfwd(final_x, ks, k0=50.0):
    """jax.vmap of ``final_x`` over ``ks`` equals the loop (1e-12); jacfwd at k0 equals central
    differences (step 1e-3) within 1e-5 relative. Shared by the coordinate-set tests."""
    np.testing.assert_allclose(jax.vmap(final_x)(ks), jnp.array([final_x(k) for k in ks]), rtol=0, atol=1e-12)
    d = jax.jacfwd(final_x)(k0)
    fd = (final_x(k0 + 1e-3) - final_x(k0 - 1e-3)) / 2e-3
    assert abs(d - fd) < 1e-5 * abs(fd)
