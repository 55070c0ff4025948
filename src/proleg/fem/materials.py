"""Isotropic linear-elastic materials with their sources.

Values are SI (Pa, kg/m^3). They are nominal handbook values: use a measured modulus or density
when you have one (``Material(...)`` or ``dataclasses.replace(material("aisi304"), E=193e9)``).

Sources
-------
- AISI 304 (EN 1.4301): E = 200 GPa and rho = 7800 kg/m^3 reproduce the FLEGX worked example
  of seed 002 (omega_1 = 171.3194 rad/s for the 300 x 50 x 3 mm strip, see
  ``proleg.flex.prbm``); nu = 0.29 and yield 215 MPa are the annealed-sheet values of the
  ASM/MatWeb data sheet; ultimate strength 510-530 MPa is the range quoted in seed 002 (we store
  the lower bound, 510 MPa, the conservative choice for a von Mises check).
- Al 7075-T6 ("Ergal"): ASM Aerospace Specification Metals data sheet: E = 71.7 GPa,
  nu = 0.33, rho = 2810 kg/m^3, yield 503 MPa, ultimate 572 MPa.
- Al 6061-T6: ASM data sheet: E = 68.9 GPa, nu = 0.33, rho = 2700 kg/m^3, yield 276 MPa,
  ultimate 310 MPa.
- Structural steel (S235/ASTM A36 class, EN 1993-1-1 §3.2.6 elastic constants): E = 210 GPa,
  nu = 0.30, rho = 7850 kg/m^3, yield 235 MPa, ultimate 360 MPa.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..errors import ModelError


@dataclass(frozen=True)
class Material:
    """Isotropic linear-elastic material.

    Parameters
    ----------
    name : str
    E : float [Pa]                  Young's modulus, > 0
    nu : float [-]                  Poisson's ratio, in (-1, 0.5)
    rho : float [kg/m^3]            density, > 0
    yield_strength : float [Pa]     0.2 % offset yield strength (nan if unknown)
    ultimate_strength : float [Pa]  ultimate tensile strength (nan if unknown)
    source : str                    where the numbers come from
    """

    name: str
    E: float
    nu: float
    rho: float
    yield_strength: float = math.nan
    ultimate_strength: float = math.nan
    source: str = ""

    def __post_init__(self):
        for field, value, ok, hint in (
            ("E", self.E, lambda v: v > 0, "a positive Young's modulus in Pa (e.g. 200e9)"),
            ("rho", self.rho, lambda v: v > 0, "a positive density in kg/m^3 (e.g. 7800)"),
            ("nu", self.nu, lambda v: -1.0 < v < 0.5, "a Poisson's ratio in (-1, 0.5) (e.g. 0.3)"),
        ):
            try:
                v = float(value)
            except (TypeError, ValueError):
                v = math.nan
            if not (math.isfinite(v) and ok(v)):
                raise ModelError(f"Material '{self.name}' {field} = {value!r} is invalid; give {hint}.")

    @property
    def G(self) -> float:
        """Shear modulus E / (2 (1 + nu)) [Pa]."""
        return self.E / (2.0 * (1.0 + self.nu))

    @property
    def lame(self) -> tuple[float, float]:
        """Lamé parameters (lambda, mu) [Pa] for 3D isotropic elasticity."""
        lam = self.E * self.nu / ((1.0 + self.nu) * (1.0 - 2.0 * self.nu))
        return lam, self.G


_LIBRARY = {
    "aisi304": Material(
        "aisi304", 200e9, 0.29, 7800.0, 215e6, 510e6,
        "AISI 304 / EN 1.4301 spring-steel strip; E, rho reproduce seed 002; nu, yield: ASM/MatWeb; "
        "ultimate 510-530 MPa (seed 002), lower bound stored",
    ),
    "al7075-t6": Material(
        "al7075-t6", 71.7e9, 0.33, 2810.0, 503e6, 572e6, "Al 7075-T6 'Ergal', ASM Aerospace Specification Metals"
    ),
    "al6061-t6": Material(
        "al6061-t6", 68.9e9, 0.33, 2700.0, 276e6, 310e6, "Al 6061-T6, ASM Aerospace Specification Metals"
    ),
    "structural_steel": Material(
        "structural_steel", 210e9, 0.30, 7850.0, 235e6, 360e6, "S235 structural steel, EN 1993-1-1 §3.2.6"
    ),
}
_ALIASES = {
    "aisi_304": "aisi304",
    "ss304": "aisi304",
    "1.4301": "aisi304",
    "ergal": "al7075-t6",
    "al7075": "al7075-t6",
    "7075-t6": "al7075-t6",
    "al6061": "al6061-t6",
    "6061-t6": "al6061-t6",
    "steel": "structural_steel",
    "s235": "structural_steel",
}


def material_names() -> list[str]:
    """Names accepted by :func:`material` (canonical names first, then aliases)."""
    return sorted(_LIBRARY) + sorted(_ALIASES)


def material(name: str | Material) -> Material:
    """Look a material up by name (case-insensitive; ``-``, ``_`` and spaces are interchangeable).

    A :class:`Material` passes through unchanged.

    >>> material("Ergal").E
    71700000000.0
    """
    if isinstance(name, Material):
        return name
    if not isinstance(name, str):
        raise ModelError(f"material(): expected a name or a Material, got {name!r}.")
    key = name.strip().lower().replace(" ", "_")
    for cand in (key, key.replace("_", "-"), key.replace("-", "_")):
        cand = _ALIASES.get(cand, cand)
        if cand in _LIBRARY:
            return _LIBRARY[cand]
    raise ModelError(
        f"Unknown material '{name}'. Valid names: {', '.join(material_names())}. "
        "Or build one with proleg.fem.Material(name, E, nu, rho, yield_strength, ultimate_strength)."
    )
