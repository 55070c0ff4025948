"""Model files: a YAML description of a :class:`~proleg.model.model.Model`, validated with pydantic.

The file uses the Python API's vocabulary: every key is the keyword argument of the matching
builder (``Model.add_part``, ``Model.add_marker``, the joint and force-element classes), all
values are SI (m, kg, s, N, rad), and vectors are in ground coordinates at the modelled pose.

.. code-block:: yaml

    name: double_pendulum
    gravity: [0, 0, -9.81]              # [m/s^2]
    units: SI                           # optional; only SI for now
    parts:                              # Model.add_part
      - {name: upper, mass: 1.0, inertia: [0.01, 0.09, 0.09], position: [0.5, 0, 0]}
    markers:                            # Model.add_marker (part, ground-frame position/orientation)
      - {name: tip, part: upper, position: [1, 0, 0]}
    joints:                             # i, j: parts with at/axis, or markers without at
      - {type: revolute, name: shoulder, i: ground, j: upper, at: [0, 0, 0], axis: [0, 1, 0]}
    forces:
      - {type: spring_damper, name: spring, i: tip, j: anchor, stiffness: 50.0, free_length: 1.0}
    simulate: {t_end: 2.0, dt_output: 0.001}   # optional defaults for the CLI

Element types
-------------
joints: ``revolute``, ``prismatic`` (alias ``translational``), ``cylindrical``, ``screw``
(``pitch`` [m/rev]), ``planar``, ``spherical``, ``fixed``, ``universal`` (``axis_i``,
``axis_j`` instead of ``axis``). With ``at`` given, ``i``/``j`` name parts (``ground`` included)
or markers; without ``at`` both name markers.

forces: ``spring_damper``, ``rotational_spring_damper`` (``joint:`` a joint name, or ``i``/``j``
markers), ``bushing`` (``stiffness``/``damping`` as 6-lists or 6x6 lists, ``preload``,
``free``), ``force`` and ``torque`` (``part`` a part or marker name, constant ``value`` (3,)
in ground components, optional ``at``). Elements are built in file order: parts, markers,
joints, forces, so a force may name the markers a joint creates (``<joint>.I``, ``<joint>.J``).

Every problem — YAML syntax, unknown or missing field, wrong type or shape, unknown name,
or an inconsistency found by the builders — raises :class:`~proleg.errors.ModelError` with the
file, the line, the element (``joints[1] 'elbow'``), the field and how to fix it.
"""

from __future__ import annotations

import difflib
import re
from pathlib import Path
from typing import Annotated, Any, Literal

import numpy as np
import yaml
from pydantic import BaseModel, BeforeValidator, ConfigDict, Field, ValidationError

from ..errors import ModelError
from ..model import forces as _f
from ..model import joints as _j
from ..model.model import Model
from ..model.parts import Part

__all__ = ["load_model", "load_model_file", "model_from_dict", "model_to_dict", "dump_model"]

SECTIONS = ("parts", "markers", "joints", "forces")


# ------------------------------------------------------------------------------------------
# Schema
# ------------------------------------------------------------------------------------------
def _array_type(*shapes: tuple[int, ...], what: str):
    """A numeric array field of one of ``shapes``, kept as nested lists of float."""
    exp = " or ".join("a " + "x".join(map(str, s)) + (" list" if len(s) > 1 else "-list") for s in shapes)

    def check(value):
        if isinstance(value, str | bytes | dict) or np.ndim(value) == 0:
            raise ValueError(f"expected {exp} of numbers ({what}), got {value!r}")
        try:
            arr = np.asarray(value, dtype=float)
        except (TypeError, ValueError):
            raise ValueError(f"expected {exp} of numbers ({what}), got {value!r}") from None
        if arr.shape not in shapes:
            raise ValueError(f"expected {exp} ({what}), got shape {arr.shape}: {value!r}")
        if not np.all(np.isfinite(arr)):
            raise ValueError(f"contains NaN or inf: {value!r}; give finite numbers ({what})")
        return arr.tolist()

    return Annotated[Any, BeforeValidator(check)]


Vec3 = _array_type((3,), what="[x, y, z] in ground coordinates")
Axis = _array_type((3,), what="a direction [ax, ay, az] in ground coordinates")
Inertia = _array_type((3,), (3, 3), what="[Ixx, Iyy, Izz] or a 3x3 tensor [kg m^2] about the COM in part axes")
Orientation = _array_type((3, 3), (4,), what="a 3x3 rotation matrix or a unit quaternion [e0, e1, e2, e3]")
Six = _array_type((6,), (6, 6), what="a 6-list (diagonal) or a 6x6 matrix [translations x3, rotations x3]")
Vec6 = _array_type((6,), what="[x, y, z, rx, ry, rz]")


class _Spec(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False, str_strip_whitespace=True)


class PartSpec(_Spec):
    """``Model.add_part``: a rigid body."""

    name: str = Field(description="part name, unique")
    mass: float = Field(gt=0, description="[kg], > 0")
    inertia: Inertia = Field(description="[Ixx, Iyy, Izz] or 3x3 [kg m^2], about the COM in part axes")
    position: Vec3 = Field(description="COM position [m] in ground")
    orientation: Orientation | None = Field(None, description="3x3 rotation matrix or unit quaternion (scalar first)")
    velocity: Vec3 | None = Field(None, description="initial COM velocity [m/s] in ground")
    angular_velocity: Vec3 | None = Field(None, description="initial angular velocity [rad/s] in ground")


class MarkerSpec(_Spec):
    """``Model.add_marker``: a frame fixed to a part, given at its ground pose."""

    name: str = Field(description="marker name, unique")
    part: str = Field(description="name of the part carrying the marker (or ground)")
    position: Vec3 = Field(description="[m] in ground at the modelled pose")
    orientation: Orientation | None = Field(None, description="3x3 rotation matrix or unit quaternion, ground frame")


class _JointSpec(_Spec):
    name: str = Field(description="joint name, unique")
    i: str = Field(description="first part (with at) or marker I (without at)")
    j: str = Field(description="second part (with at) or marker J (without at)")
    at: Vec3 | None = Field(None, description="joint origin [m] in ground; needed when connecting parts")


class _AxisJointSpec(_JointSpec):
    axis: Axis | None = Field(None, description="joint axis in ground coordinates")


class RevoluteSpec(_AxisJointSpec):
    type: Literal["revolute"]


class PrismaticSpec(_AxisJointSpec):
    type: Literal["prismatic", "translational"]


class CylindricalSpec(_AxisJointSpec):
    type: Literal["cylindrical"]


class ScrewSpec(_AxisJointSpec):
    type: Literal["screw"]
    pitch: float = Field(description="[m/rev], non-zero")


class PlanarSpec(_AxisJointSpec):
    type: Literal["planar"]


class SphericalSpec(_AxisJointSpec):
    type: Literal["spherical"]


class FixedSpec(_AxisJointSpec):
    type: Literal["fixed"]


class UniversalSpec(_JointSpec):
    type: Literal["universal"]
    axis_i: Axis | None = Field(None, description="cross-pin axis fixed in the first part, ground coordinates")
    axis_j: Axis | None = Field(None, description="cross-pin axis fixed in the second part, ground coordinates")


JointSpec = Annotated[
    RevoluteSpec
    | PrismaticSpec
    | CylindricalSpec
    | ScrewSpec
    | PlanarSpec
    | SphericalSpec
    | FixedSpec
    | UniversalSpec,
    Field(discriminator="type"),
]


class SpringDamperSpec(_Spec):
    type: Literal["spring_damper"]
    name: str = Field(description="force element name, unique")
    i: str = Field(description="marker I (the force acts on I)")
    j: str = Field(description="marker J (the reaction acts on J)")
    stiffness: float = Field(0.0, ge=0, description="[N/m], >= 0")
    damping: float = Field(0.0, ge=0, description="[N s/m], >= 0")
    free_length: float = Field(0.0, ge=0, description="[m], >= 0")
    preload: float = Field(0.0, description="[N], positive pushes the markers apart")


class RotationalSpringDamperSpec(_Spec):
    type: Literal["rotational_spring_damper"]
    name: str = Field(description="force element name, unique")
    joint: str | None = Field(None, description="a revolute/cylindrical joint name (instead of i and j)")
    i: str | None = Field(None, description="marker I (instead of joint)")
    j: str | None = Field(None, description="marker J (instead of joint)")
    stiffness: float = Field(0.0, ge=0, description="[N m/rad], >= 0")
    damping: float = Field(0.0, ge=0, description="[N m s/rad], >= 0")
    free_angle: float = Field(0.0, description="[rad]")
    preload: float = Field(0.0, description="[N m]")


class BushingSpec(_Spec):
    type: Literal["bushing"]
    name: str = Field(description="force element name, unique")
    i: str = Field(description="marker I (the force acts on I)")
    j: str = Field(description="marker J (the reaction acts on J)")
    stiffness: Six = Field(description="6-list or 6x6 [N/m x3, N m/rad x3]")
    damping: Six | None = Field(None, description="6-list or 6x6 [N s/m x3, N m s/rad x3]")
    preload: Vec6 | None = Field(None, description="6-list [N x3, N m x3]")
    free: Vec6 | None = Field(None, description="6-list [m x3, rad x3]")


class ForceSpec(_Spec):
    type: Literal["force"]
    name: str = Field(description="force element name, unique")
    part: str = Field(description="part (or marker) the force acts on")
    value: Vec3 = Field(description="constant force [N] in ground components")
    at: Vec3 | None = Field(None, description="application point [m] in ground; default the COM")


class TorqueSpec(_Spec):
    type: Literal["torque"]
    name: str = Field(description="force element name, unique")
    part: str = Field(description="part (or marker) the torque acts on")
    value: Vec3 = Field(description="constant torque [N m] in ground components")
    at: Vec3 | None = Field(None, description="application point [m] in ground (irrelevant for a pure torque)")


ForceElementSpec = Annotated[
    SpringDamperSpec | RotationalSpringDamperSpec | BushingSpec | ForceSpec | TorqueSpec,
    Field(discriminator="type"),
]


class SimulateSpec(_Spec):
    """Optional defaults for ``proleg simulate`` (the CLI); the Python API ignores them."""

    t_end: float | None = Field(None, gt=0, description="end time [s], > 0")
    dt_output: float | None = Field(None, gt=0, description="output interval [s], > 0")
    dt_max: float | None = Field(None, gt=0, description="largest integration step [s], > 0")
    rtol: float | None = Field(None, gt=0, description="relative error tolerance, > 0")
    atol: float | None = Field(None, gt=0, description="absolute error tolerance, > 0")


class ModelFile(_Spec):
    """The whole file."""

    name: str = Field("model", description="model name")
    gravity: Vec3 = Field([0.0, 0.0, -9.81], description="[m/s^2] in ground")
    units: Literal["SI"] = Field("SI", description="only SI (m, kg, s, N, rad) for now")
    parts: list[PartSpec] = Field(default_factory=list, description="rigid bodies")
    markers: list[MarkerSpec] = Field(default_factory=list, description="frames on parts")
    joints: list[JointSpec] = Field(default_factory=list, description="joints")
    forces: list[ForceElementSpec] = Field(default_factory=list, description="force elements")
    simulate: SimulateSpec | None = Field(None, description="defaults for the CLI")


_JOINT_SPECS = {
    "revolute": RevoluteSpec,
    "prismatic": PrismaticSpec,
    "translational": PrismaticSpec,
    "cylindrical": CylindricalSpec,
    "screw": ScrewSpec,
    "planar": PlanarSpec,
    "spherical": SphericalSpec,
    "fixed": FixedSpec,
    "universal": UniversalSpec,
}
_FORCE_SPECS = {
    "spring_damper": SpringDamperSpec,
    "rotational_spring_damper": RotationalSpringDamperSpec,
    "bushing": BushingSpec,
    "force": ForceSpec,
    "torque": TorqueSpec,
}
_JOINT_CLASSES = {
    "revolute": _j.Revolute,
    "prismatic": _j.Prismatic,
    "translational": _j.Prismatic,
    "cylindrical": _j.Cylindrical,
    "screw": _j.Screw,
    "planar": _j.Planar,
    "spherical": _j.Spherical,
    "fixed": _j.Fixed,
    "universal": _j.Universal,
}


# ------------------------------------------------------------------------------------------
# Locating problems: file, line, element, field
# ------------------------------------------------------------------------------------------
class _Where:
    """Turns a path into the data (``('joints', 1, 'axis')``) into ``file:line: joints[1] 'elbow' field 'axis'``."""

    def __init__(self, source: str, data, lines: dict | None):
        self.source = source
        self.data = data
        self.lines = lines or {}

    def line(self, path) -> int | None:
        path = tuple(path)
        while path not in self.lines and path:
            path = path[:-1]
        return self.lines.get(path)

    def _split(self, path):
        """(element label, field path) of a data path."""
        path = tuple(path)
        if len(path) >= 2 and path[0] in SECTIONS and isinstance(path[1], int):
            item = _get(self.data, path[:2])
            name = item.get("name") if isinstance(item, dict) else None
            label = f"{path[0]}[{path[1]}]" + (f" '{name}'" if isinstance(name, str) else "")
            return label, path[2:]
        if path and path[0] == "simulate":
            return "simulate", path[1:]
        return "", path

    def field(self, path) -> str:
        out = ""
        for k in self._split(path)[1]:
            out += f"[{k}]" if isinstance(k, int) else (f".{k}" if out else str(k))
        return out

    def prefix(self, path) -> str:
        line = self.line(path)
        head = f"{self.source}:{line}" if line is not None else self.source
        field = self.field(path)
        parts = [p for p in (self._split(path)[0], f"field '{field}'" if field else "") if p]
        return f"{head}: " + (" ".join(parts) + ": " if parts else "")

    def error(self, path, message: str) -> ModelError:
        return ModelError(self.prefix(path) + message)


def _get(data, path):
    for k in path:
        try:
            data = data[k]
        except (KeyError, IndexError, TypeError):
            return None
    return data


def _data_path(data, loc) -> list:
    """Map a pydantic ``loc`` onto the input data, dropping discriminated-union tags."""
    path, cur = [], data
    for k in loc:
        if isinstance(cur, dict) and k in cur:
            path.append(k)
            cur = cur[k]
        elif isinstance(cur, list) and isinstance(k, int) and 0 <= k < len(cur):
            path.append(k)
            cur = cur[k]
        elif isinstance(cur, dict) and isinstance(k, str) and (k == cur.get("type") or k in _JOINT_SPECS or k in _FORCE_SPECS):
            continue  # the union tag pydantic inserts into loc
        else:
            path.append(k)
            cur = None
    return path


def _spec_class(data, path):
    """The pydantic class describing the mapping that holds ``path[-1]``."""
    if len(path) >= 2 and path[0] in SECTIONS and isinstance(path[1], int):
        item = _get(data, path[:2])
        t = item.get("type") if isinstance(item, dict) else None
        if path[0] == "parts":
            return PartSpec
        if path[0] == "markers":
            return MarkerSpec
        if path[0] == "joints":
            return _JOINT_SPECS.get(t)
        return _FORCE_SPECS.get(t)
    if path and path[0] == "simulate":
        return SimulateSpec
    return ModelFile


def _describe(cls, field: str) -> str:
    if cls is None or field not in cls.model_fields:
        return ""
    return cls.model_fields[field].description or ""


def _fix(err: dict, data, path) -> str:
    """A one-line explanation and fix for one pydantic error."""
    t = err["type"]
    field = path[-1] if path and isinstance(path[-1], str) else None
    cls = _spec_class(data, path)
    desc = _describe(cls, field) if field else ""
    section = path[0] if path else None
    if t == "extra_forbidden":
        allowed = [k for k in cls.model_fields if k != "type"] if cls else []
        close = difflib.get_close_matches(str(field), allowed, n=1)
        hint = f" Did you mean '{close[0]}'?" if close else ""
        return f"unknown field '{field}'.{hint} Remove it or use one of: {', '.join(allowed)}."
    if t == "missing":
        return f"required field '{field}' is missing. Add {field}: <value>" + (f" ({desc})." if desc else ".")
    if t == "union_tag_not_found":
        kinds = _JOINT_SPECS if section == "joints" else _FORCE_SPECS
        return f"missing 'type'. Add type: <one of {', '.join(kinds)}>."
    if t == "union_tag_invalid":
        kinds = list(_JOINT_SPECS if section == "joints" else _FORCE_SPECS)
        tag = err.get("ctx", {}).get("tag")
        close = difflib.get_close_matches(str(tag), kinds, n=1)
        hint = f" Did you mean '{close[0]}'?" if close else ""
        return f"unknown {section[:-1] if section else 'element'} type '{tag}'.{hint} Use one of: {', '.join(kinds)}."
    if t in ("model_type", "model_attributes_type", "dict_type"):
        what = f"a {section[:-1]}" if section in SECTIONS else "a mapping"
        return f"expected {what} as a mapping of fields ({{name: ..., ...}}), got {err.get('input')!r}."
    if t in ("list_type",):
        return f"expected a list (YAML '- item' lines or [a, b]), got {err.get('input')!r}."
    if t == "value_error":
        exc = err.get("ctx", {}).get("error")
        return f"{exc if exc is not None else err['msg']}."
    if t == "literal_error" and field == "units":
        return f"units {err.get('input')!r} is not supported. Use units: SI and give values in m, kg, s, N, rad."
    if t.startswith("string"):
        return f"expected a name (text), got {err.get('input')!r}. Quote it if it looks like a number: '\"{err.get('input')}\"'."
    msg = err["msg"][0].lower() + err["msg"][1:]
    got = f", got {err.get('input')!r}" if "input" in err and not isinstance(err.get("input"), dict | list) else ""
    return f"{msg}{got}." + (f" Expected {field}: {desc}." if desc else "")


def _raise_validation(exc: ValidationError, where: _Where):
    errs = exc.errors()
    lines = []
    for err in errs:
        path = _data_path(where.data, err["loc"])
        lines.append(where.prefix(path) + _fix(err, where.data, path))
    if len(lines) == 1:
        raise ModelError(lines[0]) from None
    raise ModelError(f"{where.source}: {len(lines)} problems\n  " + "\n  ".join(lines)) from None


# ------------------------------------------------------------------------------------------
# YAML reading
# ------------------------------------------------------------------------------------------
def _line_map(node, path=(), out=None) -> dict:
    """``{path: line}`` for every node of a composed YAML document; raises on duplicate keys."""
    out = {} if out is None else out
    out.setdefault(path, node.start_mark.line + 1)
    if isinstance(node, yaml.MappingNode):
        seen = {}
        for k, v in node.value:
            key = k.value
            if key in seen:
                raise _DuplicateKey(path, key, seen[key], k.start_mark.line + 1)
            seen[key] = k.start_mark.line + 1
            out[path + (key,)] = k.start_mark.line + 1
            _line_map(v, path + (key,), out)
    elif isinstance(node, yaml.SequenceNode):
        for n, v in enumerate(node.value):
            _line_map(v, path + (n,), out)
    return out


class _DuplicateKey(Exception):
    def __init__(self, path, key, first, second):
        self.path, self.key, self.first, self.second = path, key, first, second


def _parse_yaml(text: str, source: str):
    try:
        data = yaml.safe_load(text)
        node = yaml.compose(text, Loader=yaml.SafeLoader)
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        loc = f"{source}:{mark.line + 1}:{mark.column + 1}" if mark else source
        what = " ".join(p for p in (exc.context, exc.problem) if p)
        raise ModelError(
            f"{loc}: YAML syntax error: {what}. Check the indentation, that brackets and quotes are closed, "
            "and that list items start with '- '."
        ) from None
    except yaml.YAMLError as exc:
        raise ModelError(f"{source}: YAML error: {exc}") from None
    lines = {}
    if node is not None:
        try:
            lines = _line_map(node)
        except _DuplicateKey as d:
            where = _Where(source, data, {d.path + (d.key,): d.second})
            raise where.error(
                d.path + (d.key,),
                f"key '{d.key}' appears twice ("
                + (f"lines {d.first} and {d.second}" if d.first != d.second else f"line {d.first}")
                + "). Keep one of them.",
            ) from None
    return data, lines


# ------------------------------------------------------------------------------------------
# Building
# ------------------------------------------------------------------------------------------
def _names(model: Model, kind: str) -> list[str]:
    if kind == "part":
        return ["ground"] + [p.name for p in model.parts]
    return [e.name for e in (model.markers if kind == "marker" else model.joints)]


def _lookup(model: Model, where: _Where, path, name: str, kinds: tuple[str, ...], advice: str = ""):
    """Find a part, marker or joint by name (in the order of ``kinds``) or raise naming the known ones."""
    for kind in kinds:
        if name in _names(model, kind):
            return getattr(model, kind)(name)
    known = [n for kind in kinds for n in _names(model, kind)]
    close = difflib.get_close_matches(name, known, n=1)
    hint = f" Did you mean '{close[0]}'?" if close else ""
    listing = ", ".join(known) if known else "none defined"
    raise where.error(path, f"no {' or '.join(kinds)} named '{name}' (known: {listing}).{hint}{advice}")


def _builder_field(data, path, message: str):
    """Append the field a builder's message names (``"Revolute 'elbow' axis has ..."``) to ``path``."""
    item = _get(data, path)
    cls = _spec_class(data, tuple(path) + ("?",))
    name = item.get("name") if isinstance(item, dict) else None
    if cls is None or not isinstance(name, str):
        return path
    if "defined twice" in message:
        return tuple(path) + ("name",)
    for field in cls.model_fields:
        if field not in ("name", "type") and field in item and re.search(rf"'{re.escape(name)}' {field}\b", message):
            return tuple(path) + (field,)
    return path


def _build(spec: ModelFile, where: _Where) -> Model:
    try:
        model = Model(spec.name, gravity=spec.gravity)
    except ModelError as exc:
        raise where.error(("gravity",), str(exc)) from None

    def guard(path, fn):
        try:
            return fn()
        except ModelError as exc:
            raise where.error(_builder_field(where.data, path, str(exc)), str(exc)) from None

    for n, p in enumerate(spec.parts):
        guard(
            ("parts", n),
            lambda p=p: model.add_part(p.name, p.mass, p.inertia, p.position, p.orientation, p.velocity, p.angular_velocity),
        )
    for n, m in enumerate(spec.markers):
        part = _lookup(model, where, ("markers", n, "part"), m.part, ("part",), " Define the part under 'parts:' first.")
        guard(("markers", n), lambda m=m, part=part: model.add_marker(part, m.name, m.position, m.orientation))
    for n, js in enumerate(spec.joints):
        _build_joint(model, where, ("joints", n), js, guard)
    for n, fs in enumerate(spec.forces):
        _build_force(model, where, ("forces", n), fs, guard)
    return model


def _build_joint(model, where, path, js, guard):
    if js.at is not None:
        kinds, advice = ("part", "marker"), ""
    else:
        kinds = ("marker",)
        advice = " Without 'at', i and j name markers; to connect parts give at: [x, y, z] (and axis)."
    ends = []
    for role in ("i", "j"):
        name = getattr(js, role)
        if js.at is None and name in _names(model, "part") and name not in _names(model, "marker"):
            raise where.error(
                path + (role,), f"'{name}' is a part; to connect parts give at: [x, y, z] (the joint origin, ground) and axis."
            )
        ends.append(_lookup(model, where, path + (role,), name, kinds, advice))
    cls = _JOINT_CLASSES[js.type]
    kwargs = {"at": js.at}
    if isinstance(js, UniversalSpec):
        kwargs.update(axis_i=js.axis_i, axis_j=js.axis_j)
    else:
        kwargs["axis"] = js.axis
    if isinstance(js, ScrewSpec):
        kwargs["pitch"] = js.pitch
    needs_axis = cls.needs_axis and isinstance(js, _AxisJointSpec)
    if needs_axis and js.at is not None and js.axis is None:
        raise where.error(path + ("axis",), f"a {js.type} joint between parts needs axis: [ax, ay, az] (ground coordinates).")
    guard(path, lambda: model.add_joint(cls(js.name, ends[0], ends[1], **kwargs)))


def _build_force(model, where, path, fs, guard):
    def marker(role):
        name = getattr(fs, role)
        return _lookup(
            model, where, path + (role,), name, ("marker",), " Define it under 'markers:' (or use '<joint>.I' / '<joint>.J')."
        )

    if isinstance(fs, SpringDamperSpec):
        i, j = marker("i"), marker("j")
        make = lambda: _f.SpringDamper(fs.name, i, j, fs.stiffness, fs.damping, fs.free_length, fs.preload)  # noqa: E731
    elif isinstance(fs, RotationalSpringDamperSpec):
        kw = dict(stiffness=fs.stiffness, damping=fs.damping, free_angle=fs.free_angle, preload=fs.preload)
        if fs.joint is not None:
            if fs.i is not None or fs.j is not None:
                raise where.error(path + ("joint",), "give either joint: <name> or i and j markers, not both.")
            joint = _lookup(model, where, path + ("joint",), fs.joint, ("joint",), " Joints must come before forces.")
            make = lambda: _f.RotationalSpringDamper(fs.name, joint=joint, **kw)  # noqa: E731
        else:
            if fs.i is None or fs.j is None:
                raise where.error(path, "give joint: <revolute or cylindrical joint name>, or both i and j markers.")
            i, j = marker("i"), marker("j")
            make = lambda: _f.RotationalSpringDamper(fs.name, i, j, **kw)  # noqa: E731
    elif isinstance(fs, BushingSpec):
        i, j = marker("i"), marker("j")
        make = lambda: _f.Bushing(fs.name, i, j, fs.stiffness, fs.damping, fs.preload, fs.free)  # noqa: E731
    else:
        cls = _f.Force if isinstance(fs, ForceSpec) else _f.Torque
        target = _lookup(model, where, path + ("part",), fs.part, ("part", "marker"))
        make = lambda: cls(fs.name, target, fs.value, at=fs.at)  # noqa: E731
    guard(path, lambda: model.add_force(make()))


# ------------------------------------------------------------------------------------------
# Public API: reading
# ------------------------------------------------------------------------------------------
def _from_data(data, source: str, lines: dict | None) -> tuple[Model, dict]:
    where = _Where(source, data, lines)
    if data is None:
        raise ModelError(f"{source}: the model file is empty. Start it with 'name: my_model' and a 'parts:' list.")
    if not isinstance(data, dict):
        raise ModelError(
            f"{where.prefix(())}expected a mapping at the top level (name:, gravity:, parts:, ...), "
            f"got {type(data).__name__}."
        )
    # An empty section (``joints:`` with nothing under it) reads as None; treat it as [].
    data = {k: ([] if (k in SECTIONS and v is None) else v) for k, v in data.items()}
    where.data = data
    try:
        spec = ModelFile.model_validate(data)
    except ValidationError as exc:
        _raise_validation(exc, where)
    model = _build(spec, where)
    simulate = spec.simulate.model_dump(exclude_none=True) if spec.simulate is not None else {}
    return model, simulate


def model_from_dict(d: dict, source: str = "<dict>") -> Model:
    """Build a :class:`Model` from a dict shaped like a model file; ``source`` names it in errors."""
    return _from_data(d, source, None)[0]


def load_model_file(path) -> tuple[Model, dict]:
    """Read a YAML model file; return the model and its ``simulate:`` defaults (``{}`` if absent).

    Raises
    ------
    ModelError
        On any problem, naming the file, line, element and field.
    """
    path = Path(path)
    source = str(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ModelError(f"Model file '{source}' does not exist. Check the path (relative to {Path.cwd()}).") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ModelError(f"Model file '{source}' cannot be read: {exc}.") from None
    data, lines = _parse_yaml(text, source)
    return _from_data(data, source, lines)


def load_model(path) -> Model:
    """Read a YAML model file and return the :class:`Model` (see :func:`load_model_file`)."""
    return load_model_file(path)[0]


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
