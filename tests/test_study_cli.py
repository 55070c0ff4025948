"""``proleg study run | status | report`` on a YAML study file, and its validation errors."""

import json

import pytest
from typer.testing import CliRunner

import proleg as pl
from proleg.cli.main import app
from proleg.study.studyfile import load_study_file

STUDY = """
name: cli-study
model: {model}
space:
  spring.stiffness: {{range: [10, 1000]}}
  spring.damping: {{log: [0.1, 2.0]}}
outputs:
  x_end: "r.part('lower').position[-1, 0]"
  z_min: "r.part('lower').position[:, 2].min()"
simulate: {{t_end: 0.1, dt_output: 0.01}}
design: {{kind: lhs, n: 4, seed: 1}}
workers: 1
store: store
"""


@pytest.mark.slow  # ~60 s on the loaded 2-core VM (a fresh compilation and the report figures)
def test_study_file_run_status_report(tmp_path):
    from pathlib import Path

    model = Path(__file__).parents[1] / "examples" / "double_pendulum.yaml"
    f = tmp_path / "s.yaml"
    f.write_text(STUDY.format(model=model))
    runner = CliRunner()
    res = runner.invoke(app, ["study", "run", str(f)])
    assert res.exit_code == 0, res.output
    rows = pl.study.Store(tmp_path / "store").read()
    assert len(rows) == 4 and (rows["status"] == "success").all()
    # the expressions give the same numbers as the Python API
    st, kw = load_study_file(f)
    r = pl.simulate(st.target.with_params({"spring.stiffness": rows["spring.stiffness"][0], "spring.damping": rows["spring.damping"][0]}), progress=False, t_end=0.1, dt_output=0.01)
    assert rows["z_min"][0] == pytest.approx(float(r.part("lower").position[:, 2].min()), abs=1e-10)
    res = runner.invoke(app, ["study", "status", str(tmp_path / "store"), "--json"])
    assert res.exit_code == 0 and json.loads(res.stdout) == {"rows": 4, "done": 4, "failed": 0, "pending": 0, "duplicates": 0, "by_status": {"success": 4}}
    html = (tmp_path / "store" / "report.html").read_text()
    assert html.count("<img") >= 3 and "Pareto" in html


def test_study_file_errors_name_the_field(tmp_path):
    f = tmp_path / "bad.yaml"
    f.write_text("space: {a: {range: [1, 2]}}\noutputs: {x: 'r.t[-1]'}\nsimulate: {t_end: 1}\ndesign: {kind: latin}\nrobot: hyq_leg\n")
    with pytest.raises(pl.ModelError, match="design.kind"):
        load_study_file(f)
    f.write_text("space: {a: [1, 2]}\noutputs: {x: 'r.t[-1]'}\nsimulate: {t_end: 1}\nrobot: hyq_leg\n")
    with pytest.raises(pl.ModelError, match="space.a is a bare list"):
        load_study_file(f)
    f.write_text("space: {a: 1}\noutputs: {x: 'r.t[-1]'}\nsimulate: {t_end: 1}\n")
    with pytest.raises(pl.ModelError, match="exactly one of 'model'"):
        load_study_file(f)
    f.write_text("space: {a: {range: [1, 2]}}\noutputs: {x: 'r.t[-1]'}\nsimulate: {t_end: 1}\nrobot: hyq_leg\nlanes: 0\n")
    with pytest.raises(pl.ModelError, match="lanes"):
        load_study_file(f)
    res = CliRunner().invoke(app, ["study", "status", str(tmp_path)])
    assert res.exit_code == 2 and "study store" in res.output
