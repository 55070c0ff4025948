"""The identify/validate CLI on real pneumatic-piston friction data and on synthetic files."""

import json
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import typer
from typer.testing import CliRunner

from proleg.cli.identify import register

DATA = Path("/work/shared/data")
REAL = {p: DATA / f"pneumatic_piston_friction_O-ring_{p}.csv" for p in ("1bar", "5bar")}

app = typer.Typer()


@app.callback()
def _root() -> None:
    """Test root: register() adds 'identify' and 'validate'."""


register(app)
runner = CliRunner()


def run_json(args):
    res = runner.invoke(app, args)
    assert res.exit_code == 0, res.output
    return json.loads(res.stdout)


@pytest.mark.parametrize("pressure", ["1bar", "5bar"])
def test_real_friction_data_hysteresis(pressure, tmp_path):
    path = REAL[pressure]
    if not path.exists():
        pytest.skip(f"{path} not available")
    fig = tmp_path / "loops.png"
    out = run_json(["identify", "hysteresis", str(path), "--force", "force_N", "--stroke", "position_mm",
                    "--time", "time_ms", "--units", "force=N,stroke=mm,time=ms", "--figure", str(fig), "--json"])
    print(f"\n{pressure}: k = {out['k']:.4g} N/m {out['k_ci']}, c = {out['c']:.4g} N s/m {out['c_ci']}, "
          f"F_c = {out['friction']:.4g} N {out['friction_ci']} (loop area), "
          f"fit {out['friction_fit']:.4g} N, cycles {out['cycles']}, runs {out['runs']}")
    # the file is one continuous record of 10 back-and-forth strokes (time never restarts; the largest
    # gap is 0.27 s at the start): each loop is one repetition
    assert out["runs"] == 10 and out["cycles"] == 10 and out["runs_in_file"] == 1
    assert out["repetition"] == "loop"
    for q in ("k", "c", "friction", "friction_fit"):
        lo, hi = out[f"{q}_ci"]
        assert lo < out[q] < hi
    # O-ring friction: the force steps by about 2 F_c = 11 N (1 bar) / 18 N (5 bar) when the stroke
    # reverses; the level rises with pressure (the seal is pressed harder)
    expected = {"1bar": (4.0, 7.0), "5bar": (7.0, 11.0)}[pressure]
    assert expected[0] < out["friction"] < expected[1]
    # the loop-area level ΔE/4X and the least-squares Coulomb term agree within 3 %
    assert out["friction_fit"] == pytest.approx(out["friction"], rel=0.03)
    assert out["c"] > 0
    # the seal is nearly rigid along the stroke: k is tiny against F_c / X (5.4 N / 20 mm = 270 N/m)
    assert abs(out["k"]) < 0.3 * out["friction"] / 0.02
    assert fig.stat().st_size > 1000


def test_real_data_table_output():
    if not REAL["1bar"].exists():
        pytest.skip("data not available")
    res = runner.invoke(app, ["identify", "hysteresis", str(REAL["1bar"]), "--force", "force_N",
                              "--stroke", "position_mm", "--time", "time_ms"])
    assert res.exit_code == 0, res.output
    assert "k (RMS slope" in res.stdout and "95 % CI" in res.stdout
    assert "10 loops" in res.stdout


def test_bad_input_exits_2_with_message(tmp_path):
    if not REAL["1bar"].exists():
        pytest.skip("data not available")
    res = runner.invoke(app, ["identify", "hysteresis", str(REAL["1bar"]), "--force", "force_kN",
                              "--stroke", "position_mm", "--time", "time_ms"])
    assert res.exit_code == 2
    assert "force_kN" in res.stderr and "Available columns" in res.stderr
    assert "Traceback" not in res.output
    d = pd.read_csv(REAL["1bar"], nrows=300)
    d.loc[41, "position_mm"] = np.nan
    p = tmp_path / "nan.csv"
    d.to_csv(p, index=False)
    res = runner.invoke(app, ["identify", "hysteresis", str(p), "--force", "force_N", "--stroke", "position_mm",
                              "--time", "time_ms", "--json"])
    assert res.exit_code == 2 and "data row 42" in res.stderr and res.stdout == ""
    res = runner.invoke(app, ["identify", "hysteresis", str(tmp_path / "none.csv"), "--force", "f",
                              "--stroke", "s"])
    assert res.exit_code == 2 and "not found" in res.stderr


def test_drop_cli(tmp_path):
    sys.path.insert(0, str(Path(__file__).parent))
    from test_identify_classical import drop_record

    t, F, c, v0, _ = drop_record(zeta=0.6)
    p = tmp_path / "drop.csv"
    pd.DataFrame({"t_ms": t * 1e3, "fz_kN": F / 1e3}).to_csv(p, index=False)
    out = run_json(["identify", "drop", str(p), "--force", "fz_kN", "--time", "t_ms", "--mass", "4.5", "--json"])
    assert out["c"] == pytest.approx(c, rel=1e-3)
    assert out["v_impact"] == pytest.approx(v0, rel=1e-4)
    out = run_json(["identify", "drop", str(p), "--force", "fz_kN", "--time", "t_ms", "--mass", "4.5",
                    "--height", "0.05", "--json"])
    assert out["v_impact"] == pytest.approx(v0, rel=1e-12)


def test_battery_cli(tmp_path):
    i = np.linspace(0.5, 18.0, 40)
    p = tmp_path / "batt.parquet"
    pd.DataFrame({"i_mA": i * 1e3, "v": 37.17 - 0.13 * i}).to_parquet(p)
    out = run_json(["identify", "battery", str(p), "--current", "i_mA", "--voltage", "v",
                    "--figure", str(tmp_path / "b.png"), "--json"])
    assert out["v_nom"] == pytest.approx(37.17, rel=1e-12)
    assert out["r_s"] == pytest.approx(0.13, rel=1e-10)
    assert (tmp_path / "b.png").exists()


def test_validate_cli(tmp_path):
    t = np.arange(0, 4, 0.001)
    sim = pd.DataFrame({"time": t, "hip_force": 500 + 100 * np.sin(2 * np.pi * t)})
    te = np.arange(0, 4, 0.004)
    exp = pd.DataFrame({"time_ms": te * 1e3, "F": 500 + 100 * np.sin(2 * np.pi * (te - 0.03)) + 2.0})
    sp, ep = tmp_path / "sim.parquet", tmp_path / "exp.csv"
    sim.to_parquet(sp)
    exp.to_csv(ep, index=False)
    out = run_json(["validate", str(sp), str(ep), "--map", "hip_force=F", "--data-time", "time_ms",
                    "--figure", str(tmp_path / "o.png"), "--json"])
    assert out["shift"] == pytest.approx(0.03, abs=2e-4)
    m = out["metrics"]["F"]
    assert m["rms"] == pytest.approx(2.0, rel=0.05)
    assert m["r"] > 0.999
    res = runner.invoke(app, ["validate", str(sp), str(ep), "--map", "hip_force=G", "--data-time", "time_ms"])
    assert res.exit_code == 2 and "'G'" in res.stderr
