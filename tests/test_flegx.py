"""FLEGX flexible jumping leg (seed 002): link models, worm drive, jump bookkeeping, bad input.

Closed forms: Eq. 3 (first bending frequency of a cantilever), the tip stiffness 3 E I / L³,
the elastica of a cantilever under a vertical end force (Bisshopp & Drucker), the worm's
power balance from the tooth normal force (Eq. 16 derived independently), the self-locking
limit f* = cos θ_n tan γ, and the ballistic rise v²/2g of the centre of mass after take-off.
"""

import math
import warnings

import jax
import numpy as np
import pytest

import proleg as pl
from proleg.drives import WormGear
from proleg.flex import cantilever_first_omega, elastica_tip
from proleg.fem import material
from proleg.robots import flegx, flegx_data as D
from proleg.papers import flegx_jump
from proleg.robots.flegx import add_link, strip_reduced
from proleg.papers.flegx_jump import MotionLaw, jump_flight, worm_torques
from proleg.units import deg

MAT = material("aisi304")
#: a fast push that makes even the rigid leg leave the ground (≈ 65 mm), short squat
FAST = dict(t_settle=0.1, t_squat=0.3, t_hold=0.05, extend=(-12 * deg, 24 * deg), t_push=0.22, t_after=0.45)


@pytest.mark.parametrize("case", [1, 2, 3, 4, 5, 6])
def test_cb_link_first_frequency_and_tip_stiffness(case):
    """Clamped at its frame node, the CB strip's first bending frequency is Eq. 3's within 1 %
    (beam FE + 3 fixed-interface modes: ~1e-5 in fact), and its static tip stiffness is the
    beam formula 3 E I / L³ (the constraint modes make boundary statics exact: 1e-9)."""
    L, W, t = D.LINK_CASES[case]
    rb, beam, root, tip = strip_reduced(L, W, t, MAT, 10, 3)
    frame = [k for k, d in enumerate(rb.boundary_dofs) if d in set(beam.node_dofs([root]))]
    keep = np.setdiff1d(np.arange(rb.nq), frame)
    K, M = rb.K[np.ix_(keep, keep)], rb.M[np.ix_(keep, keep)]
    import scipy.linalg

    w = np.sqrt(np.clip(scipy.linalg.eigh(K, M, eigvals_only=True), 0, None))
    EI = MAT.E * W * t**3 / 12
    w1 = cantilever_first_omega(L, MAT.E, W * t**3 / 12, MAT.rho * W * t)
    assert w[0] == pytest.approx(w1, rel=1e-2)
    assert w[0] == pytest.approx(w1, rel=1e-4)  # what the beam FE actually gives
    col = {int(d): k for k, d in enumerate(rb.boundary_dofs)}[beam.dof(tip, "uz")]
    f = np.zeros(rb.nq)
    f[col] = 1.0
    u = np.zeros(rb.nq)
    u[keep] = np.linalg.solve(K, f[keep])
    assert 1.0 / u[col] == pytest.approx(3 * EI / L**3, rel=1e-9)


def test_cb_beam_link_agrees_with_the_p2_tet_strip():
    """The scikit-fem P2-tet solid of case 2, clamped over its root face, is stiffer than the beam
    only by the plate effect (between E and E/(1-ν²); 2.0 % for this 70 mm wide strip): the beam CB body is that strip."""
    from proleg.fem import SolidModel

    L, W, t = D.LINK_CASES[2]
    solid = SolidModel.box((L, W, t), 0.0125, MAT, order=2)
    clamped = solid.node_dofs(solid.nodes_where(lambda x, y, z: np.isclose(x, 0.0)))
    w_solid = solid.modes(1, clamped)[0][0]
    w_beam = cantilever_first_omega(L, MAT.E, W * t**3 / 12, MAT.rho * W * t)
    assert w_beam <= w_solid <= w_beam / math.sqrt(1 - MAT.nu**2) * 1.001
    # 2.0 % here (the 70 mm strip is wider than test_fem_solid's 50 mm one: more plate effect)
    assert w_solid == pytest.approx(w_beam, rel=0.025)


def _clamped_link(link_model, load, case=6):
    """The strip clamped horizontally to ground, no gravity, a vertical (non-follower) tip load."""
    L, W, t = D.LINK_CASES[case]
    m = pl.Model("clamped", gravity=(0, 0, 0))
    link = add_link(m, m.ground, np.zeros(3), np.array([1.0, 0.0, 0.0]), link_model, (L, W, t), MAT)
    tip_part = link["tip_part"]
    kw = {"node": link["cb"]["tip"]} if link_model == "cb" else {}
    tip = m.add_marker(tip_part, "tip", position=None if kw else (L, 0, 0), **kw)
    m.add_force(pl.Force("load", tip, value=(0.0, 0.0, -load)))
    eq = pl.solve_equilibrium(pl.assemble(m))
    p = np.asarray(eq.result().marker("tip").position[0])
    return p[0], -p[2], L, MAT.E * W * t**3 / 12


@pytest.mark.parametrize("link_model,alpha2,tol", [
    ("prbm", 0.1, 5e-3), ("prbm", 0.5, 5e-3),  # PRBM: the 0.5 % tip-path criterion, small and moderate load
    ("cb", 0.1, 5e-3),  # the linear modal body meets it at small load only
])
def test_link_tip_under_a_vertical_load_against_the_elastica(link_model, alpha2, tol):
    """Static tip position under P = α² E I / L² (α² = 0.1: b ≈ 3 % of L; 0.5: b ≈ 16 %):
    distance from the elastica tip within tol × L (measured: PRBM 0.010 % and 0.24 %, CB 0.07 %).

    Limits (measured, case 6): the *dynamic* PRBM (γ = 0.738 from Eqs. 8-11, not Howell's
    0.85) leaves the 0.5 % band near α² = 0.7 (0.87 % at α² = 1, b = 30 % of L); the linear CB
    body near α² = 0.3 (0.6 %; it is linear, b = P L³ / 3 E I, below)."""
    L, W, t = D.LINK_CASES[6]
    EI = MAT.E * W * t**3 / 12
    P = alpha2 * EI / L**2
    a, b, L, EI = _clamped_link(link_model, P)
    ae, be, _ = elastica_tip(P, L, EI)
    assert math.hypot(a - ae, b - be) / L < tol
    assert b > 0.02 * L  # it really bent
    if link_model == "cb":  # linear: exactly the small-deflection beam, the tip does not shorten
        assert b == pytest.approx(P * L**3 / (3 * EI), rel=1e-6)
        assert a == pytest.approx(L, rel=1e-9)


def test_worm_power_balance_and_efficiency():
    """Eq. 16 against the tooth-force balance: P_in − P_out equals f W v_s (W the tooth normal
    force, v_s the sliding speed) sample by sample, both branches; η(0.133) = 0.60."""
    wg = WormGear(**D.WORM)
    assert wg.efficiency(wg.friction_for_efficiency(0.60)) == pytest.approx(0.60, abs=1e-12)
    assert wg.friction_for_efficiency(0.60) == pytest.approx(0.133, abs=1e-3)
    rng = np.random.default_rng(0)
    tau, w = rng.normal(0, 30, 500), rng.normal(0, 5, 500)
    out = worm_torques(tau, w, "worm")
    bal = out["power_in"] - out["power_out"] - out["mesh_loss"]
    assert np.max(np.abs(bal)) < 1e-9 * np.max(np.abs(out["power_in"]))
    assert np.all(out["mesh_loss"] >= 0)
    fwd = tau * w > 0
    assert np.allclose(out["power_out"][fwd] / out["power_in"][fwd], out["efficiency"][fwd], rtol=1e-12)


def test_worm_backdriven_below_self_locking_friction_locked_above():
    """Lowering a load (wheel torque τ > 0 holding it, speed ω < 0): below f* = cos θ_n tan γ the
    load back-drives the worm (power reaches the motor, which brakes with τ_in of the sign of τ);
    above f* the set is self-locking: the motor must drive even to lower (τ_in opposes τ and the
    motor delivers power)."""
    wg = WormGear(**D.WORM)
    f_star = wg.self_locking_friction
    assert f_star == pytest.approx(math.cos(wg.normal_pressure_angle) * math.tan(wg.lead_angle))
    tau, w = np.array([20.0]), np.array([-2.0])
    below = worm_torques(tau, w, "worm", friction=0.9 * f_star)
    above = worm_torques(tau, w, "worm", friction=1.1 * f_star)
    assert below["back_efficiency"][0] > 0 and below["worm_torque"][0] > 0 and below["power_in"][0] < 0
    assert above["back_efficiency"][0] < 0 and above["worm_torque"][0] < 0 and above["power_in"][0] > 0
    assert not bool(wg.is_self_locking(D.WORM_FRICTION_STATIC))  # FLEGX: f = 0.14 < 0.217, back-drivable


@pytest.fixture(scope="module")
def rigid_jump():
    return flegx_jump(link_model="rigid", gears="worm", dt_output=1e-3, **FAST)


def _com(res, model):
    num = 0.0
    mass = 0.0
    for p in model.parts:
        num = num + p.mass * np.asarray(res.part(p.name).position)
        mass += p.mass
    return num / mass


def test_take_off_bookkeeping_rise_is_v2_over_2g(rigid_jump):
    """After take-off only gravity acts vertically (frictionless guide): the centre of mass rises
    v²/2g with v its vertical velocity at take-off, within 1e-3 (relative)."""
    j = rigid_jump
    m, res = j.metrics, j.result
    assert 0.03 < m["jump_height"] < 0.12 and m["take_off_time"] < m["apex_time"] < m["landing_time"]
    t = res.t
    i0 = int(np.searchsorted(t, m["take_off_time"]))
    i1 = int(np.searchsorted(t, m["landing_time"]))
    com = _com(res, j.model)
    vz = np.gradient(com[:, 2], t)
    # the velocity at take-off from momentum: v = v_com(t_to) (central difference of the COM)
    v = vz[i0 + 1]
    rise = com[i0 + 1 : i1, 2].max() - com[i0 + 1, 2]
    assert rise == pytest.approx(v**2 / (2 * 9.81), rel=1e-3)
    # and the total vertical momentum changes at -M g in flight
    M = j.model.flegx.total_mass
    dp = M * (vz[i1 - 2] - vz[i0 + 2])
    assert dp == pytest.approx(-M * 9.81 * (t[i1 - 2] - t[i0 + 2]), rel=5e-3)


def test_worm_power_balance_over_a_jump(rigid_jump):
    """gears="worm" (the dynamic worm mesh): motor work = work into the wheels + friction loss
    + mesh damping loss + the change of the mesh's spring energy and of the rotors' kinetic
    energy, over the whole jump within 1e-3 of the motor's ∫|P| dt (measured: 7e-5)."""
    s = rigid_jump.series
    t = s["time [s]"]
    both = lambda k: s[f"hip_{k}"] + s[f"knee_{k}"]  # noqa: E731
    W_in, W_out = np.trapezoid(both("power_in [W]"), t), np.trapezoid(both("power_out [W]"), t)
    W_loss, W_damp = np.trapezoid(both("mesh_loss [W]"), t), np.trapezoid(both("damping_power [W]"), t)
    E = both("spring_energy [J]") + both("worm_kinetic_energy [J]")
    scale = np.trapezoid(np.abs(s["hip_power_in [W]"]) + np.abs(s["knee_power_in [W]"]), t)
    assert abs(W_in - W_out - W_loss - W_damp - (E[-1] - E[0])) < 1e-3 * scale
    assert W_loss > 0.2 * scale  # η ≈ 0.6 forward and η_back ≈ 0.37: a large share of the work is lost
    assert np.all(both("mesh_loss [W]") >= 0)
    m = rigid_jump.metrics
    assert m["peak_hip_torque_worm"] > 1.3 * m["peak_hip_torque"] / 9.67  # worse than ideal (1/η = 1.7 at the peak)


def test_worm_mesh_efficiency_is_eq16_while_sliding(rigid_jump):
    """Where the worm slides fast (|v_s| > v_dynamic, μ = 0.13) and the motor drives (P_in, P_out
    > 0), the dynamic mesh's instantaneous efficiency P_out / P_in is Eq. 16's η(0.13) = 0.606:
    median within 2 % (the spread: mesh spring/damper power and the rotor's inertia)."""
    from proleg.papers.flegx_jump import worm_drive_outputs

    wg = WormGear(**D.WORM)
    eta = []
    for d in ("hip", "knee"):
        o = worm_drive_outputs(rigid_jump.result, rigid_jump.model, d)
        sel = (np.abs(o["sliding_speed"]) > D.WORM_V_DYNAMIC) & np.isfinite(o["efficiency"])
        eta.append(o["efficiency"][sel])
    eta = np.concatenate(eta)
    assert eta.size > 50
    assert np.median(eta) == pytest.approx(wg.efficiency(D.WORM_FRICTION_DYNAMIC), rel=2e-2)


def _worm_and_wheel(f, J=0.01, load=-5.0):
    """A wheel (inertia J [kg m²] about y, constant load torque [N m]) meshed with a free FLEGX
    worm (no motor torque): back-driven or held by the worm's friction f."""
    from proleg.robots.flegx import add_worm_drive

    wg = WormGear(**D.WORM)
    m = pl.Model("worm_wheel", gravity=(0, 0, 0))
    housing = m.add_part("housing", 1.0, [1e-3] * 3, (0, 0, 0))
    m.add_joint(pl.Fixed("housing", housing, m.ground, at=(0, 0, 0)))
    wheel = m.add_part("wheel", 1.0, [J, J, J], (0, 0, 0))
    m.add_joint(pl.Revolute("wheel", wheel, housing, at=(0, 0, 0), axis=(0, 1, 0)))
    m.add_force(pl.Torque("load", wheel, value=(0.0, load, 0.0)))
    m.add_variable("worm_f_static", f)
    m.add_variable("worm_f_dynamic", f)
    mass = D.WORM_INERTIA / (0.5 * wg.worm_pitch_diameter) ** 2
    add_worm_drive(m, "w", "wheel", wheel, housing, np.zeros(3), wg, mass)
    return m, wg, mass


def test_worm_mesh_backdriven_below_self_locking_friction_locked_above():
    """In the dynamics: a loaded wheel meshed with a free worm. Below f* = cos θ_n tan γ the load
    back-drives the worm at the closed-form acceleration of the rigid mesh with sliding friction,
    α = T / (J + m n r1 r2 B/A), A = sin γ − (f/cos θ_n) cos γ, B = cos γ + (f/cos θ_n) sin γ
    (within 2 %: mesh compliance and the stiction → sliding transition); above f* the worm
    self-locks: the wheel only creeps at a sliding speed below the stiction velocity."""
    wg = WormGear(**D.WORM)
    f_star = wg.self_locking_friction
    model, wg, mass = _worm_and_wheel(0.8 * f_star)
    system = pl.assemble(model)
    r1, r2, n = 0.5 * wg.worm_pitch_diameter, 0.5 * wg.wheel_pitch_diameter, wg.ratio
    cn, g = math.cos(wg.normal_pressure_angle), wg.lead_angle
    out = {}
    for f in (0.8 * f_star, 1.1 * f_star):
        res = pl.simulate(system.with_params(worm_f_static=f, worm_f_dynamic=f), t_end=0.2, dt_output=1e-3)
        out[f] = res
    below, above = out[0.8 * f_star], out[1.1 * f_star]
    t, phi = below.t, np.asarray(below.joint("wheel").angle)
    sel = t >= 0.05
    alpha = 2 * np.polyfit(t[sel], phi[sel], 2)[0]
    f = 0.8 * f_star
    A, B = math.sin(g) - f / cn * math.cos(g), math.cos(g) + f / cn * math.sin(g)
    assert alpha == pytest.approx(-5.0 / (0.01 + mass * n * r1 * r2 * B / A), rel=2e-2)
    assert phi[-1] < -0.5  # really back-driven: half a radian in 0.2 s
    phi_lock = np.asarray(above.joint("wheel").angle)
    vs = np.gradient(np.asarray(above.joint("w_worm").translation), above.t) / math.cos(g)
    assert abs(phi_lock[-1]) < 5e-3
    assert np.max(np.abs(vs[above.t > 0.02])) < D.WORM_V_STATIC


@pytest.mark.slow
def test_rigid_jump_is_the_stiff_cb_limit():
    """E × 100: the CB leg's jump converges to the rigid leg's (E × 1 differs by far more); ideal gears."""
    h_rigid = flegx_jump(link_model="rigid", dt_output=1e-3, **FAST).metrics["jump_height"]
    h = {s: flegx_jump(link_model="cb", dt_output=1e-3, model_options={"E_scale": s}, **FAST).metrics["jump_height"]
         for s in (1.0, 100.0)}
    assert abs(h[100.0] - h_rigid) < 0.05 * h_rigid
    assert abs(h[1.0] - h_rigid) > 5 * abs(h[100.0] - h_rigid)


def test_model_structure_and_mass_split():
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        for c in (1, 2, 3, 4):
            m = flegx(configuration=c, link_model="rigid")
            assert m.flegx.total_mass == pytest.approx(D.TABLE_I[c][0], rel=1e-12)  # Table I with case 2
            s = pl.assemble(m)
    assert any("redundant" in str(r.message) for r in rec)  # the second tendon (No. 4)
    m4 = flegx(configuration=4, link_model="cb", link_case=6)
    assert m4.flegx.total_mass == pytest.approx(7.97 + MAT.rho * (0.3 * 0.05 - 0.25 * 0.07) * 0.003, rel=1e-12)
    assert {"tendon_a", "tendon_b", "knee_wheel"} <= {p.name for p in m4.parts}
    assert "knee_wheel" not in {p.name for p in flegx(configuration=1).parts}
    for c in (1, 4):  # the worm sliders' mass comes out of their housings: same total and centre of mass
        ideal, worm = (flegx(configuration=c, link_model="rigid", gears=g) for g in ("ideal", "worm"))
        com = [sum(p.mass * np.asarray(p.position) for p in m.parts) / sum(p.mass for p in m.parts) for m in (ideal, worm)]
        assert sum(p.mass for p in worm.parts) == pytest.approx(D.TABLE_I[c][0], rel=1e-12)
        assert np.allclose(com[0], com[1], atol=1e-12)
        assert {"hip_worm", "knee_worm"} <= {p.name for p in worm.parts}
    del s


def test_bad_input_errors():
    with pytest.raises(pl.ModelError, match="configuration.*1-4"):
        flegx(configuration=5)
    with pytest.raises(pl.ModelError, match="link_case.*1-6"):
        flegx(link_case=7)
    with pytest.raises(pl.ModelError, match="thickness.*range"):
        flegx(link_geometry=(0.25, 0.07, 0.0))
    with pytest.raises(pl.ModelError, match="link_model.*'rigid', 'prbm', 'cb'"):
        flegx(link_model="elastic")
    with pytest.raises(pl.ModelError, match="gears"):
        flegx(gears="belt")
    with pytest.raises(pl.ModelError, match="knee angle.*range 5…150"):
        flegx_jump(link_model="rigid", squat=(-50 * deg, 170 * deg))
    with pytest.raises(pl.ModelError, match="hip angle.*range"):
        MotionLaw(extend=(60 * deg, 30 * deg)).validate()
    with pytest.raises(pl.ModelError, match="t_push"):
        MotionLaw(t_push=0.0).validate()


def test_jump_flight_is_robust_to_touch_and_go_and_hops():
    """The jump is the flight that holds the highest airborne guide position; its height is
    measured from the standing height, so a touch-and-go before it (the still-extending leg)
    and the hops after the landing change neither the height nor the flight picked."""
    law = MotionLaw(t_settle=0.1, t_squat=0.3, t_hold=0.05, t_push=0.2)  # push starts at 0.45 s
    t = np.arange(0.0, 1.5, 1e-3)
    g = 9.81
    z_stand, t_to, v = 0.40, 0.62, 1.0  # ballistic flight from 0.62 s
    z = np.where(t < t_to, z_stand + 0.05 * np.clip((t - 0.45) / 0.17, 0, 1), z_stand + 0.05 + v * (t - t_to) - 0.5 * g * (t - t_to) ** 2)
    t_ld = t_to + 2 * v / g
    N = np.where((t < t_to) | (t >= t_ld), 100.0, 0.0)
    N[(t >= 0.55) & (t < 0.57)] = 0.0  # touch-and-go while extending
    z = np.where(t >= t_ld, z_stand, z)
    N[(t >= 1.2) & (t < 1.25)] = 0.0  # a hop after the landing (guide at the standing height)
    jump, (i_to, i_ld) = jump_flight(t, z, N, law)
    assert jump["flights"] == 3
    assert jump["take_off_time"] == pytest.approx(t_to, abs=1e-3)
    assert jump["landing_time"] == pytest.approx(t_ld, abs=1e-3)
    assert jump["jump_height"] == pytest.approx(0.05 + v**2 / (2 * g), abs=1e-5)
    assert jump["flight_rise"] == pytest.approx(v**2 / (2 * g), abs=1e-5)
    # a leg that never leaves the ground did not jump, however far it extends
    none, _ = jump_flight(t, z, np.full_like(t, 50.0), law)
    assert none["jump_height"] == 0.0 and none["flights"] == 0 and math.isnan(none["take_off_time"])


def test_study_variants_are_the_group_system_with_other_parameters():
    """flegx_study runs a group of variants as one compiled System: the group's base System with
    a variant's looked-up parameters (``apply``) has the constraints, generalized forces and mass
    action of that variant built from scratch, to the last bit, at a random state."""
    from types import SimpleNamespace

    from proleg.assembly.system import constraints, generalized_forces, mass_action
    from proleg.papers.flegx_study import _Variants

    var = _Variants(dict(name="prbm-direct", link_model="prbm", configurations=(1, 3), cases=(1, 6)), MotionLaw())
    rng = np.random.default_rng(1)
    for key, own in var.systems.items():
        applied = var.apply(var.base, {"configuration": float(key[0]), "link_case": float(key[1])})
        q = np.asarray(own.params["q_init"]) + 1e-3 * rng.normal(size=own.nq)
        v = rng.normal(size=own.params["v_init"].shape)
        for f, args in ((constraints, (q, 1.2)), (generalized_forces, (q, v, 1.2)), (mass_action, (q, v))):
            a, b = f(own, *args), f(applied, *args)
            # bitwise: the same functions on equal parameters, in this process; apply() must
            # rebuild exactly the variant's own system
            assert all(np.array_equal(x, y) for x, y in zip(jax.tree_util.tree_leaves(a), jax.tree_util.tree_leaves(b), strict=True))
        assert var.key_of(SimpleNamespace(system=applied)) == key
    assert len(var.table) > 3  # masses, inertias, poses and the PRBM constants really differ
