"""``proleg identify ...`` and ``proleg validate``: classical identification and validation from files.

Thin wrappers: read and check the file (:mod:`proleg.identify.data`), call
:mod:`proleg.identify` / :mod:`proleg.validate`, print a rich table or one JSON object
(``--json``), optionally save a figure. A bad file prints the reason (file, column, row) and exits
with code 2.
"""

from __future__ import annotations

import functools
import json
import math
from pathlib import Path
from typing import Annotated

import typer
from rich.table import Table

from ..errors import DataError
from ._out import MARKUP, console, error

identify_app = typer.Typer(rich_markup_mode=MARKUP, help="Identify stiffness, damping, friction and battery parameters from measurements.",
                           no_args_is_help=True)

_UNITS_HELP = ("Units per role, e.g. 'force=N,stroke=mm,time=ms'. Default: the column-name suffix "
               "(time_ms -> ms, position_mm -> mm) or SI.")


def _fail(message: str) -> None:
    error(message)


def _data_errors(fn):
    """Turn a DataError (and a missing file) into a clear message and exit code 2."""

    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        try:
            return fn(*args, **kwargs)
        except DataError as exc:
            _fail(str(exc))
        except FileNotFoundError as exc:
            _fail(f"{exc.filename}: file not found.")

    return wrapper


def _json_out(obj: dict) -> None:
    """Print exactly one JSON object (no NaN: non-finite floats become null)."""

    def clean(v):
        if isinstance(v, float) and not math.isfinite(v):
            return None
        if isinstance(v, dict):
            return {k: clean(x) for k, x in v.items()}
        if isinstance(v, (list, tuple)):
            return [clean(x) for x in v]
        if hasattr(v, "item"):
            return clean(v.item())
        return v

    typer.echo(json.dumps(clean(obj), allow_nan=False))


def _g(v: float) -> str:
    return f"{v:.5g}"


@identify_app.command("hysteresis")
@_data_errors
def hysteresis(
    data: Annotated[Path, typer.Argument(help="CSV or Parquet file with force and stroke columns.")],
    force: Annotated[str, typer.Option("--force", help="Force column.")],
    stroke: Annotated[str, typer.Option("--stroke", help="Stroke (displacement) column.")],
    time: Annotated[str, typer.Option("--time", help="Time column.")] = "time",
    units: Annotated[str | None, typer.Option("--units", help=_UNITS_HELP)] = None,
    run_col: Annotated[str | None, typer.Option("--run-col", help="Column with a run id (else runs are "
                                                                  "split at time restarts/gaps).")] = None,
    confidence: Annotated[float, typer.Option("--confidence", min=0.5, max=0.999, help="Confidence level of the intervals [-], 0.5-0.999.")] = 0.95,
    figure: Annotated[Path | None, typer.Option("--figure", help="Save loops + RMS line here (PNG/PDF/SVG).")] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print one JSON object instead of a table.")] = False,
) -> None:
    """Stiffness (RMS line, Eq. 4), damping (loop energy, Eq. 5) and Coulomb friction with intervals."""
    from ..identify.classical import identify_hysteresis, plot_hysteresis
    from ..identify.data import load_record, parse_units

    rec = load_record(data, {"force": force, "stroke": stroke, "time": time}, units=parse_units(units),
                      time="time", run_col=run_col)
    res = identify_hysteresis(rec["time"], rec["stroke"], rec["force"], run=rec.run, confidence=confidence,
                              source=rec.source, stroke_name=stroke)
    if figure is not None:
        plot_hysteresis(res, figure)
    if as_json:
        out = res.to_dict()
        out["file"] = str(data)
        out["columns"] = rec.columns
        out["units_read"] = rec.units
        if figure is not None:
            out["figure"] = str(figure)
        _json_out(out)
        return
    con = console()
    rep = ("each loop is one repetition (one continuous run)" if res.repetition == "loop"
           else f"each of the {res.nruns} runs is one repetition")
    tb = Table(title=f"{data.name}: {len(res.loops)} loops, {len(res.repetitions)} repetitions ({rep})")
    for col in ("quantity", "mean", f"{int(100 * confidence)} % CI", "σ rel", "unit"):
        tb.add_column(col, justify="right" if col != "quantity" else "left")
    names = {"k": "k (RMS slope, Eq. 4)", "c": "c (loop energy, Eq. 5)", "friction": "F_c (loop area = 4 F_c X)",
             "k_fit": "k (fit with Coulomb term)", "friction_fit": "F_c (fit F = kx + F_c sgn ẋ + F0)"}
    for q, row in res.table.iterrows():
        tb.add_row(names.get(q, q), _g(row["mean"]), f"[{_g(row['ci_low'])}, {_g(row['ci_high'])}]",
                   f"{100 * row['rel_sigma']:.2f} %", row["unit"])
    con.print(tb)
    con.print(f"units read: {rec.units}")
    if figure is not None:
        con.print(f"figure: {figure}")


@identify_app.command("drop")
@_data_errors
def drop(
    data: Annotated[Path, typer.Argument(help="CSV or Parquet file of one drop test.")],
    force: Annotated[str, typer.Option("--force", help="Impact (ground) force column, upwards positive.")],
    time: Annotated[str, typer.Option("--time", help="Time column.")],
    mass: Annotated[float, typer.Option("--mass", help="Dropped mass [kg].")],
    stroke: Annotated[str | None, typer.Option("--stroke", help="Measured compression column (optional).")] = None,
    v_impact: Annotated[float | None, typer.Option("--v-impact", help="Impact speed [m/s] (default: Eq. 7).")] = None,
    height: Annotated[float | None, typer.Option("--height", help="Drop height [m]; v = sqrt(2 g h).")] = None,
    units: Annotated[str | None, typer.Option("--units", help=_UNITS_HELP)] = None,
    threshold: Annotated[float | None, typer.Option("--threshold", help="Force rise marking the impact [N].")] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print one JSON object.")] = False,
) -> None:
    """Damping from a drop test by impulse/momentum balance (seed 000, Eqs. 6-7)."""
    from ..identify.classical import G0, drop_damping
    from ..identify.data import load_record, parse_units

    if v_impact is not None and height is not None:
        raise DataError("give either --v-impact or --height, not both.")
    if height is not None:
        if not height > 0:
            raise DataError(f"--height must be positive [m], got {height}.")
        v_impact = math.sqrt(2.0 * G0 * height)
    rec = load_record(data, {"force": force, "time": time, "stroke": stroke}, units=parse_units(units), time="time")
    res = drop_damping(rec["time"], rec["force"], mass, stroke=rec.data.get("stroke"), v_impact=v_impact,
                       threshold=threshold, source=rec.source)
    if as_json:
        out = res.to_dict()
        out["file"] = str(data)
        _json_out(out)
        return
    tb = Table(title=f"{data.name}: drop test, m = {mass:g} kg")
    tb.add_column("quantity")
    tb.add_column("value", justify="right")
    tb.add_column("unit")
    for name, v, u in [("impact at", res.t_impact, "s"), ("ΔT (impact window)", res.duration, "s"),
                       ("impulse ∫F dt", res.impulse, "N s"), ("v_i used", res.v_impact, "m/s"),
                       ("v_i from Eq. 7", res.v_impact_eq7 if res.v_impact_eq7 is not None else float("nan"), "m/s"),
                       ("Δl_max", res.dl_max, "m"), ("c (momentum fit)", res.c, "N s/m"),
                       ("k (momentum fit)", res.k, "N/m"), ("c (Eq. 6 as printed)", res.c_eq6, "N s/m")]:
        tb.add_row(name, "-" if not math.isfinite(v) else _g(v), u)
    console().print(tb)


@identify_app.command("battery")
@_data_errors
def battery(
    data: Annotated[Path, typer.Argument(help="CSV or Parquet file with current and voltage.")],
    current: Annotated[str, typer.Option("--current", help="Load current column [A].")],
    voltage: Annotated[str, typer.Option("--voltage", help="Terminal voltage column [V].")],
    units: Annotated[str | None, typer.Option("--units", help="Units, e.g. 'current=mA,voltage=V'.")] = None,
    figure: Annotated[Path | None, typer.Option("--figure", help="Save data, fit and residuals here.")] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print one JSON object.")] = False,
) -> None:
    """Battery model V = V_nom - i R_s by least squares (seed 003, Eq. 9)."""
    from ..identify.classical import fit_battery, plot_battery
    from ..identify.data import load_record, parse_units

    rec = load_record(data, {"current": current, "voltage": voltage}, units=parse_units(units), time=None,
                      allow_constant=("voltage",))
    fit = fit_battery(rec["current"], rec["voltage"], source=rec.source)
    if figure is not None:
        plot_battery(fit, figure)
    if as_json:
        out = fit.to_dict()
        out["file"] = str(data)
        _json_out(out)
        return
    tb = Table(title=f"{data.name}: V = V_nom − i R_s ({fit.current.size} points)")
    for c in ("parameter", "value", "std. error", "unit"):
        tb.add_column(c)
    tb.add_row("V_nom", _g(fit.v_nom), _g(fit.v_nom_se), "V")
    tb.add_row("R_s", _g(fit.r_s), _g(fit.r_s_se), "Ω")
    tb.add_row("RMS residual", _g(fit.rms), "", "V")
    console().print(tb)


@_data_errors
def validate_cmd(
    sim: Annotated[Path, typer.Argument(help="Simulation result (CSV or Parquet) with a time column.")],
    data: Annotated[Path, typer.Argument(help="Measurement (CSV or Parquet).")],
    map: Annotated[str, typer.Option("--map", help="Signal pairs 'sim_col=data_col,...'.")],
    sim_time: Annotated[str, typer.Option("--sim-time", help="Time column of the simulation [s].")] = "time",
    data_time: Annotated[str, typer.Option("--data-time", help="Time column of the measurement.")] = "time",
    units: Annotated[str | None, typer.Option("--units", help="Units of measurement columns, e.g. "
                                                               "'time_ms=ms,force=kN' (default: suffix or SI).")] = None,
    align: Annotated[bool, typer.Option("--align/--no-align", help="Shift the simulation by cross-correlation.")] = True,
    max_shift: Annotated[float | None, typer.Option("--max-shift", help="Largest shift searched [s].")] = None,
    figure: Annotated[Path | None, typer.Option("--figure", help="Save an overlay figure here.")] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print one JSON object.")] = False,
) -> None:
    """Compare a simulation with a measurement: time shift, RMS / max / normalised error, correlation."""
    from ..identify.data import _suffix_unit, check_signal, parse_mapping, read_table, unit_factor
    from ..validate import compare, plot_overlay

    pairs = parse_mapping(map, what="--map")
    if not pairs:
        raise DataError("--map is empty; give pairs like 'hip_force=force_N'.")
    unit_map = parse_mapping(units, what="--units")
    s = read_table(sim)
    e = read_table(data).copy()
    for col in [data_time, *pairs.values()]:
        if col not in e.columns:
            raise DataError(f"{data}: column '{col}' not found. Available columns: "
                            f"{', '.join(str(c) for c in e.columns)}.")
        unit = unit_map.get(col) or _suffix_unit(col)
        if unit:
            vals = check_signal(e[col], source=str(data), column=col, allow_constant=True)
            e[col] = vals * unit_factor(unit, what=f"{data}: unit of '{col}'")
    res = compare(s, e, pairs, sim_time=sim_time, exp_time=data_time, align=align, max_shift=max_shift)
    if figure is not None:
        plot_overlay(res, figure)
    if as_json:
        _json_out({"shift": res.shift, "metrics": {k: dict(v) for k, v in res.metrics.iterrows()}})
        return
    tb = Table(title=f"{sim.name} vs {data.name} (simulation shifted by {res.shift:.4g} s)")
    for c in ("signal", "sim", "RMS", "max |e|", "NRMS", "r", "n"):
        tb.add_column(c)
    for sig, row in res.metrics.iterrows():
        tb.add_row(sig, row["sim"], _g(row["rms"]), _g(row["max_abs"]), f"{100 * row['nrms']:.2f} %",
                   f"{row['r']:.4f}", str(int(row["n"])))
    console().print(tb)


def register(app: typer.Typer) -> None:
    """Add ``identify`` (sub-commands hysteresis, drop, battery) and ``validate`` to the main app."""
    app.add_typer(identify_app, name="identify")
    app.command("validate")(validate_cmd)


@identify_app.command("fit")
@_data_errors
def fit_cmd(
    model: Path = typer.Argument(..., help="Model file (YAML)."),
    data: Path = typer.Argument(..., help="Experiment CSV or Parquet."),
    params: str = typer.Option(..., "--params", help="Comma-separated parameters, e.g. 'spring.stiffness,spring.damping'."),
    map_: str = typer.Option(..., "--map", help="column=signal pairs, e.g. 'z_mm=mass.z' (signal specs: part.x, joint.angle, element.output)."),
    time_col: str = typer.Option("time", "--time", help="Time column."),
    units: str = typer.Option("", "--units", help="Units per column, e.g. 'time=ms,z_mm=mm'."),
    rtol: float = typer.Option(1e-7, "--rtol", help="Simulation tolerance during the fit."),
    figure: Path = typer.Option(None, "--figure", help="Write the measured-vs-fitted overlay here."),
    json_out: bool = typer.Option(False, "--json", help="Print one JSON object."),
):
    """Fit model parameters to a measured time series through the differentiable simulator (Levenberg-Marquardt)."""
    import json as _json

    import numpy as np

    import proleg as pl
    from proleg.identify.data import load_record
    from proleg.identify.fit import fit, plot_fit
    from proleg.io import load_model_file

    from proleg.errors import ModelError

    try:
        pairs = [p.split("=", 1) for p in map_.split(",") if p.strip()]
        if not pairs or any(len(p) != 2 for p in pairs):
            raise DataError(f"--map '{map_}': give column=signal pairs separated by commas.")
        unit_map = dict(p.split("=", 1) for p in units.split(",") if p.strip())
        roles = {col: col for col, _ in pairs}
        roles["time"] = time_col
        rec = load_record(data, roles, units={("time" if k == time_col else k): v for k, v in unit_map.items()})
        mdl, _ = load_model_file(model)
        system = pl.assemble(mdl)
        t = np.asarray(rec.data["time"])
        measured = {sig: np.asarray(rec.data[col]) for col, sig in pairs}
        res = fit(system, [p.strip() for p in params.split(",")], t, measured, simulate_kw=dict(rtol=rtol, atol=rtol * 1e-1))
        if figure is not None:
            fig = plot_fit(res, t, measured, simulate_kw=dict(rtol=rtol, atol=rtol * 1e-1))
            fig.savefig(figure, dpi=120)
    except ModelError as exc:
        _fail(str(exc))
    if json_out:
        typer.echo(_json.dumps({"params": dict(zip(res.names, map(float, res.values))), "stderr": dict(zip(res.names, map(float, res.stderr))), "rms": res.rms, "evaluations": res.iterations, "success": res.success}))
        return
    console().print(res.table().to_string(index=False))
    console().print(f"rms residual {res.rms:.4g} (weighted), {res.iterations} evaluations: {res.message}")


@identify_app.command("modal")
@_data_errors
def modal_cmd(
    force_file: Annotated[Path, typer.Argument(help="CSV/Parquet with the time and hammer-force columns, or a UFF "
                                                    "file (.uff/.unv, dataset 58: FRFs or time records).")],
    accel_file: Annotated[Path | None, typer.Argument(help="CSV/Parquet with the time and one column per "
                                                           "accelerometer (not with a UFF file).")] = None,
    time_col: Annotated[str, typer.Option("--time", help="Time column [s] in both files.")] = "time",
    force_col: Annotated[str | None, typer.Option("--force", help="Force column [N] (default: the first non-time column).")] = None,
    n_modes: Annotated[int | None, typer.Option("--n-modes", help="Keep the n most prominent peaks.")] = None,
    f_min: Annotated[float | None, typer.Option("--f-min", help="Lowest frequency searched [Hz].")] = None,
    f_max: Annotated[float | None, typer.Option("--f-max", help="Highest frequency searched [Hz].")] = None,
    estimator: Annotated[str, typer.Option("--estimator", help="FRF estimator: H1 (response noise), H2 (force noise) "
                                                              "or Hv.")] = "H1",
    json_out: Annotated[bool, typer.Option("--json", help="Print one JSON object.")] = False,
):
    """Experimental modal analysis of an impact-hammer test: FRFs averaged over the hits (pyFRF),
    natural frequencies and damping ratios from LSCF's stabilisation diagram, mode shapes by LSFD
    (pyEMA); one shape value per channel. A UFF file gives FRFs or time records directly."""
    import numpy as np

    from proleg.identify.data import check_signal, read_table
    from proleg.identify.hammer import modal, modal_from_frf

    f_range = None if f_min is None and f_max is None else (f_min or 0.5, f_max or 1e9)
    if force_file.suffix.lower() in (".uff", ".unv"):
        from proleg.identify.uff import read_uff

        if accel_file is not None:
            raise DataError(f"{force_file}: a UFF file holds every channel; give no second file ({accel_file}).")
        rec = read_uff(force_file)
        if rec.kind == "frf":
            acols = rec.channels
            res = modal_from_frf(rec.x, rec.data, n_modes=n_modes, f_range=f_range, source=str(force_file))
        else:
            t, F, A, acols = rec.force_and_accelerations()
            res = modal(t, F, A, n_modes=n_modes, f_range=f_range, estimator=estimator, source=str(force_file))
        _modal_print(res, acols, json_out)
        return
    if accel_file is None:
        raise DataError(f"{force_file}: give the accelerometer file too (or a UFF file with all channels).")
    fdf, adf = read_table(force_file), read_table(accel_file)
    for path, df in ((force_file, fdf), (accel_file, adf)):
        if time_col not in df.columns:
            raise DataError(f"{path}: no column '{time_col}' (columns: {list(df.columns)}); pass --time NAME.")
    fcols = [c for c in fdf.columns if c != time_col]
    force_col = force_col or (fcols[0] if fcols else None)
    if force_col not in fdf.columns:
        raise DataError(f"{force_file}: no force column '{force_col}' (columns: {list(fdf.columns)}); pass --force NAME.")
    acols = [c for c in adf.columns if c != time_col]
    if not acols:
        raise DataError(f"{accel_file}: no accelerometer column besides '{time_col}'.")
    t = check_signal(fdf[time_col], source=str(force_file), column=time_col)
    ta = check_signal(adf[time_col], source=str(accel_file), column=time_col)
    if ta.size != t.size:
        raise DataError(f"{accel_file}: column '{time_col}' has {ta.size} rows but {force_file} has {t.size}; "
                        "the force and acceleration records must have the same length.")
    if not np.allclose(ta, t, rtol=0, atol=1e-9 * max(1.0, abs(t).max())):
        raise DataError(f"{accel_file}: column '{time_col}' differs from {force_file}'s; record both on one clock.")
    F = check_signal(fdf[force_col], source=str(force_file), column=force_col)
    A = np.column_stack([check_signal(adf[c], source=str(accel_file), column=c) for c in acols])
    res = modal(t, F, A, n_modes=n_modes, f_range=f_range, estimator=estimator, source=f"{force_file} / {accel_file}")
    _modal_print(res, acols, json_out)


def _modal_print(res, acols, json_out):
    if json_out:
        _json_out({"frequencies_hz": res.frequencies.tolist(), "damping": res.damping.tolist(),
                   "shapes": {c: res.shapes[i].tolist() for i, c in enumerate(acols)}, "averages": res.n_averages,
                   "message": res.message})
        return
    if res.frequencies.size == 0:
        Console().print(res.message)
        return
    t_ = Table(title=f"modal identification ({res.n_averages} hits averaged, {res.estimator}, LSCF + LSFD)")
    for col in ["mode", "f [Hz]", "zeta [%]"] + acols:
        t_.add_column(col)
    for k in range(res.frequencies.size):
        t_.add_row(str(k + 1), _g(res.frequencies[k]), _g(100 * res.damping[k]), *[_g(v) for v in res.shapes[:, k]])
    console().print(t_)
