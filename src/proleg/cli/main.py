"""The ``proleg`` command line (typer). Thin: every command calls the library."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import typer
from rich.table import Table

from ._out import MARKUP, ErrorsAsOneLine, console, error, say

# rich_markup_mode=None: help text as written ('[s]' stays); ErrorsAsOneLine: every error one line (cli/_out.py)
app = typer.Typer(add_completion=False, no_args_is_help=True, help="proleg: virtual prototyping of legged robots.",
                  rich_markup_mode=MARKUP, cls=ErrorsAsOneLine)

# name -> (module, function, description); scenarios write into results/<name>/ by default
SCENARIOS = {
    "hyq-drop": ("proleg.papers.hyq_report", "run_drop", "HyQ leg drop test: rigid vs 4 vs 8 bushings, HTML report (main job)"),
    "hyq-stand": ("proleg.papers.hyq_stand", "run_stand", "Whole HyQ (URDF) dropped 10 cm onto four feet: GRF vs weight share, torques vs statics, 3D animation"),
    "hyq-trot": ("proleg.papers.hyq_trot_report", "run_trot", "Whole HyQ trots at 1 m/s on hydraulic cylinders (pressures, flows, energy) beside ideal torque sources"),
    "hyq-jump": ("proleg.papers.hyq_jump", "run_jump", "Whole HyQ vertical jump on hydraulic cylinders, push designed by CMA-ES: height and what limits it (torque, pressure, flow)"),
    "hyq-static": ("proleg.papers.hyq_report", "run_static", "HyQ leg static test, payload 0/3/7 kg"),
    "hyq-quasistatic": ("proleg.papers.hyq_report", "run_quasistatic", "HyQ leg quasi-static cycles: force-stroke loops"),
    "scout2-bound": ("proleg.papers.scout2_report", "run_bound", "Scout II bounding: Table 6 as printed, the leg damping calibrated on the 1.286 m/s speed (or the stop where none bounds), predictions, HTML report"),
    "hyq-bushing-study": ("proleg.papers.hyq_study", "run_bushing_study", "HyQ 8-bushing drop vs pin stiffness 1e6-1e10 N/m: proleg.study store + HTML report"),
    "flegx-jump": ("proleg.papers.flegx_report", "run_jump", "FLEGX countermovement jump: rigid vs PRBM vs CB link (seed 002 Fig. 3)"),
    "flegx-machinery": ("proleg.papers.flegx_report", "run_machinery", "FLEGX worm-gear jump with landing vs ideal gears (seed 002 Fig. 4)"),
    "flegx-study": ("proleg.papers.flegx_report", "run_study", "FLEGX configurations 1-4 x link cases 1-6, Table I"),
    "torso-modal": ("proleg.papers.torso_report", "run_torso_modal", "HyQ torso FE modes vs a synthetic hammer test (seed 001 Table 2)"),
    "torque-sensor-study": ("proleg.papers.sensor_study", "run_torque_sensor_study", "HyQ torque sensor: five FE concepts, optuna optimisation, the spoke sensor designed to 1 deg at 140 N m"),
}


def _version(value: bool):
    if value:
        from proleg import __version__

        typer.echo(f"proleg {__version__}")
        raise typer.Exit()


@app.callback()
def main(version: bool = typer.Option(False, "--version", callback=_version, is_eager=True, help="Print the version.")):
    """proleg: virtual prototyping of legged robots (multibody dynamics in JAX, float64)."""


def _load(model_path: Path, fixed_base: bool = False):
    from proleg.errors import ModelError
    from proleg.io import load_model_file

    try:
        if model_path.suffix.lower() == ".urdf":
            import warnings

            from proleg.io.urdf import load_urdf

            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                return load_urdf(model_path, floating_base=not fixed_base), {}
        return load_model_file(model_path)
    except ModelError as exc:
        error(exc)


def _auto_choice(system) -> str:
    from proleg.solvers.auto import Auto

    ig, why = Auto().choose(system, 1.0)
    return f"{ig.describe()} — {why}"


def _assemble(mdl):
    """assemble, with a model error printed as one line and exit code 2."""
    import proleg as pl
    from proleg.errors import ModelError

    try:
        return pl.assemble(mdl)
    except ModelError as exc:
        error(str(exc))


@app.command()
def info(
    model: Path = typer.Argument(..., help="Model file (YAML or .urdf)."),
    json_out: bool = typer.Option(False, "--json", help="Print one JSON object instead of a table."),
    fixed_base: bool = typer.Option(False, "--fixed-base", help="URDF: weld the root link to ground (default: floating base)."),
):
    """Parts, markers, joints, elements, degrees of freedom (Gruebler and Jacobian rank), redundant
    constraints, the joint residual at the modelled pose, parts attached to nothing."""
    import warnings

    import proleg as pl
    from proleg.assembly.system import dof_report, unconnected_parts

    mdl, _ = _load(model, fixed_base)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        system = _assemble(mdl)
    dof = dof_report(system)
    data = {
        "model": mdl.name,
        "parts": [p.name for p in mdl.parts],
        "markers": [m.name for m in mdl.markers],
        "joints": [f"{j.name} ({j.kind})" for j in mdl.joints],
        "forces": [f"{f.name} ({f.kind})" for f in mdl.forces],
        "contacts": [c.name for c in mdl.contacts],
        "motions": [m.name for m in mdl.motions],
        "controllers": [c.name for c in mdl.controllers],
        "dof_gruebler": dof["gruebler"],
        "dof_rank": dof["rank"],
        "redundant": [f"{j}: {lab}" for j, lab in dof["redundant"]],
        "initial_residual": (f"{dof['initial_residual'][0]:.3g} ({dof['initial_residual'][1]}: {dof['initial_residual'][2]})"
                             if dof["initial_residual"][0] > 1e-12 else "0"),
        "unconnected_parts": unconnected_parts(system.topo),
        # What simulate's coordinates="auto" runs on (assembly/coordinates.py).
        "coordinates": "planar (3 per part)" if system.topo.planar[0] is not None else f"absolute (not planar: {system.topo.planar[1]})",
        # What simulate's integrator="auto" picks, and why (solvers/auto.py), for a 1 s run.
        "integrator": _auto_choice(system),
    }
    # The structure key's parts (issue 42): what a new compile depends on; every other number is
    # data (system.params), and a model that differs only in those shares the compiled run.
    from proleg.analyses.structure import structure_summary

    data["structure"] = structure_summary(system)
    if getattr(mdl, "urdf", None) is not None:
        data["mass_kg"] = round(sum(p.mass for p in mdl.parts), 6)
        data["urdf: dropped or approximated"] = list(mdl.urdf.notes)
    if json_out:
        typer.echo(json.dumps(data))
        return
    t = Table(title=f"model '{mdl.name}'", show_header=False)
    for k, v in data.items():
        if isinstance(v, dict):
            v = "; ".join(f"{kk}: {vv}" for kk, vv in v.items())
        t.add_row(k, ", ".join(map(str, v)) if isinstance(v, list) else str(v))
    console().print(t)


@app.command()
def simulate(
    model: Path = typer.Argument(..., help="Model file (YAML or .urdf)."),
    t_end: float = typer.Option(None, "--t-end", help="End time [s] (default: the file's simulate.t_end)."),
    dt_output: float = typer.Option(None, "--dt-output", help="Output interval [s] (default: the file's simulate.dt_output, else t_end/500)."),
    out: Path = typer.Option(Path("result.parquet"), "--out", help="Parquet file to write."),
    rtol: float = typer.Option(None, "--rtol", help="Relative local error tolerance [-] of the step-size control "
                               "(default: the file's simulate.rtol, else GeneralizedAlpha's 1e-6)."),
):
    """Simulate a model file and write the time histories to Parquet (units in column names)."""
    import proleg as pl
    from proleg.errors import SolverError

    mdl, opts = _load(model)
    t_end = t_end if t_end is not None else opts.get("t_end")
    if t_end is None:
        error("give --t-end or a 'simulate: {t_end: ...}' section in the model file.")
    kw = {}
    dt = dt_output if dt_output is not None else opts.get("dt_output")
    if rtol is not None or opts.get("rtol") is not None:
        kw["rtol"] = rtol if rtol is not None else opts["rtol"]
    if opts.get("atol") is not None:
        kw["atol"] = opts["atol"]
    system = _assemble(mdl)
    try:
        res = pl.simulate(system, t_end=t_end, dt_output=dt, progress=True, integrator=pl.GeneralizedAlpha(**kw))
    except SolverError as exc:
        if exc.result is not None and len(exc.result.t) > 1:
            exc.result.to_parquet(out)
            say(f"partial results ({len(exc.result.t)} outputs) written to {out}", "yellow")
        error(f"solver stopped: {exc}", 1)
    res.to_parquet(out)
    say(f"{res}\nwrote {out}")


@app.command()
def run(
    scenario: str = typer.Argument(..., help="Scenario name; `proleg run list` shows them."),
    out_dir: Path = typer.Option(None, "--out-dir", help="Output folder (default results/<scenario>)."),
):
    """Run a built-in virtual test of a source paper's system and write its results and report."""
    import importlib

    if scenario == "list" or scenario not in SCENARIOS:
        t = Table(title="scenarios")
        t.add_column("name")
        t.add_column("what")
        for k, (_, _, d) in SCENARIOS.items():
            t.add_row(k, d)
        console().print(t)
        if scenario != "list":
            error(f"unknown scenario '{scenario}'. Valid: {', '.join(SCENARIOS)}")
        return
    mod, fn, _ = SCENARIOS[scenario]
    target = getattr(importlib.import_module(mod), fn)
    out_dir = out_dir or Path("results") / scenario
    out_dir.mkdir(parents=True, exist_ok=True)
    path = target(out_dir)
    say(f"done: {path}", "green")


@app.command()
def view(
    result: Path = typer.Argument(..., help="Result Parquet file (Result.to_parquet, proleg simulate, proleg run)."),
    model: Path = typer.Option(None, "--model", help="Model file (.urdf or YAML) for the part shapes (URDF meshes)."),
    fixed_base: bool = typer.Option(False, "--fixed-base", help="URDF: the root link was welded to ground."),
    out: Path = typer.Option(None, "--out", help="HTML file to write (default: next to the Parquet file)."),
    open_: bool = typer.Option(True, "--open/--no-open", help="Open the page in the default browser."),
):
    """Write a self-contained 3D animation (HTML, opens offline) of a result file, and open it."""
    import pandas as pd

    from proleg.report.animate import page, scene_from_frame

    if not result.is_file():
        error(f"result file {result} not found.")
    try:
        df = pd.read_parquet(result)
    except Exception as exc:  # pyarrow's ArrowInvalid, OSError: not a Parquet file
        error(f"{result} is not a readable Parquet file ({type(exc).__name__}: {exc}).")
    if "time [s]" not in df.columns:
        error(f"{result} has no 'time [s]' column; expected a file written by Result.to_parquet.")
    mdl = _load(model, fixed_base)[0] if model is not None else None
    scene = scene_from_frame(df, model=mdl)
    if not scene["parts"]:
        error(f"{result} has no part pose columns ('NAME.x [m]', 'NAME.e0', ...).")
    out = out or result.with_suffix(".html")
    tmp = out.with_name(f".tmp-{out.name}")  # written whole, then renamed: never half a page
    try:
        tmp.write_text(page(scene, f"proleg: {result.name}"), encoding="utf-8")
        tmp.replace(out)
    except OSError as exc:
        tmp.unlink(missing_ok=True)
        error(f"cannot write {out}: {exc}")
    say(f"wrote {out}")
    if open_:
        import webbrowser

        webbrowser.open(out.resolve().as_uri())


def _register_optional():
    for modname in ("proleg.cli.prbm", "proleg.cli.identify", "proleg.cli.study", "proleg.cli.cache"):
        try:
            mod = __import__(modname, fromlist=["register"])
        except ImportError as exc:  # pragma: no cover - a broken optional module must not kill the CLI
            print(f"proleg: {modname} unavailable: {exc}", file=sys.stderr)
            continue
        mod.register(app)


_register_optional()

if __name__ == "__main__":
    app()
