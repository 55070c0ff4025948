"""HTML reports (proleg.report.html): one self-contained file with embedded figures and tables."""

import re

import numpy as np
import pandas as pd
import pytest

from proleg.errors import DataError
from proleg.report import Report, quicklook


def _results() -> pd.DataFrame:
    """A results-shaped frame: a 1 m pendulum tip, x = sin θ, z = -cos θ, θ = 0.3 cos(ω t)."""
    t = np.linspace(0.0, 2.0, 201)
    th = 0.3 * np.cos(np.sqrt(9.81) * t)
    return pd.DataFrame(
        {
            "time [s]": t,
            "lower.x [m]": np.sin(th),
            "lower.z [m]": -np.cos(th),
            "elbow.angle [rad]": th,
        }
    )


def test_report_is_self_contained(tmp_path):
    df = _results()
    rep = Report("Pendulum check", subtitle="two figures and a table")
    rep.add_heading("Results", 2)
    rep.add_text("Released from rest at **0.3 rad**; see `lower.x`.\n\n- small angle\n- no damping")
    rep.add_figure(quicklook(df, ["lower.*"], title="Tip position"), caption="Tip position")
    rep.add_figure(quicklook(df, "elbow.angle [rad]"), caption="Elbow angle")
    rep.add_table(df.iloc[::50], caption="Every 50th sample", float_format="{:.4f}")
    rep.add_parameters([("length", 1.0, "m", "assumed"), ("g", 9.81, "m/s^2", "ISO 80000-3")])
    rep.add_key_values({"integrator": "HHT", "steps": 2000})
    path = rep.save(tmp_path / "report.html")

    assert path == tmp_path / "report.html" and path.exists()
    text = path.read_text(encoding="utf-8")
    assert text.count('<img src="data:image/png;base64,') == 2
    assert rep.figures == ["Tip position", "Elbow angle"]
    assert rep.tables == ["Every 50th sample", "Parameters", ""]
    # Header texts, with the unit split into its own span.
    for name, unit in [("time", "[s]"), ("lower.x", "[m]"), ("lower.z", "[m]"), ("elbow.angle", "[rad]")]:
        assert f'{name} <span class="unit">{unit}</span>' in text
    for header in ("Parameter", "Value", "Unit", "Source", "Quantity"):
        assert f"<th>{header}</th>" in text
    assert "ISO 80000-3" in text and "HHT" in text
    assert "0.5000" in text  # float_format applied: the time column at t = 0.5 s
    assert "<strong>0.3 rad</strong>" in text and "<li>small angle</li>" in text
    # Self-contained: nothing fetched from the network or the disk.
    assert "http://" not in text and "https://" not in text
    assert 'src="file' not in text and "<link" not in text and "<script" not in text
    # The embedded images are valid PNGs.
    for b64 in re.findall(r'data:image/png;base64,([A-Za-z0-9+/=]+)"', text):
        import base64

        assert base64.b64decode(b64)[:8] == b"\x89PNG\r\n\x1a\n"


def test_text_is_escaped():
    rep = Report("<Title & co>")
    rep.add_text("a < b and <script>x</script>")
    html = rep.to_html()
    assert "<script>" not in html
    assert "&lt;Title &amp; co&gt;" in html and "a &lt; b" in html


def test_add_figure_closes_pyplot_figures():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots()
    ax.plot([0, 1], [0, 1])
    n = len(plt.get_fignums())
    Report("r").add_figure(fig, "line")
    assert len(plt.get_fignums()) == n - 1


def test_quicklook_groups_by_unit_and_checks_columns():
    df = _results()
    fig = quicklook(df, ["lower.x [m]", "lower.z [m]", "elbow.angle [rad]"])
    axes = fig.get_axes()
    assert [ax.get_ylabel() for ax in axes] == ["[m]", "[rad]"]
    assert len(axes[0].get_lines()) == 2
    np.testing.assert_array_equal(axes[1].get_lines()[0].get_xdata(), df["time [s]"])
    assert len(quicklook(df, group_by_unit=False).get_axes()) == 3
    with pytest.raises(DataError, match="no column matches 'upper.x'"):
        quicklook(df, ["upper.x"])
