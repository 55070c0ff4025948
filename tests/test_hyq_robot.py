"""The whole HyQ from its URDF: model contents, the weight-share closed form, and (slow) the
hyq-stand scenario: GRF per foot = weight share within 1 %, servo torques = static closed form."""

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
    np.testing.assert_allclose(f, 800 * (0.25 + 0.04 * feet[:, 0] / (4 * 0.16) + 0.015 * feet[:, 1] / (4 * 0.09)), rtol=1e-13)


@pytest.mark.slow
def test_hyq_stand():
    from proleg.robots.hyq import stand

    pytest.importorskip("pinocchio")
    res, feet, joints, extra = stand(t_end=1.5)
    assert np.abs(feet["error [%]"]).max() < 1.0
    # servo torque vs static closed form: 1 % of the largest torque (the rest is the contact's
    # residual creep and the PD's damping of it at the last sample)
    tmax = np.abs(joints["static closed form [N m]"]).max()
    assert np.abs(joints["difference [N m]"]).max() < 0.01 * tmax
