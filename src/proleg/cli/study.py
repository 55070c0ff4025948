"""``proleg study run | status | report``: YAML design studies (proleg.study).

Examples::

    proleg study run study.yaml [--executor dask --scheduler tcp://host:8786]
    proleg study status results/my-study
    proleg study report results/my-study
"""

from __future__ import annotations

import json as _json
from pathlib import Path

import typer

from ..errors import DataError, ModelError
from ._out import MARKUP, error, say

study_app = typer.Typer(add_completion=False, no_args_is_help=True, rich_markup_mode=MARKUP,
                        help="Design studies: run a YAML study file, show a store's status, write its report.")


@study_app.command("run")
def run(
    file: Path = typer.Argument(..., help="Study file (YAML)."),
    executor: str = typer.Option(None, "--executor", help="auto | vmap | processes | dask (default: the file's)."),
    scheduler: str = typer.Option(None, "--scheduler", help="Dask scheduler address, e.g. tcp://host:8786."),
    store: Path = typer.Option(None, "--store", help="Store folder (default: the file's store)."),
    workers: int = typer.Option(None, "--workers", help="Worker processes / concurrent batches."),
    lanes: int = typer.Option(None, "--lanes", help="Variants per compiled vmap call (1: one after the other)."),
    report: bool = typer.Option(True, "--report/--no-report", help="Write STORE/report.html afterwards."),
):
    """Run (or resume) the study of FILE; rows go to its Parquet store as batches finish."""
    from ..study.studyfile import load_study_file

    try:
        study, kw = load_study_file(file)
        if executor:
            kw["executor"] = executor
        if scheduler:
            kw["executor"], kw["scheduler"] = "dask", scheduler
        if store:
            kw["store"] = str(store)
        if workers:
            kw["workers"] = workers
        if lanes:
            kw["lanes"] = lanes
        table = study.run(progress=True, **kw)
    except (ModelError, DataError) as exc:
        error(exc)
    ok = int((table["status"] == "success").sum())
    say(f"done: {len(table)} variants ({ok} succeeded, {len(table) - ok} failed) in {kw['store']}", "green")
    if report:
        from ..study.report import study_report

        say(f"report: {study_report(kw['store'])}")


@study_app.command("status")
def status(store: Path = typer.Argument(..., help="Study store folder."), json: bool = typer.Option(False, "--json", help="Print one JSON object.")):
    """Done / failed / pending variants of a study store."""
    from ..study.store import Store

    st = Store(store)
    if st.definition() is None:
        error(f"'{store}' is not a study store (no study.json).")
    s = st.status()
    if json:
        typer.echo(_json.dumps(s))
        return
    typer.echo(f"{store}: {s['done']} done, {s['failed']} failed, {s['pending']} pending ({s['rows']} rows, {s['duplicates']} duplicates)")
    for k, v in s["by_status"].items():
        typer.echo(f"  {k}: {v}")


@study_app.command("report")
def report(store: Path = typer.Argument(..., help="Study store folder."), out: Path = typer.Option(None, "--out", help="HTML file (default STORE/report.html).")):
    """Write the HTML report of a study store."""
    from ..study.report import study_report

    try:
        typer.echo(str(study_report(store, out)))
    except DataError as exc:
        error(exc)


def register(app: typer.Typer) -> None:
    """Add ``study`` (run, status, report) to ``app``."""
    app.add_typer(study_app, name="study")
