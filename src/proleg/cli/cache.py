"""``proleg cache info | clear``: inspect and empty proleg's compile cache (``PROLEG_CACHE_DIR``)."""

from __future__ import annotations

import json

import typer
from rich.console import Console
from rich.table import Table

cache_app = typer.Typer(add_completion=False, no_args_is_help=True,
                        help="The compile cache: traced functions, XLA executables and trails kept across processes.")


def _store():
    from proleg.cache_store import get
    from proleg.compile_cache import cache_dir

    path = cache_dir()
    if path is None:
        Console(stderr=True).print("The compile cache is off (PROLEG_CACHE_DIR is empty).")
        raise typer.Exit(0)
    return get(path)


def _mb(n: int) -> str:
    return f"{n / 2**20:.1f} MiB" if n >= 2**20 else f"{n / 1024:.1f} KiB"


@cache_app.command("info")
def info(json_out: bool = typer.Option(False, "--json", help="One JSON object on stdout."),
         verify: bool = typer.Option(False, "--verify", help="Also check every entry's checksum (reads them all).")):
    """Folder, entries by kind (export: traced functions; xla: executables; trail: prefetch lists;
    tmp: writes in progress; legacy: older formats), total size and the cap (PROLEG_CACHE_MAX_BYTES)."""
    from proleg.cache_store import verify_file

    st = _store()
    data = st.info()
    if verify:
        data["invalid"] = {p: r for _m, _s, p, k in st.files() if k in ("export", "xla", "trail") and (r := verify_file(p))}
    if json_out:
        typer.echo(json.dumps(data))
        return
    table = Table(title=f"proleg cache: {data['dir']}" + ("" if data["exists"] else " (not created yet)"))
    for col in ("kind", "entries", "size"):
        table.add_column(col, justify="left" if col == "kind" else "right")
    for kind, v in data["kinds"].items():
        table.add_row(kind, str(v["entries"]), _mb(v["bytes"]))
    table.add_row("total", str(sum(v["entries"] for v in data["kinds"].values())),
                  f"{_mb(data['total_bytes'])} of {_mb(data['max_bytes'])} cap")
    Console().print(table)
    if verify:
        for p, r in data["invalid"].items():
            typer.echo(f"invalid: {p}: {r}")
        typer.echo(f"{len(data['invalid'])} invalid entries (a run deletes and rebuilds them)")


@cache_app.command("clear")
def clear():
    """Delete every cache file (the next run of each model compiles again); files in the folder
    that are not the cache's are left."""
    st = _store()
    before = st.info()["total_bytes"]
    n = st.clear()
    typer.echo(f"removed {n} files ({_mb(before)}) from {st.root}")


def register(app: typer.Typer) -> None:
    """Add ``cache`` (info, clear) to ``app``."""
    app.add_typer(cache_app, name="cache")
