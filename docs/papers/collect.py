"""Run a scenario and bring its report's tables into the docs (docs/papers/tables/NAME/).

    PYTHONPATH=src python docs/papers/collect.py torso-modal flegx-jump     # run, then collect
    PYTHONPATH=src python docs/papers/collect.py --no-run hyq-static       # collect results/NAME/

A scenario runs for one to several minutes, too long for every docs build, so its tables are
committed here as CSV with the commit, date and wall time of the run (meta.json); docs/hooks.py
renders them on the seed pages (``<!-- scenario: NAME -->``). Every number on those pages is then
one the scenario computed, never typed in by hand. Rerun this after a change that moves them.
"""

from __future__ import annotations

import argparse
import datetime as _dt
import importlib
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd

ROOT = Path(__file__).resolve().parents[2]
OUT = ROOT / "docs" / "papers" / "tables"

def _drop_summary(df: pd.DataFrame) -> pd.DataFrame:
    """hyq-drop writes its channels (drop.parquet, one block per model); its summary table of peaks
    and settling is recomputed from them with the report's own functions."""
    from proleg.papers.hyq_report import summary_table
    from proleg.papers.hyq_tests import drop_summary

    order = list(dict.fromkeys(df["model"]))
    summ = summary_table({m: drop_summary(df[df["model"] == m].drop(columns="model").reset_index(drop=True)) for m in order})
    return summ.reset_index()


def _codesign(df: pd.DataFrame) -> pd.DataFrame:
    """flegx-study's co-design rows (codesign.parquet) as its report shows them."""
    from proleg.papers.flegx_report import codesign_table

    return codesign_table(df)


def _shared_law(df: pd.DataFrame) -> pd.DataFrame:
    """flegx-study's shared law: each configuration's shortest push within the limits (shared_law.parquet)."""
    from proleg.papers.flegx_report import shared_law_table

    return shared_law_table(df)


def _sensor_feasible(df: pd.DataFrame) -> pd.DataFrame:
    """torque-sensor-study's requirement trials (CMA-ES over FE solves) that meet the requirement,
    closest to the target twist first (the limits are sensor_requirement.REQUIREMENT's)."""
    from proleg.papers.sensor_requirement import REQUIREMENT as R

    ok = df[(df["status"] == "success") & (df["gauge_strain"] <= R["max_gauge_strain"]) & (df["safety_factor"] >= R["safety"])
            & df["twist"].between(R["twist_min"], R["twist_max"])]
    cols = ["spoke_width", "r_hub", "r_ring", "thickness", "gauge_offset", "twist", "stiffness", "gauge_strain", "safety_factor", "max_von_mises"]
    return ok.sort_values("twist_error")[cols].head(8).reset_index(drop=True)


# scenario -> [(Parquet file in results/NAME/, title, columns to keep, None for all, or a function
# of the table that derives the one to show)]
TABLES = {
    "hyq-drop": [("drop.parquet", "Drop test: peaks, settling and differences from the rigid leg (seed 000 Fig. 5, seed 001)", _drop_summary)],
    "hyq-quasistatic": [("identification.parquet", "Quasi-static cycles: cylinder stiffness k and damping c identified from the "
                         "force-stroke loops (seed 000 Eqs. 4-5)", None)],
    "hyq-static": [("static.parquet", "Static test: payloads on the slider, pose, cylinder forces and ground reaction", None)],
    "torso-modal": [("table2_calibrated_on.parquet", "Calibrated on: the Table 2 row the foam pads were fitted to (its agreement is "
                     "a fit, not a prediction)", None),
                    ("table2_predicted.parquet", "Predicted (held out): FE modes of the calibrated torso against seed 001 Table 2; "
                     "frame rows chosen by MAC with the bare frame's elastic modes", None),
                    ("table2_test_pairing.parquet", "Table 2's layout filled from the FE-versus-synthetic-test pairing by MAC", None)],
    "flegx-jump": [("metrics.parquet", "Countermovement jump, No. 4, 250×70×3 link: rigid vs PRBM vs Craig–Bampton", None)],
    "flegx-machinery": [("metrics.parquet", "Worm gears in the dynamics vs ideal gears (seed 002 Fig. 4)", None)],
    "flegx-study": [("shared_law.parquet", "The shared law: each configuration's shortest push within 520 MPa and 77 N m up to "
                     "take-off (PRBM, case 2); the longest sets the one law all variants run", _shared_law),
                    ("table1.parquet", "Seed 002 Table I: configurations 1–4 at the shared law, next to the paper", None),
                    ("codesign.parquet", "Table I by co-design: each configuration's optimum law within 520 MPa and 77 N m (reduced size)",
                     _codesign)],
    "scout2-bound": [("metrics.parquet", "Bounding gait metrics, Model I and Model II (seed 003 §5)", None)],
    "hyq-stand": [("feet.parquet", "Whole HyQ settled on four feet: vertical ground reaction per foot against its weight share", None),
                  ("joints.parquet", "Servo torques against the static closed form (moments of distal gravity and foot reaction)", None)],
    "hyq-trot": [("metrics.parquet", "The whole HyQ trotting at 1 m/s: hydraulic cylinders with chamber pressures against ideal torque "
                  "sources (every numeric metric of the run)", None)],
    "hyq-jump": [("metrics.parquet", "The whole HyQ jumping: the designed push on the cylinders against the same law on ideal torque "
                  "sources", None),
                 ("limit_check.parquet", "What limits the jump: the height gained with each limit raised alone (and together)",
                  ["raised", "jump_torque_limit", "hyq_supply_pressure", "hyq_valve_flow", "height", "height_gain", "limit",
                   "max_joint_torque", "max_chamber_pressure", "share_torque", "share_pressure", "share_flow", "status"])],
    "hyq-bushing-study": [("table.parquet", "8-bushing drop against the pins' radial stiffness (a proleg.study)",
                           ["pin_stiffness", "peak_hip_force", "peak_knee_force", "status", "steps", "newton_iterations"])],
    "torque-sensor-study": [("designs.parquet", "Torque-sensor concepts and the optimised design (seed 001 Problem 2)", None),
                            ("requirement_trials.parquet", "Spoke sensor designed to its requirement (about 1° at 140 N m, gauge strain "
                             "≤ 0.06 %, safety factor ≥ 1): the FE trials that meet it, closest to 1° first", _sensor_feasible)],
}


def _git(*args) -> str:
    return subprocess.run(["git", *args], cwd=ROOT, capture_output=True, text=True).stdout.strip()


def run(name: str, out_dir: Path) -> float:
    from proleg.cli.main import SCENARIOS

    module, function, _ = SCENARIOS[name]
    fn = getattr(importlib.import_module(module), function)
    t0 = time.perf_counter()
    import inspect

    # by signature, not by catching TypeError: a TypeError inside a run must not start it again
    quiet = {"progress": False} if "progress" in inspect.signature(fn).parameters else {}
    fn(str(out_dir), **quiet)
    return time.perf_counter() - t0


def collect(name: str, results: Path, wall_s: float | None) -> Path:
    folder = OUT / name
    folder.mkdir(parents=True, exist_ok=True)
    tables = []
    for file, title, cols in TABLES[name]:
        df = pd.read_parquet(results / file)
        if callable(cols):
            df = cols(df)
        elif cols:
            df = df[cols]
        if not isinstance(df.index, pd.RangeIndex):
            df = df.reset_index()
        csv = Path(file).with_suffix(".csv").name
        df.to_csv(folder / csv, index=False, float_format="%.6g")
        tables.append({"file": file, "title": title, "csv": csv})
    dirty = " (with uncommitted changes)" if _git("status", "--porcelain", "--", "src") else ""
    meta = {"scenario": name, "commit": _git("rev-parse", "--short", "HEAD") + dirty,
            "date": _dt.date.today().isoformat(), "wall_s": wall_s, "load_1min": round(os.getloadavg()[0], 1), "tables": tables}
    (folder / "meta.json").write_text(json.dumps(meta, indent=2) + "\n")
    return folder


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenarios", nargs="+", choices=sorted(TABLES))
    ap.add_argument("--no-run", action="store_true", help="collect the tables already in results/NAME/")
    ap.add_argument("--results", default=str(ROOT / "results"))
    a = ap.parse_args(argv)
    for name in a.scenarios:
        results = Path(a.results) / name
        wall = None if a.no_run else run(name, results)
        print(f"{name}: {collect(name, results, wall)}", file=sys.stderr)


if __name__ == "__main__":
    main()
