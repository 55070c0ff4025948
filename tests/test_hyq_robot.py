"""The whole HyQ from its URDF: model contents, the weight-share closed form, the static torque
closed form against Pinocchio (no simulation), and (slow) the hyq-stand scenario: GRF per foot =
weight share within 1 %, servo torques = static closed form."""

import numpy as np
import pytest

pytest.importorskip("yourdfpy", reason="yourdfpy is not installed: pip install -e .[test]")

from proleg.errors import ModelError  # noqa: E402
from proleg.robots import hyq  # noqa: E402
from proleg.robots.hyq import LEGS, weight_share  # noqa: E402


def _model(**kw):
    try:
        return hyq(**kw)
    except ModelError as exc:  # no example-robot-data
        pytest.skip(str(exc))


def test_hyq_model():
    m = _model(drop=0.1)
    assert len(m.parts) == 13 and len(m.joints) == 12 and len(m.controllers) == 12
    assert sum(p.mass for p in m.parts) == pytest.approx(86.774005, abs=1e-9)  # URDF total (Pinocchio agrees)
    assert [c.name for c in m.contacts] == [f"{leg}_foot.contact" for leg in LEGS]
    for c in m.contacts:  # lowest sphere 10 cm above the ground
        assert c.marker.position[2] - c.radius == pytest.approx(0.1, abs=1e-12)
    assert m.force("lf_kfe_joint.damping").damping == 0.1


def test_weight_share_closed_form():
    feet = np.array([[0.4, 0.3], [0.4, -0.3], [-0.4, 0.3], [-0.4, -0.3]])
    np.testing.assert_allclose(weight_share(feet, (0.0, 0.0), 800.0), 200.0)
    f = weight_share(feet, (0.04, 0.015), 800.0)
    # rectangle: f_i = W (1/4 + x_c x_i / (4 a²) + y_c y_i / (4 b²))
    # rtol 1e-12: a well-conditioned 3 × 4 minimum-norm solve of ~200 N shares, round-off only
    np.testing.assert_allclose(f, 800 * (0.25 + 0.04 * feet[:, 0] / (4 * 0.16) + 0.015 * feet[:, 1] / (4 * 0.09)), rtol=1e-12)


def test_static_torques_against_pinocchio():
    """The static closed form τ_k = −a_k · Σ_distal (r − p_k) × F (hyq.static_torques) at the
    stance, with arbitrary foot forces at the sphere's ground point, equals Pinocchio's
    τ = g(q) − Σ J_footᵀ F (generalized gravity and the contact Jacobian at that point), for
    every joint: an independent check of the formula the slow scenario test relies on."""
    pin = pytest.importorskip("pinocchio", reason="Pinocchio (pip package 'pin') is not installed: pip install -e .[test]")
    import jax.numpy as jnp

    import proleg as pl
    from proleg.analyses.result import Result
    from proleg.analyses.simulate import initial_z
    from proleg.robots.hyq import FOOT_RADIUS, hyq_urdf_path, stance_positions, static_torques
    from proleg.spatial.rotation import p_from_matrix

    model = _model(drop=0.0)
    system = pl.assemble(model)
    q0 = system.params["q_init"]
    one = Result(system, np.zeros(1), q0[None], jnp.zeros_like(q0)[None], jnp.zeros((1, 2)), initial_z(system)[None])
    rng = np.random.default_rng(19)
    feet = {}
    for leg in LEGS:
        centre = np.asarray(one.marker(f"{leg}_foot.contact").position[0])
        feet[leg] = (rng.normal(0.0, 60.0, 3) + np.array([0.0, 0.0, 200.0]), centre - np.array([0.0, 0.0, FOOT_RADIUS]))
    tau = static_torques(one, 0, feet=feet)

    pm = pin.buildModelFromUrdf(str(hyq_urdf_path()), pin.JointModelFreeFlyer())
    pd = pm.createData()
    pm.gravity.linear = np.asarray(model.gravity, float)
    X = model.urdf.base_pose
    x, y, z, w = np.roll(np.asarray(p_from_matrix(X[:3, :3])), -1)  # proleg (w, x, y, z) → pin (x, y, z, w)
    q = np.zeros(pm.nq)
    q[:7] = [*X[:3, 3], x, y, z, w]
    for n, val in stance_positions().items():
        q[pm.joints[pm.getJointId(n)].idx_q] = val
    tau_pin = pin.computeGeneralizedGravity(pm, pd, q).copy()
    pin.computeJointJacobians(pm, pd, q)
    pin.updateFramePlacements(pm, pd)
    for leg, (F, point) in feet.items():
        fid = pm.getFrameId(f"{leg}_foot")
        J = pin.getFrameJacobian(pm, pd, fid, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
        r = point - pd.oMf[fid].translation  # from the frame origin to the ground point
        tau_pin -= J[:3].T @ F + J[3:].T @ np.cross(r, F)
    for n, t in tau.items():
        # both float64 sums of a few products of O(100 N) × O(0.5 m); 1e-9 N m is round-off
        assert t == pytest.approx(tau_pin[pm.joints[pm.getJointId(n)].idx_v], abs=1e-9), n


@pytest.mark.slow
def test_hyq_stand():
    from proleg.papers.hyq_stand import stand

    res, feet, joints, extra = stand(t_end=1.5)
    assert np.abs(feet["error [%]"]).max() < 1.0
    # servo torque vs static closed form: 1 % of the largest torque (the rest is the contact's
    # residual creep and the PD's damping of it at the last sample)
    tmax = np.abs(joints["static closed form [N m]"]).max()
    assert np.abs(joints["difference [N m]"]).max() < 0.01 * tmax
