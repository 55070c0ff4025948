"""HyQ leg model (proleg.robots.hyq_leg): geometry, mass properties, joints, inputs.

Sources: MODEL_DATA §1 (hyq-description URDF, cylinder formulas), seeds 000 and 001.
"""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import proleg as pl
from proleg.assembly.constraints import joint_angle
from proleg.assembly.system import constraints, dof_report, kinematics
from proleg.robots import hyq_data as D
from proleg.robots import hyq_leg
from proleg.robots.hyq_leg import _geometry, _slender, _upper_leg_residual
from proleg.units import deg


def _length(model, side):
    return np.linalg.norm(model.marker(f"{side}_actuator.I").position - model.marker(f"{side}_actuator.J").position)


# ------------------------------------------------------------------------------------------
# cylinder kinematics
# ------------------------------------------------------------------------------------------
def test_lever_arm_is_the_length_rate():
    """l(θ) of MODEL_DATA is the distance from the joint axis to the cylinder line, = |dc/dθ|."""
    for th in np.linspace(D.HFE_RANGE_DEG[0], D.HFE_RANGE_DEG[1], 7) * deg:
        assert float(jax.grad(D.hip_cylinder_length)(th)) == pytest.approx(float(D.hip_lever_arm(th)), rel=1e-12)
    for th in np.linspace(D.KFE_RANGE_DEG[0], D.KFE_RANGE_DEG[1], 7) * deg:
        assert float(jax.grad(D.knee_cylinder_length)(th)) == pytest.approx(-float(D.knee_lever_arm(th)), rel=1e-12)


@pytest.mark.parametrize("th1_deg,th2_deg", [(-70, 20), (-30, 60), (0, 100), (20, 140), (50, 30)])
def test_built_cylinder_length_follows_formula(th1_deg, th2_deg):
    """Pin-to-pin lengths of the model built at a pose equal c1(θ1), c2(θ2) (derivation in hyq_leg)."""
    m = hyq_leg(hip_angle=th1_deg * deg, knee_angle=th2_deg * deg, servo=False, contact=False)
    assert _length(m, "hip") == pytest.approx(float(D.hip_cylinder_length(th1_deg * deg)), abs=1e-12)
    assert _length(m, "knee") == pytest.approx(float(D.knee_cylinder_length(th2_deg * deg)), abs=1e-12)


@pytest.fixture(scope="module")
def rigid_system():
    return pl.assemble(hyq_leg("rigid", servo=False))


def test_assembled_cylinder_length_vs_joint_angle(rigid_system):
    """Move the assembled rigid model through its joint range (Newton on Φ(q) = 0 with the slider
    height, θ1 and θ2 imposed) and compare the actuator lengths with MODEL_DATA c(θ) to 1e-9."""
    system = rigid_system
    names = system.topo.marker_names
    idx = {k: names.index(k) for k in ("hip.I", "hip.J", "knee.I", "knee.J", "hip_actuator.I", "hip_actuator.J", "knee_actuator.I", "knee_actuator.J")}
    b = system.topo.body_names.index("slider")
    q0 = system.params["q_init"]
    z0 = q0[7 * b + 2]

    def coords(q):
        _, mk = kinematics(system, q)
        th1 = joint_angle(mk.R[idx["hip.I"]][None], mk.R[idx["hip.J"]][None])[0]
        th2 = joint_angle(mk.R[idx["knee.I"]][None], mk.R[idx["knee.J"]][None])[0]
        ell = [jnp.linalg.norm(mk.r[idx[f"{s}_actuator.I"]] - mk.r[idx[f"{s}_actuator.J"]]) for s in ("hip", "knee")]
        return jnp.stack([q[7 * b + 2] - z0, th1, th2]), jnp.stack(ell)

    def residual(q, target):
        return jnp.concatenate([constraints(system, q, 0.0), coords(q)[0] - target])

    @jax.jit
    def newton(q, target):
        def body(q, _):
            J = jax.jacfwd(residual)(q, target)
            return q - jnp.linalg.solve(J, residual(q, target)), None

        q, _ = jax.lax.scan(body, q, None, length=12)
        return q, jnp.max(jnp.abs(residual(q, target))), coords(q)[1]

    q = q0
    for th1, th2 in [(-30, 60), (-10, 80), (10, 100), (30, 120), (45, 135), (0, 40), (-40, 25), (-65, 30)]:
        q, res, ell = newton(q, jnp.array([0.0, th1 * deg, th2 * deg]))
        assert float(res) < 1e-12
        assert float(ell[0]) == pytest.approx(float(D.hip_cylinder_length(th1 * deg)), abs=1e-9)
        assert float(ell[1]) == pytest.approx(float(D.knee_cylinder_length(th2 * deg)), abs=1e-9)


# ------------------------------------------------------------------------------------------
# mass properties and frames
# ------------------------------------------------------------------------------------------
def test_upper_leg_split_reproduces_urdf_mass_properties():
    """Structure + 2 cylinders + 2 rods at the nominal pose = URDF upper leg (mass, COM, inertia)."""
    cyl = dict(cylinder_mass=D.CYLINDER_MASS, rod_mass=D.ROD_MASS, cylinder_length=D.CYLINDER_LENGTH, rod_length=D.ROD_LENGTH)
    m = hyq_leg(drop_height=0.0, servo=False, contact=False)
    R1 = D.urdf_link_frame(-30 * deg)
    O = m.marker("hip.J").position
    parts = [m.part(n) for n in ("upper_leg", "hip_cylinder", "hip_rod", "knee_cylinder", "knee_rod")]
    mass = sum(p.mass for p in parts)
    com = sum(p.mass * p.position for p in parts) / mass
    J = np.zeros((3, 3))
    for p in parts:
        d = p.position - com
        J += p.orientation @ p.inertia @ p.orientation.T + p.mass * (d @ d * np.eye(3) - np.outer(d, d))
    # Reproduced to round-off: sums of a few products (3×3 products through BLAS, whose kernel
    # differs by CPU). 64 eps × the scale: the mass; 1 m for the COM (the leg spans < 1 m);
    # Σ m |d|² + |J_i| for the inertia, whose parallel-axis terms cancel to the URDF's values.
    eps = np.finfo(float).eps
    scale_J = sum(p.mass * (p.position - com) @ (p.position - com) + np.abs(p.inertia).max() for p in parts)
    assert mass == pytest.approx(D.UPPER_LEG_MASS, rel=64 * eps)
    np.testing.assert_allclose(R1.T @ (com - O), D.UPPER_LEG_COM, atol=64 * eps * 1.0)
    np.testing.assert_allclose(R1.T @ J @ R1, np.array(D.UPPER_LEG_INERTIA), atol=64 * eps * scale_J)
    m_s, _, J_s = _upper_leg_residual(cyl)
    assert m_s == pytest.approx(D.UPPER_LEG_MASS - 2 * (D.CYLINDER_MASS + D.ROD_MASS))
    assert np.linalg.eigvalsh(J_s).min() > 0


def test_frames_and_masses():
    m = hyq_leg(payload=3.0, drop_height=0.05)
    assert m.part("slider").mass == pytest.approx(D.HIP_ASSEMBLY_MASS + 3.0)
    assert m.hyq.total_mass == pytest.approx(D.HIP_ASSEMBLY_MASS + 3.0 + D.UPPER_LEG_MASS + D.LOWER_LEG_MASS)
    # URDF link frame of the lower leg: x from the knee to the foot, z = +y (the pin axis)
    R2 = m.part("lower_leg").orientation
    foot, knee = m.marker("foot").position, m.marker("knee.I").position
    # unit vectors and positions (< 1 m) from sin/cos and 3×3 products: 64 eps of the scale
    eps = np.finfo(float).eps
    np.testing.assert_allclose(R2[:, 0], (foot - knee) / np.linalg.norm(foot - knee), atol=64 * eps)
    np.testing.assert_allclose(R2[:, 2], [0, 1, 0], atol=64 * eps)
    # foot sphere bottom at the drop height, foot under the hip (θ1 = −30°, θ2 = 60°)
    assert foot[2] - D.FOOT_RADIUS == pytest.approx(0.05, abs=64 * eps * 1.0)
    assert abs(foot[0]) < 0.01
    np.testing.assert_allclose(m.part("lower_leg").inertia, np.array(D.LOWER_LEG_INERTIA))


def test_slender_inertia():
    assert _slender(1.0, 0.3, 0.0)[0] == pytest.approx(0.3**2 / 12)


# ------------------------------------------------------------------------------------------
# joints, pins, DOF
# ------------------------------------------------------------------------------------------
def test_pin_layout():
    counts = {}
    for joints in ("rigid", "bushings4", "bushings8"):
        m = hyq_leg(joints)
        counts[joints] = sorted(f.name for f in m.forces if isinstance(f, pl.Bushing))
    assert counts["rigid"] == []
    assert counts["bushings4"] == ["pin1", "pin2", "pin3", "pin6"]
    assert counts["bushings8"] == ["pin1", "pin2", "pin3", "pin4a", "pin4b", "pin5a", "pin5b", "pin6"]
    kinds = {j.name: j.kind for j in hyq_leg("rigid").joints}
    assert kinds == {
        "slider": "prismatic", "hip": "revolute", "knee": "revolute", "pin2": "universal", "pin3": "universal",
        "pin5": "universal", "pin6": "universal", "hip_slide": "cylindrical", "knee_slide": "cylindrical",
    }


def test_dof_and_no_redundant_constraints(rigid_system):
    """Rigid: 7 bodies × 6 − (5 + 5 + 5 + 2 × (4 + 4 + 4)) = 3 DOF (slider, θ1, θ2), no redundant row.
    Bushing models: only the slider prismatic, the cylindrical pairs and the remaining rigid pins."""
    rep = dof_report(rigid_system)
    assert rep["redundant"] == [] and rep["gruebler"] == 3 and rep["rank"] == 3
    for joints, dof in (("bushings4", 42 - (5 + 5 + 4 + 4 + 4)), ("bushings8", 42 - (5 + 4 + 4))):
        rep = dof_report(pl.assemble(hyq_leg(joints, servo=False)))
        assert rep["redundant"] == [] and rep["gruebler"] == dof and rep["rank"] == dof


def test_actuator_and_servo_parameters():
    m = hyq_leg("rigid", gain="low", actuators="quasi-static")
    act = {a.name: a for a in m.actuators}
    assert act["hip_actuator"].stiffness == 8.30e4 and act["knee_actuator"].damping == 1.93e5
    pid = {c.name: c for c in m.controllers}
    assert pid["hip_servo"].kp == 150.0 and pid["hip_servo"].kd == 6.0
    assert act["hip_actuator"].free_length == pytest.approx(float(D.hip_cylinder_length(-30 * deg)))
    m8 = hyq_leg("bushings8")
    assert {c.name: c.kind for c in m8.controllers} == {"hip_servo": "discrete", "knee_servo": "discrete"}
    k = m8.force("pin1").stiffness
    assert np.diag(k)[:3].tolist() == [1e8, 1e8, 1e7] and np.diag(k)[5] == 0.0


# ------------------------------------------------------------------------------------------
# bad input
# ------------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    "kw,match",
    [
        (dict(joints="bushings6"), r"joints 'bushings6'.*'rigid', 'bushings4', 'bushings8'"),
        (dict(gain="medium"), r"gain 'medium'.*'low', 'high'"),
        (dict(actuators="static"), r"actuators 'static'.*'quasi-static', 'drop'"),
        (dict(payload=-1.0), r"payload must be ≥ 0"),
        (dict(drop_height=-0.01), r"below the force plate"),
        (dict(hip_angle=80 * deg), r"hip_angle.*outside"),
        (dict(bushing_stiffness=[1, 2, 3]), r"bushing_stiffness"),
        (dict(actuator_coefficients={"hip_q": 1.0}), r"hip_q"),
    ],
)
def test_bad_input(kw, match):
    with pytest.raises(pl.ModelError, match=match):
        hyq_leg(**kw)


def test_geometry_consistency():
    g = _geometry(-30 * deg, 60 * deg, 0.6, dict(cylinder_length=0.2, rod_length=0.15))
    assert np.linalg.norm(g["A1"] - g["O"]) == pytest.approx(D.HIP_A)
    assert np.linalg.norm(g["B1"] - g["O"]) == pytest.approx(D.HIP_B)
    assert np.linalg.norm(g["A2"] - g["K"]) == pytest.approx(D.KNEE_A)
    assert np.linalg.norm(g["B2"] - g["K"]) == pytest.approx(D.KNEE_B)
