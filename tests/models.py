"""Small models shared by several test files (imported as ``from models import ...``, like
tolerances.py): one definition instead of a copy per file."""

from __future__ import annotations

import proleg as pl


def spring_pendulum(name: str = "spring_pendulum"):
    """A double pendulum (two 1 kg, 1 m links on revolutes about y) whose tip hangs on a
    50 N/m spring-damper to a ground anchor: cheap to compile, smooth, and its spring's
    ``stiffness`` and ``damping`` are parameters a study or sweep can vary. Returns the System."""
    m = pl.Model(name, gravity=(0, 0, -9.81))
    up = m.add_part("upper", mass=1.0, inertia=(0.01, 0.09, 0.09), position=(0.5, 0, 0))
    lo = m.add_part("lower", mass=1.0, inertia=(0.01, 0.09, 0.09), position=(1.5, 0, 0))
    m.add_joint(pl.Revolute("shoulder", m.ground, up, at=(0, 0, 0), axis=(0, 1, 0)))
    m.add_joint(pl.Revolute("elbow", up, lo, at=(1, 0, 0), axis=(0, 1, 0)))
    tip = m.add_marker(lo, "tip", position=(2, 0, 0))
    anchor = m.add_marker(m.ground, "anchor", position=(2, 0, -1))
    m.add_force(pl.SpringDamper("spring", tip, anchor, stiffness=50.0, damping=0.5, free_length=1.0))
    return pl.assemble(m)


def robot_path(rel):
    """A URDF or SRDF shipped by example-robot-data (its cmeel prefix), ``rel`` below its robots/
    folder; the test is skipped where the package is not installed."""
    import sys
    from pathlib import Path

    import pytest

    for base in sys.path:
        p = Path(base) / "cmeel.prefix" / "share" / "example-robot-data" / "robots" / rel
        if p.is_file():
            return p
    pytest.skip(f"example-robot-data is not installed (no {rel}): pip install -e .[test]")
