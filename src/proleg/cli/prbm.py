"""``proleg prbm``: dynamic pseudo-rigid-body model of a strip cantilever (seed 002).

Example::

    proleg prbm --length 300mm --width 50mm --thickness 3mm --material aisi304 \\
        --load 30N --deflection 11.8mm --damping-ratio 0.015 [--json]
"""

from __future__ import annotations

import json as _json
import math
import re
from typing import Annotated

import typer

from ..errors import ConvergenceError, ModelError
from ._out import error

_LENGTH = {"m": 1.0, "cm": 1e-2, "mm": 1e-3, "um": 1e-6, "in": 0.0254}
_FORCE = {"n": 1.0, "kn": 1e3, "mn": 1e-3, "lbf": 4.4482216152605}
_NUMBER = re.compile(r"^\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*([a-zA-Z]*)\s*$")


def parse_quantity(text: str, units: dict[str, float], what: str, default_unit: str) -> float:
    """Parse '300mm', '3 mm', '0.3m', '30N' into SI using ``units``; a bare number is in ``default_unit``."""
    m = _NUMBER.match(str(text))
    if not m:
        raise ModelError(f"Cannot read {what} '{text}': write a number with a unit, e.g. '300mm' "
                         f"(units: {', '.join(units)}).")
    unit = m.group(2).lower() or default_unit
    if unit not in units:
        raise ModelError(f"Unknown unit '{m.group(2)}' in {what} '{text}'; use one of {', '.join(units)}.")
    return float(m.group(1)) * units[unit]


def parse_length(text: str, what: str = "length") -> float:
    """A length with unit (m, cm, mm, um, in; bare numbers are m) -> m."""
    return parse_quantity(text, _LENGTH, what, "m")


def parse_force(text: str, what: str = "load") -> float:
    """A force with unit (N, kN, mN, lbf; bare numbers are N) -> N."""
    return parse_quantity(text, _FORCE, what, "n")


def prbm(
    length: Annotated[str, typer.Option("--length", help="Strip length L, e.g. 300mm")],
    width: Annotated[str, typer.Option("--width", help="Strip width W, e.g. 50mm")],
    thickness: Annotated[str, typer.Option("--thickness", help="Strip thickness t (bending direction), e.g. 3mm")],
    material: Annotated[
        str, typer.Option("--material", help="aisi304, al7075-t6, al6061-t6, structural_steel")
    ] = "aisi304",
    load: Annotated[str, typer.Option("--load", help="Transverse tip load P of the calibration, e.g. 30N")] = "30N",
    deflection: Annotated[
        str | None, typer.Option("--deflection", help="Tip deflection b under the load (default: exact elastica)")
    ] = None,
    damping_ratio: Annotated[float, typer.Option("--damping-ratio", help="Damping ratio xi of the PRB spring")] = 0.015,
    json: Annotated[bool, typer.Option("--json", help="Print one JSON object (SI units) instead of a table")] = False,
) -> None:
    """Dynamic PRB 1R model of a flexible strip: gamma, K_t, C_t, J, omega_1 (seed 002, Eqs. 1-11)."""
    from ..flex.prbm import dynamic_prbm

    try:
        link = dynamic_prbm(
            parse_length(length, "--length"), parse_length(width, "--width"), parse_length(thickness, "--thickness"),
            material, parse_force(load, "--load"),
            None if deflection is None else parse_length(deflection, "--deflection"), damping_ratio)
    except (ModelError, ConvergenceError) as exc:
        error(exc)
    data = link.as_dict()
    if json:
        typer.echo(_json.dumps(data))
        return
    from rich.table import Table

    from ._out import console

    r = math.pi / 180.0
    table = Table(title=f"PRB 1R model, {link.material.name} strip {link.length * 1e3:g} x {link.width * 1e3:g} x "
                        f"{link.thickness * 1e3:g} mm")
    table.add_column("quantity")
    table.add_column("SI", justify="right")
    table.add_column("seed-002 units", justify="right")
    table.add_row("gamma", f"{link.gamma:.5g}", "")
    table.add_row("K_t", f"{link.K_t:.6g} N m/rad", f"{link.K_t * 1e3 * r:.5g} N mm/deg")
    table.add_row("C_t", f"{link.C_t:.6g} N m s/rad", f"{link.C_t * 1e3 * r:.5g} N mm s/deg")
    table.add_row("J", f"{link.J:.6g} kg m^2", f"{link.J * 1e6:.5g} kg mm^2")
    table.add_row("omega_1", f"{link.omega_1:.6g} rad/s", f"{link.omega_1 / (2 * math.pi):.6g} Hz")
    table.add_row("K_Theta", f"{link.K_Theta:.5g}", "")
    table.add_row("c_theta", f"{link.c_theta:.5g}", "")
    table.add_row("pivot from clamp", f"{(1 - link.gamma) * link.length:.5g} m", "")
    console().print(table)


def register(app: typer.Typer) -> None:
    """Add ``prbm`` as a command of ``app``."""
    app.command("prbm")(prbm)
