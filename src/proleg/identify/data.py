"""Reading and validating experiment files for identification (CSV or Parquet).

A measurement file is a table with one row per sample. :func:`load_record` picks the columns
that play a *role* (``force``, ``stroke``, ``time``, ...), converts them to SI with a unit per
role, checks them and returns a :class:`Record`. Everything that makes a file unusable raises a
:class:`~proleg.errors.DataError` that names the file, the column and the row. Rows are counted
as **1-based data rows** (the header is not counted; in a CSV file data row ``n`` is on line
``n + 1``).

Units
-----
A unit is a name from :mod:`proleg.units` (``mm``, ``ms``, ``kN``, ``bar``, ``deg``, ...) or one
of ``m s N Pa rad V A Ohm 1``. Give them per role, ``parse_units("force=N,stroke=mm,time=ms")``.
A role without an explicit unit takes it from the column-name suffix when that suffix is a known
unit (``time_ms`` -> ms, ``position_mm`` -> mm, ``force_N`` -> N); otherwise SI is assumed.

Runs
----
One file may hold several runs (repetitions). Samples are split into runs by a run-id column
(``run_col``), else by the clock: a run ends where the time stamp jumps back to (near) the start
of the current run (the logger was restarted) or where it jumps forward by more than
``gap_factor`` times the median sample interval. Inside a run the time must increase strictly.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from .. import units as _u
from ..errors import DataError

__all__ = [
    "UNITS",
    "Record",
    "check_signal",
    "load_record",
    "parse_mapping",
    "parse_units",
    "read_table",
    "split_runs",
    "unit_factor",
]

#: Unit name -> factor to SI (multiply a value in the unit by the factor to get SI).
UNITS: dict[str, float] = {
    "1": 1.0, "m": _u.m, "mm": _u.mm, "cm": _u.cm, "km": _u.km, "um": 1e-6,
    "s": _u.s, "ms": _u.ms, "us": 1e-6, "min": 60.0, "h": 3600.0,
    "N": _u.N, "kN": _u.kN, "mN": 1e-3, "kg": _u.kg, "g": _u.g,
    "Pa": _u.Pa, "kPa": _u.kPa, "MPa": _u.MPa, "bar": _u.bar,
    "rad": _u.rad, "deg": _u.deg, "Nm": _u.Nm, "Nmm": _u.Nmm,
    "V": 1.0, "mV": 1e-3, "A": 1.0, "mA": 1e-3, "Ohm": 1.0,
    "m/s": 1.0, "mm/s": 1e-3, "rad/s": 1.0, "deg/s": _u.deg,
}


def unit_factor(unit: str, *, what: str = "unit") -> float:
    """Factor that converts a value in ``unit`` to SI; DataError for an unknown unit name."""
    try:
        return UNITS[unit]
    except KeyError:
        raise DataError(
            f"{what}: unknown unit {unit!r}. Known units: {', '.join(UNITS)}."
        ) from None


def parse_mapping(spec: str | None, *, what: str = "mapping") -> dict[str, str]:
    """Parse ``"a=b,c=d"`` into ``{"a": "b", "c": "d"}`` (whitespace around items is ignored)."""
    out: dict[str, str] = {}
    if not spec:
        return out
    for item in spec.split(","):
        item = item.strip()
        if not item:
            continue
        key, sep, value = item.partition("=")
        if not sep or not key.strip() or not value.strip():
            raise DataError(f"{what}: cannot read {item!r}; write KEY=VALUE pairs separated by commas, "
                            "e.g. 'force=N,stroke=mm,time=ms'.")
        out[key.strip()] = value.strip()
    return out


def parse_units(spec: str | None) -> dict[str, str]:
    """Parse a unit spec ``"force=N,stroke=mm,time=ms"`` into ``{role: unit}``, checking each unit."""
    units = parse_mapping(spec, what="--units")
    for role, unit in units.items():
        unit_factor(unit, what=f"--units {role}")
    return units


def _suffix_unit(column: str) -> str | None:
    """Unit named by a column suffix (``position_mm`` -> ``mm``), or None."""
    if "_" not in column:
        return None
    suffix = column.rsplit("_", 1)[1]
    return suffix if suffix in UNITS and suffix != "1" else None


def read_table(path: str | Path) -> pd.DataFrame:
    """Read a CSV (``.csv``, ``.txt``) or Parquet (``.parquet``, ``.pq``) file into a DataFrame.

    Raises
    ------
    DataError
        The file does not exist, has an unsupported suffix, cannot be parsed or has no rows.
    """
    path = Path(path)
    if not path.is_file():
        raise DataError(f"{path}: file not found.")
    suffix = path.suffix.lower()
    try:
        if suffix in (".parquet", ".pq"):
            frame = pd.read_parquet(path)
        elif suffix in (".csv", ".txt", ".dat"):
            frame = pd.read_csv(path, skipinitialspace=True)
        else:
            raise DataError(f"{path}: unsupported file type {suffix!r}; use .csv or .parquet.")
    except DataError:
        raise
    except Exception as exc:  # pandas/pyarrow raise many types; report them as a data problem
        raise DataError(f"{path}: cannot be read as a table ({type(exc).__name__}: {exc}).") from exc
    if len(frame) == 0:
        raise DataError(f"{path}: the file has a header but no data rows.")
    return frame


def check_signal(values, *, source: str, column: str, rows=None, allow_constant: bool = False) -> np.ndarray:
    """Return ``values`` as a finite float array, or raise DataError naming source, column and row.

    Parameters
    ----------
    values : array-like (n,)
        The samples; strings that are not numbers are reported with their row.
    source : str
        The file name (or a label for in-memory arrays) for messages.
    column : str
        The column name for messages.
    rows : (n,) int, optional
        1-based data-row number of each sample; default ``1..n``.
    allow_constant : bool
        If False (default) a signal with a single value throughout raises.
    """
    raw = pd.Series(np.asarray(values).ravel() if not isinstance(values, pd.Series) else values.to_numpy())
    rows = np.arange(1, len(raw) + 1) if rows is None else np.asarray(rows)
    num = pd.to_numeric(raw, errors="coerce")
    bad_text = num.isna().to_numpy() & raw.notna().to_numpy()
    if bad_text.any():
        i = int(np.argmax(bad_text))
        raise DataError(f"{source}: column '{column}' is not numeric at data row {rows[i]} "
                        f"(1-based, header not counted): value {raw.iloc[i]!r}. Fix or remove that row.")
    arr = num.to_numpy(dtype=float)
    bad = ~np.isfinite(arr)
    if bad.any():
        i = int(np.argmax(bad))
        what = "is empty (NaN)" if np.isnan(arr[i]) else f"is {arr[i]}"
        raise DataError(f"{source}: column '{column}' {what} at data row {rows[i]} "
                        "(1-based, header not counted). Fill or remove that row.")
    if not allow_constant and arr.size and np.ptp(arr) == 0.0:
        raise DataError(f"{source}: column '{column}' is constant ({arr[0]:g}) over data rows "
                        f"{rows[0]}-{rows[-1]}; it carries no information. Check the column mapping.")
    return arr


def split_runs(t: np.ndarray, *, run=None, rows=None, source: str = "data", column: str = "time",
               gap_factor: float = 50.0) -> np.ndarray:
    """Label each sample with a run number 0, 1, ... and check that time increases inside each run.

    Parameters
    ----------
    t : (n,) float [s]
        Time stamps.
    run : (n,) array, optional
        Run identifiers (any hashable values); runs are numbered in order of first appearance and
        must be contiguous blocks.
    gap_factor : float
        Without ``run``, a forward jump larger than ``gap_factor`` times the median sample interval
        starts a new run. Default 50 (0.5 s at 100 Hz): the friction files have logger hiccups of up
        to 0.27 s inside one record, which must not split it.

    Raises
    ------
    DataError
        Duplicate or decreasing time stamps inside a run (with the data row), a run column whose
        runs are interleaved.
    """
    t = np.asarray(t, dtype=float)
    n = t.size
    rows = np.arange(1, n + 1) if rows is None else np.asarray(rows)
    labels = np.zeros(n, dtype=int)
    if run is not None:
        codes, uniques = pd.factorize(pd.Series(np.asarray(run)), sort=False)
        seen: set[int] = set()
        for i, code in enumerate(codes):
            if i and code == codes[i - 1]:
                continue
            if code in seen:
                break
            seen.add(int(code))
        else:
            i = -1
        if i >= 0:
            raise DataError(f"{source}: the runs in the run column are not contiguous blocks: run "
                            f"{uniques[codes[i]]!r} appears again at data row {rows[i]} (1-based). "
                            "Sort the file by run, then time.")
        labels = codes.astype(int)
    else:
        if n >= 2:
            dt = np.diff(t)
            pos = dt[dt > 0]
            med = float(np.median(pos)) if pos.size else 0.0
            start = 0
            run_id = 0
            for i in range(1, n):
                d = t[i] - t[i - 1]
                restart = d < 0 and (t[i] - t[start]) <= 0.05 * (t[i - 1] - t[start]) + med
                jump = med > 0 and d > gap_factor * med
                if restart or jump:
                    run_id += 1
                    start = i
                labels[i] = run_id
    for r in np.unique(labels):
        idx = np.flatnonzero(labels == r)
        d = np.diff(t[idx])
        bad = np.flatnonzero(d <= 0)
        if bad.size:
            j = idx[bad[0] + 1]
            kind = "repeats" if d[bad[0]] == 0 else "goes backwards"
            raise DataError(f"{source}: column '{column}' {kind} at data row {rows[j]} (1-based, header "
                            f"not counted): {t[j - 1]:.9g} s then {t[j]:.9g} s. Time must increase "
                            "strictly within a run; sort the file, drop duplicate rows, or give a run column.")
    return labels


@dataclass(frozen=True)
class Record:
    """Validated signals of one experiment file, in SI units.

    Attributes
    ----------
    source : str
        File name, for messages.
    columns : dict role -> column name in the file.
    units : dict role -> unit the column was read in.
    data : dict role -> (n,) float array in SI.
    rows : (n,) int
        1-based data row of each sample in the file.
    run : (n,) int
        Run number of each sample (0, 1, ...).
    """

    source: str
    columns: dict[str, str]
    units: dict[str, str]
    data: dict[str, np.ndarray]
    rows: np.ndarray
    run: np.ndarray = field(repr=False)

    def __getitem__(self, role: str) -> np.ndarray:
        return self.data[role]

    def __len__(self) -> int:
        return int(self.rows.size)

    @property
    def nruns(self) -> int:
        return int(self.run.max()) + 1 if self.run.size else 0

    def runs(self) -> list[Record]:
        """The runs as separate records (same columns and units)."""
        out = []
        for r in range(self.nruns):
            m = self.run == r
            out.append(Record(self.source, self.columns, self.units,
                              {k: v[m] for k, v in self.data.items()}, self.rows[m], self.run[m]))
        return out

    def describe_rows(self) -> str:
        """'data rows a-b' for messages."""
        return f"data rows {self.rows[0]}-{self.rows[-1]}"


def load_record(path: str | Path, columns: Mapping[str, str | None], *, units: Mapping[str, str] | None = None,
                time: str | None = "time", run_col: str | None = None, gap_factor: float = 50.0,
                allow_constant: tuple[str, ...] = ()) -> Record:
    """Read a file and return the columns that play the given roles as a validated :class:`Record`.

    Parameters
    ----------
    path : str or Path
        CSV or Parquet file.
    columns : mapping role -> column name
        E.g. ``{"force": "force_N", "stroke": "position_mm", "time": "time_ms"}``. Roles mapped to
        None are skipped.
    units : mapping role -> unit name, optional
        Unit each role's column is stored in; missing roles take the column-name suffix or SI.
    time : str or None
        The role holding time stamps (checked for order, used to split runs); None if there is none.
    run_col : str, optional
        Column holding a run identifier.
    allow_constant : tuple of str
        Roles that may be constant (e.g. a pressure that is held).

    Raises
    ------
    DataError
        Missing column (the available columns are listed), non-numeric value, NaN, constant
        signal, unsorted or duplicate time stamps — each with the file, the column and the row.
    """
    source = str(path)
    frame = read_table(path)
    units = dict(units or {})
    cols = {role: col for role, col in columns.items() if col is not None}
    unknown = set(units) - set(cols)
    if unknown:
        raise DataError(f"{source}: --units names {sorted(unknown)}, which are not among the roles "
                        f"{sorted(cols)}.")
    for role, col in cols.items():
        if col not in frame.columns:
            raise DataError(f"{source}: column '{col}' (for {role}) not found. Available columns: "
                            f"{', '.join(map(str, frame.columns))}.")
    if run_col is not None and run_col not in frame.columns:
        raise DataError(f"{source}: run column '{run_col}' not found. Available columns: "
                        f"{', '.join(map(str, frame.columns))}.")
    rows = np.arange(1, len(frame) + 1)
    data: dict[str, np.ndarray] = {}
    used_units: dict[str, str] = {}
    for role, col in cols.items():
        unit = units.get(role) or _suffix_unit(col) or ("s" if role == time else "SI")
        factor = 1.0 if unit == "SI" else unit_factor(unit, what=f"{source}: unit of column '{col}'")
        arr = check_signal(frame[col], source=source, column=col, rows=rows,
                           allow_constant=role in allow_constant or role == time)
        data[role] = arr * factor
        used_units[role] = unit
    if time is not None and time in data:
        run = frame[run_col].to_numpy() if run_col is not None else None
        if run is not None and pd.isna(run).any():
            i = int(np.flatnonzero(pd.isna(run))[0])
            raise DataError(f"{source}: run column '{run_col}' is empty at data row {rows[i]} (1-based).")
        labels = split_runs(data[time], run=run, rows=rows, source=source, column=cols[time],
                            gap_factor=gap_factor)
    else:
        labels = np.zeros(len(frame), dtype=int)
    return Record(source, cols, used_units, data, rows, labels)
