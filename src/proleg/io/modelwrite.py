"""Writing YAML model files: :func:`model_to_dict` and :func:`dump_model`.

The inverse of the reader in :mod:`proleg.io.modelfile` (which re-exports both): a
:class:`~proleg.model.model.Model` becomes the dict of a model file (the schema of
:mod:`proleg.io.modelspec`) and then flow-style YAML, SI units, floats written so that a load
gives back the same numbers.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import yaml

from ..errors import ModelError
from ..model import forces as _f
from ..model import joints as _j
from ..model.model import Model
from ..model.parts import Part
from .modelspec import SECTIONS, SimulateSpec

__all__ = ["model_to_dict", "dump_model"]


# ------------------------------------------------------------------------------------------
# Writing
# ------------------------------------------------------------------------------------------
def _vec(a) -> list:
    return np.asarray(a, dtype=float).tolist()


def _clean(a) -> list:
    """A derived pose (marker stored relative to its part) with round-off noise dropped (15 digits)."""
    return [float(f"{x:.15g}") for x in np.ravel(a)] if np.ndim(a) == 1 else [_clean(r) for r in a]


def _is_identity(R) -> bool:
    return bool(np.allclose(R, np.eye(3), rtol=0, atol=1e-12))


def _six_out(M):
    M = np.asarray(M, dtype=float)
    return _vec(np.diag(M)) if np.array_equal(M, np.diag(np.diag(M))) else _vec(M)


def _end_name(obj) -> str:
    return obj.name  # Part or Marker, both named; ground is "ground"


def model_to_dict(model: Model, simulate: dict | None = None) -> dict:
    """The model-file dict of ``model`` (the inverse of :func:`model_from_dict`).

    Markers created by joints and forces are left out (they are re-created on load); joint
    ends keep the form they were given in (parts with ``at``/``axis``, or markers).
    """
    for what in ("contacts", "motions", "controllers"):
        if getattr(model, what, None):
            raise ModelError(f"Model '{model.name}' has {what}; the model-file format does not cover them yet.")
    auto: set[int] = set()
    for jt in model.joints:
        if isinstance(jt.i_in, Part):
            auto.add(id(jt.marker_i))
        if isinstance(jt.j_in, Part):
            auto.add(id(jt.marker_j))
    for fe in model.forces:
        if isinstance(fe, _f.Force | _f.Torque) and fe.marker_in is None and fe.marker is not None:
            auto.add(id(fe.marker))

    out: dict[str, Any] = {"name": model.name, "gravity": _vec(model.gravity), "units": "SI"}
    parts = []
    for p in model.parts:
        J = np.asarray(p.inertia)
        d = {
            "name": p.name,
            "mass": float(p.mass),
            "inertia": _vec(np.diag(J)) if np.array_equal(J, np.diag(np.diag(J))) else _vec(J),
            "position": _vec(p.position),
        }
        if not _is_identity(p.orientation):
            d["orientation"] = _vec(p.orientation)
        if np.any(p.velocity):
            d["velocity"] = _vec(p.velocity)
        if np.any(p.angular_velocity):
            d["angular_velocity"] = _vec(p.angular_velocity)
        parts.append(d)
    markers = []
    for m in model.markers:
        if id(m) in auto:
            continue
        d = {"name": m.name, "part": m.part.name, "position": _clean(m.position)}
        if not _is_identity(m.orientation):
            d["orientation"] = _clean(m.orientation)
        markers.append(d)
    joints = []
    for jt in model.joints:
        d = {"type": jt.kind, "name": jt.name, "i": _end_name(jt.i_in), "j": _end_name(jt.j_in)}
        if jt.at is not None:
            d["at"] = _vec(jt.at)
        if isinstance(jt, _j.Universal):
            for k in ("axis_i", "axis_j"):
                if getattr(jt, k, None) is not None:
                    d[k] = _vec(getattr(jt, k))
        elif jt.axis is not None:
            d["axis"] = _vec(jt.axis)
        if isinstance(jt, _j.Screw):
            d["pitch"] = float(jt.pitch)
        joints.append(d)
    forces = [_force_to_dict(fe) for fe in model.forces]
    out.update(parts=parts, markers=markers, joints=joints, forces=forces)
    if getattr(model, "couplers", None):
        out["couplers"] = [
            {"name": c.name, "joint_1": c.joint_1.name, "joint_2": c.joint_2.name, "ratio": float(c.ratio), "dof": c.dof}
            for c in model.couplers
        ]
    if simulate:
        out["simulate"] = SimulateSpec.model_validate(simulate).model_dump(exclude_none=True)
    return out


def _force_to_dict(fe) -> dict:
    d: dict[str, Any] = {"type": fe.kind, "name": fe.name}
    if isinstance(fe, _f.SpringDamper):
        d.update(i=fe.i.name, j=fe.j.name, stiffness=fe.stiffness, damping=fe.damping, free_length=fe.free_length)
        if fe.preload:
            d["preload"] = fe.preload
    elif isinstance(fe, _f.RotationalSpringDamper):
        if fe.joint is not None:
            d["joint"] = fe.joint if isinstance(fe.joint, str) else fe.joint.name
        else:
            d.update(i=fe.i.name, j=fe.j.name)
        d.update(stiffness=fe.stiffness, damping=fe.damping, free_angle=fe.free_angle)
        if fe.preload:
            d["preload"] = fe.preload
    elif isinstance(fe, _f.Bushing):
        d.update(i=fe.i.name, j=fe.j.name, stiffness=_six_out(fe.stiffness))
        if np.any(fe.damping):
            d["damping"] = _six_out(fe.damping)
        if np.any(fe.preload):
            d["preload"] = _vec(fe.preload)
        if np.any(fe.free):
            d["free"] = _vec(fe.free)
    elif isinstance(fe, _f.Force | _f.Torque):
        if fe.fn is not None:
            raise ModelError(
                f"{type(fe).__name__} '{fe.name}' has a function value; a model file holds only constant "
                "values. Give value=(x, y, z), or keep this element in Python."
            )
        d["part"] = fe.marker_in.name if fe.marker_in is not None else fe.part.name
        d["value"] = _vec(fe.value)
        if fe.at is not None:
            d["at"] = _vec(fe.at)
    elif fe.kind == "joint_stop":
        d.update(joint=fe.joint.name, stiffness=fe.stiffness, exponent=fe.exponent, damping=fe.damping, penetration=fe.penetration)
        d.update({k: float(getattr(fe, k)) for k in ("lower", "upper") if np.isfinite(getattr(fe, k))})
    elif fe.kind == "joint_friction":
        d.update(joint=fe.joint.name, friction=fe.friction, damping=fe.damping, slip_rate=fe.slip_rate)
    else:
        raise ModelError(f"Force element {fe!r} ({type(fe).__name__}) cannot be written to a model file yet.")
    return {k: (float(v) if isinstance(v, float | np.floating) else v) for k, v in d.items()}


class _Flow(list):
    pass


class _FlowMap(dict):
    pass


class _Dumper(yaml.SafeDumper):
    pass


_Dumper.add_representer(_Flow, lambda dumper, data: dumper.represent_sequence("tag:yaml.org,2002:seq", data, flow_style=True))
_Dumper.add_representer(
    _FlowMap, lambda dumper, data: dumper.represent_mapping("tag:yaml.org,2002:map", data.items(), flow_style=True)
)


def _flowify(obj):
    if isinstance(obj, list):
        return _Flow(_flowify(x) for x in obj)
    if isinstance(obj, dict):
        return _FlowMap({k: _flowify(v) for k, v in obj.items()})
    return obj


def dump_model(model: Model, path, simulate: dict | None = None) -> Path:
    """Write ``model`` (and optional ``simulate`` CLI defaults) to a YAML model file; return the path.

    Floats are written with ``repr`` so a load gives back the same numbers (marker poses to
    round-off, as they are stored relative to their part).
    """
    d = model_to_dict(model, simulate)
    doc: dict[str, Any] = {}
    for k, v in d.items():
        if k in SECTIONS:
            doc[k] = [_flowify(item) for item in v]
        elif isinstance(v, list | dict):
            doc[k] = _flowify(v)
        else:
            doc[k] = v
    text = yaml.dump(doc, Dumper=_Dumper, sort_keys=False, width=10_000, allow_unicode=True)
    path = Path(path)
    path.write_text(f"# proleg model file, SI units (m, kg, s, N, rad); written by proleg.io.dump_model\n{text}", encoding="utf-8")
    return path
