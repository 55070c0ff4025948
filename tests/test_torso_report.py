"""The torso-modal report (issues 31 and 35): its prose numbers are computed by the run (a
perturbed parameter changes them), the calibrated-on and predicted rows are apart, and the UFF
files and the stabilisation diagram are written."""

import re

import numpy as np
import pytest

pytest.importorskip("pyFRF")
pytest.importorskip("sdypy.EMA")


def _prose(html):
    return " ".join(re.findall(r"<p>(.*?)</p>", html, flags=re.S))


@pytest.mark.slow
def test_report_prose_follows_the_run(tmp_path):
    import pandas as pd

    from proleg.identify.uff import read_modes_uff, read_uff
    from proleg.papers.torso_report import run_torso_modal

    a = run_torso_modal(tmp_path / "a", n_hits=2, f_max=150.0)
    b = run_torso_modal(tmp_path / "b", n_hits=2, f_max=150.0, tube_wall=0.0035)
    pa, pb = _prose(a.read_text()), _prose(b.read_text())
    assert pa != pb
    # the predicted frame frequencies in the prose are the run's own table's, to the printed digits
    for path, prose in ((tmp_path / "a", pa), (tmp_path / "b", pb)):
        pred = pd.read_parquet(path / "table2_predicted.parquet")
        frame = pred[pred["quantity"].str.startswith("frame")]
        assert f"Predicted frame modes: {', '.join(f'{x:.1f}' for x in frame['FE [Hz]'])} Hz" in prose
        cal = pd.read_parquet(path / "table2_calibrated_on.parquet")
        assert list(cal["quantity"]) == ["bounce on foam"]
        assert "bounce on foam" not in set(pred["quantity"])
        assert read_uff(path / "hammer_frf.uff").data.shape[1] == 11
        m = read_modes_uff(path / "fe_modes.uff")
        assert m.frequencies.size > 10 and np.all(np.diff(m.frequencies) >= 0)
        assert (path / "stabilisation.parquet").exists()
    fa = pd.read_parquet(tmp_path / "a" / "table2_predicted.parquet")["FE [Hz]"].to_numpy()
    fb = pd.read_parquet(tmp_path / "b" / "table2_predicted.parquet")["FE [Hz]"].to_numpy()
    assert not np.allclose(fa, fb, rtol=1e-3)
