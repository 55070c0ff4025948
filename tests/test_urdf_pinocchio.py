"""Cross-check against an independent engine: HyQ and Solo12 from example-robot-data's URDFs, at
20 random states (floating base pose and twist, joint positions within limits, joint rates,
joint torques), proleg's joint-space mass matrix and accelerations equal Pinocchio's
(``crba``, ``aba``) within 1e-8 relative; total mass and COM equal.

proleg integrates absolute coordinates with constraints (index-3 DAE), so the comparison maps
the joint-space state to absolute (q, v) (proleg.io.urdf_kin), checks that it satisfies every
constraint, forms M_j = Jᵀ M J with J = ∂v/∂ν, solves proleg's own KKT system
[[M, Φ_qᵀ], [Φ_q, 0]] for q̈, and maps q̈ back to joint space (least squares on J). The joint
damping of the URDF (<dynamics damping>, modelled by proleg) is added to Pinocchio's torque as
−d q̇, since ``aba`` does not apply it.
"""

import warnings
from pathlib import Path

import numpy as np
import pytest

pin = pytest.importorskip("pinocchio", reason="Pinocchio (pip package 'pin') is not installed: pip install -e .[test]")

import jax  # noqa: E402
import jax.numpy as jnp  # noqa: E402

import proleg as pl  # noqa: E402
from proleg.analyses.simulate import initial_z  # noqa: E402
from proleg.assembly.system import constraints  # noqa: E402
from proleg.io.urdf import UrdfWarning, load_urdf  # noqa: E402
from proleg.io.urdf_kin import joint_space_jacobian, joint_space_state  # noqa: E402
from proleg.model.control import JointActuator  # noqa: E402
from proleg.solvers.initial import kkt_accelerations, mass_matrix  # noqa: E402
from models import robot_path  # noqa: E402

# Both quantities are float64 results of O(n) recursions (Pinocchio) vs dense KKT solves
# (proleg) on ~90 coordinates; measured ~1e-15. 1e-8 is the bound.
RTOL = 1e-8


@pytest.mark.parametrize(
    "rel",
    [
        "hyq_description/robots/hyq_no_sensors.urdf",
        # same check, a second robot: ~60 s more (compilation) on a 2-core machine
        pytest.param("solo_description/robots/solo12.urdf", marks=pytest.mark.slow),
    ],
    ids=["hyq", "solo12"],
)
def test_against_pinocchio(rel):
    path = robot_path(rel)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UrdfWarning)
        model = load_urdf(path, joint_stops=False, feet=())
    names = model.urdf.joint_names()
    for n in names:
        model.add_actuator(JointActuator(f"{n}.tau", n, effort=0.0))
    system = pl.assemble(model)
    z0 = initial_z(system)

    pm = pin.buildModelFromUrdf(str(path), pin.JointModelFreeFlyer())
    pd = pm.createData()
    iq = np.array([pm.joints[pm.getJointId(n)].idx_q for n in names])
    iv = np.array([pm.joints[pm.getJointId(n)].idx_v for n in names])
    perm = np.r_[0:6, iv]
    damping = np.array([float(pm.damping[i]) for i in iv])

    masses = np.array([p.mass for p in model.parts])
    # n positive masses summed in two orders (Pinocchio sums its bodies, merged over fixed
    # joints): each within (n − 1) eps relative of the exact sum, so 2 n eps in any order
    assert masses.sum() == pytest.approx(pin.computeTotalMass(pm), rel=2 * len(masses) * np.finfo(float).eps)

    @jax.jit
    def proleg_side(qj, vj, bp, bq, nu, tau):
        q, v, qdd0 = joint_space_state(model, qj, vj, base_position=bp, base_quaternion=bq, base_velocity=nu)
        J = joint_space_jacobian(model, qj, base_position=bp, base_quaternion=bq)
        qdd, _ = kkt_accelerations(system.with_params(joint_actuator_effort=tau), q, v, 0.0, z0)
        Mj = J.T @ mass_matrix(system, q) @ J
        a = jnp.linalg.lstsq(J, qdd - qdd0)[0]
        com = masses @ q.reshape(-1, 7)[:, :3] / masses.sum()
        return Mj, a, com, jnp.abs(constraints(system, q, 0.0)).max()

    lo = np.array([j[3] if j[3] is not None else -np.pi for j in model.urdf.joints])
    hi = np.array([j[4] if j[4] is not None else np.pi for j in model.urdf.joints])
    rng = np.random.default_rng(19)
    worst = np.zeros(3)
    for _ in range(20):
        qj, vj, tau = rng.uniform(lo, hi), rng.normal(size=len(names)), rng.normal(scale=10.0, size=len(names))
        bp, nu = rng.normal(size=3), rng.normal(size=6)
        bq = rng.normal(size=4)
        bq /= np.linalg.norm(bq)
        qp = np.zeros(pm.nq)
        qp[:3], qp[3:7], qp[iq] = bp, [bq[1], bq[2], bq[3], bq[0]], qj  # Pinocchio: quaternion x, y, z, w
        vp = np.zeros(pm.nv)
        vp[:6], vp[iv] = nu, vj
        tp = np.zeros(pm.nv)
        tp[iv] = tau - damping * vj
        a_pin = pin.aba(pm, pd, qp, vp, tp)[perm]
        M_pin = pin.crba(pm, pd, qp)
        M_pin = (np.triu(M_pin) + np.triu(M_pin, 1).T)[np.ix_(perm, perm)]
        com_pin = pin.centerOfMass(pm, pd, qp).copy()

        Mj, a, com, phi = (np.asarray(x) for x in proleg_side(qj, vj, bp, bq, nu, tau))
        assert phi < 1e-12  # the mapped state satisfies every joint constraint
        e = (np.linalg.norm(Mj - M_pin) / np.linalg.norm(M_pin), np.linalg.norm(a - a_pin) / np.linalg.norm(a_pin), np.abs(com - com_pin).max())
        worst = np.maximum(worst, e)
    assert worst[0] < RTOL, f"mass matrix relative error {worst[0]:.2e}"
    assert worst[1] < RTOL, f"acceleration relative error {worst[1]:.2e}"
    assert worst[2] < 1e-12, f"COM error {worst[2]:.2e} m"
    print(f"{rel}: worst relative error M {worst[0]:.1e}, accelerations {worst[1]:.1e}; COM {worst[2]:.1e} m")
