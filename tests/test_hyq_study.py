"""The HyQ pin-stiffness study: a study row equals the drop test of the same variant built by
``hyq_tests.variant_system`` (the drop report's sweep)."""

import numpy as np
import pytest

from proleg.robots.hyq_leg import cylinder_forces
from proleg.papers.hyq_study import SWEEP_T_END, bushing_study
from proleg.papers.hyq_tests import drop_test, variant_system


@pytest.mark.slow
def test_study_rows_equal_the_drop_test_of_the_variant():
    st = bushing_study()
    ks = [1e6, 1e9]
    tab = st.run(design={"pin_stiffness": ks}, workers=1, progress=False)
    assert (tab["status"] == "success").all()
    for k, row in zip(ks, tab.to_dict("records")):
        r = drop_test(system=variant_system(st.target, bushing_stiffness=k), t_end=SWEEP_T_END).results["drop"]
        fh, fk = cylinder_forces(r)
        # same model and solver options, but sweep's free-running batch steps through the
        # output times without simulate's chunk boundaries (256 outputs): the step sequences
        # differ slightly (479 vs 492 steps at 1e9 N/m), so the peaks agree to ~1e-6, not exactly
        assert row["peak_hip_force"] == pytest.approx(np.abs(fh).max(), rel=1e-6)
        assert row["peak_knee_force"] == pytest.approx(np.abs(fk).max(), rel=1e-6)
        assert abs(row["steps"] - r.stats["steps"]) <= 0.05 * r.stats["steps"]
    # a softer pin lowers the hip peak (the drop report's hierarchy: 1e6 N/m well below rigid)
    assert tab["peak_hip_force"][0] < 0.5 * tab["peak_hip_force"][1]
