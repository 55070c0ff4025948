"""The study store: a folder holding a Parquet dataset, one row per variant.

Layout::

    DIR/study.json            the study's definition and the software versions
    DIR/rows/part-*.parquet   one file per finished batch (the definition in its metadata)
    DIR/plans/*.json          the variant keys each run asked for (for ``status``: pending)
    DIR/optuna.db             optimisation trials (optuna's storage), when optimising

A batch file is written under a temporary name and renamed into place (``os.replace``, atomic
on POSIX), so a killed process leaves either the whole batch or none of it. A variant is
identified by its ``key``: a hash of its parameter values, so that a rerun of the same design
finds what is done whatever the order, the executor or the batch sizes.
"""

from __future__ import annotations

import hashlib
import json
import os
import uuid
from pathlib import Path

import numpy as np
import pandas as pd

from ..errors import ModelError

META_KEY = b"proleg.study"


def variant_key(values: dict) -> str:
    """16-hex-digit hash of a variant's parameter values ({name: number, string or array})."""
    canon = {k: (v if isinstance(v, str) else np.asarray(v, float).round(12).tolist()) for k, v in sorted(values.items())}
    return hashlib.sha1(json.dumps(canon, sort_keys=True).encode()).hexdigest()[:16]


def definition_diff(old, new, path="") -> list[str]:
    """Human-readable differences between two JSON-like definitions."""
    out = []
    if isinstance(old, dict) and isinstance(new, dict):
        for k in sorted(set(old) | set(new), key=str):
            p = f"{path}.{k}" if path else str(k)
            if k not in old:
                out.append(f"{p}: added ({_short(new[k])})")
            elif k not in new:
                out.append(f"{p}: removed (was {_short(old[k])})")
            else:
                out += definition_diff(old[k], new[k], p)
    elif old != new:
        out.append(f"{path}: stored {_short(old)}, now {_short(new)}")
    return out


def _short(v, n=80):
    s = json.dumps(v, default=str)
    return s if len(s) <= n else s[: n - 3] + "..."


def versions() -> dict:
    """Versions of proleg and the libraries a study result depends on."""
    import platform
    from importlib import metadata

    out = {"python": platform.python_version()}
    for pkg in ("proleg", "jax", "jaxlib", "numpy", "scipy", "pandas", "pyarrow", "optuna", "SALib", "distributed"):
        try:
            out[pkg] = metadata.version(pkg)
        except metadata.PackageNotFoundError:
            pass
    return out


class Store:
    """A study's Parquet dataset in folder ``path`` (created on first use)."""

    def __init__(self, path):
        self.path = Path(path)
        self.rows_dir = self.path / "rows"

    # -- definition ------------------------------------------------------------------------
    def definition(self) -> dict | None:
        f = self.path / "study.json"
        return json.loads(f.read_text())["definition"] if f.exists() else None

    def open(self, definition: dict) -> Store:
        """Create the store for ``definition``, or check that it holds the same study: a
        different one is refused with the differences named (use a new folder for it)."""
        definition = json.loads(json.dumps(definition, default=str))
        old = self.definition()
        if old is not None:
            diff = definition_diff(old, definition)
            if diff:
                raise ModelError(
                    f"Study store '{self.path}' holds a different study: " + "; ".join(diff[:8])
                    + (f" (and {len(diff) - 8} more)" if len(diff) > 8 else "")
                    + ". Use a new store folder for the changed study, or restore the definition to resume."
                )
        else:
            self.rows_dir.mkdir(parents=True, exist_ok=True)
            _atomic_write(self.path / "study.json", json.dumps({"definition": definition, "versions": versions()}, indent=1).encode())
        self.rows_dir.mkdir(parents=True, exist_ok=True)
        for tmp in self.rows_dir.glob(".tmp-*"):  # left by a process killed mid-write
            tmp.unlink(missing_ok=True)
        return self

    # -- rows ------------------------------------------------------------------------------
    def write(self, rows: list[dict]) -> Path | None:
        """Append one batch of rows (atomically: the file appears whole or not at all)."""
        if not rows:
            return None
        import pyarrow as pa
        import pyarrow.parquet as pq

        df = pd.DataFrame(rows)
        table = pa.Table.from_pandas(df, preserve_index=False)
        meta = dict(table.schema.metadata or {})
        meta[META_KEY] = (self.path / "study.json").read_bytes() if (self.path / "study.json").exists() else b"{}"
        table = table.replace_schema_metadata(meta)
        name = f"part-{pd.Timestamp.now('UTC').strftime('%Y%m%dT%H%M%S%f')}-{uuid.uuid4().hex[:8]}.parquet"
        tmp = self.rows_dir / f".tmp-{name}"
        pq.write_table(table, tmp)
        with open(tmp, "rb") as fh:
            os.fsync(fh.fileno())
        os.replace(tmp, self.rows_dir / name)
        return self.rows_dir / name

    def read(self) -> pd.DataFrame:
        """Every stored row (all batches), in the order written."""
        files = sorted(self.rows_dir.glob("part-*.parquet")) if self.rows_dir.exists() else []
        if not files:
            return pd.DataFrame()
        return pd.concat([pd.read_parquet(f) for f in files], ignore_index=True)

    def done_keys(self) -> set:
        df = self.read()
        return set(df["key"]) if len(df) else set()

    # -- plans and status ------------------------------------------------------------------
    def add_plan(self, keys: list[str], label: str) -> None:
        d = self.path / "plans"
        d.mkdir(parents=True, exist_ok=True)
        h = hashlib.sha1("".join(keys).encode()).hexdigest()[:12]
        _atomic_write(d / f"{h}.json", json.dumps({"label": label, "keys": keys}).encode())

    def status(self) -> dict:
        """{"rows", "done", "failed", "pending", "duplicates", "by_status"} of the store."""
        df = self.read()
        planned = set()
        for f in sorted((self.path / "plans").glob("*.json")) if (self.path / "plans").exists() else []:
            planned |= set(json.loads(f.read_text())["keys"])
        keys = set(df["key"]) if len(df) else set()
        by = df["status"].value_counts().to_dict() if len(df) else {}
        return {
            "rows": len(df),
            "done": int(by.get("success", 0)),
            "failed": int(len(df) - by.get("success", 0)),
            "pending": len(planned - keys),
            "duplicates": int(len(df) - len(keys)),
            "by_status": {str(k): int(v) for k, v in by.items()},
        }


def _atomic_write(path: Path, data: bytes) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".tmp-{uuid.uuid4().hex[:8]}-{path.name}")
    tmp.write_bytes(data)
    os.replace(tmp, path)
