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
      - {name: tilted, mass: 1.0, inertia: [0.01, 0.09, 0.09], position: [2, 0, 0], rpy_deg: [0, -30, 0]}
    markers:                            # Model.add_marker (part, ground-frame position/orientation)
      - {name: tip, part: upper, position: [1, 0, 0]}
    joints:                             # i, j: parts with at/axis, or markers without at
      - {type: revolute, name: shoulder, i: ground, j: upper, at: [0, 0, 0], axis: [0, 1, 0]}
    forces:
      - {type: spring_damper, name: spring, i: tip, j: anchor, stiffness: 50.0, free_length: 1.0}
    simulate: {t_end: 2.0, dt_output: 0.001}   # optional defaults for the CLI

Orientations (parts and markers) are ``orientation:`` (a 3x3 rotation matrix, part axes →
ground, or a unit quaternion [e0, e1, e2, e3], scalar first) or ``rpy_deg: [roll, pitch, yaw]``
in degrees: rotations about the fixed ground axes x, then y, then z (URDF's ``rpy``, Adams'
space-fixed 123), R = Rz(yaw) Ry(pitch) Rx(roll). Not both.

Element types
-------------
joints: ``revolute``, ``prismatic`` (alias ``translational``), ``cylindrical``, ``screw``
(``pitch`` [m/rev]), ``planar``, ``spherical``, ``fixed``, ``universal`` (``axis_i``,
``axis_j`` instead of ``axis``). With ``at`` given, ``i``/``j`` name parts (``ground`` included)
or markers; without ``at`` both name markers.

forces: ``spring_damper``, ``rotational_spring_damper`` (``joint:`` a joint name, or ``i``/``j``
markers), ``bushing`` (``stiffness``/``damping`` as 6-lists or 6x6 lists, ``preload``,
``free``), ``force`` and ``torque`` (``part`` a part or marker name, constant ``value`` (3,)
in ground components, optional ``at``), ``joint_stop`` and ``joint_friction`` (``joint:`` a joint
name). couplers: ``name``, ``joint_1``, ``joint_2``, ``ratio`` (q1 = r q2). Elements are built in file order: parts, markers,
joints, forces, so a force may name the markers a joint creates (``<joint>.I``, ``<joint>.J``).

Every problem — YAML syntax, unknown or missing field, wrong type or shape, unknown name,
or an inconsistency found by the builders — raises :class:`~proleg.errors.ModelError` with the
file, the line, the element (``joints[1] 'elbow'``), the field and how to fix it.

This module reads (YAML, error locations, building); the schema is in :mod:`proleg.io.modelspec`
and the writer (:func:`model_to_dict`, :func:`dump_model`) in :mod:`proleg.io.modelwrite`. All
their names are importable from here too.
"""

from __future__ import annotations

import difflib
import re
from pathlib import Path

import yaml
from pydantic import ValidationError

from ..errors import ModelError
from ..model import forces as _f
from ..model.model import Model

# The schema (pydantic) and the writer live in their own modules; every name is imported back so
# that what was importable from this module still is.
from .modelspec import (  # noqa: F401
    _FORCE_SPECS,
    _JOINT_CLASSES,
    _JOINT_SPECS,
    SECTIONS,
    Axis,
    BushingSpec,
    CouplerSpec,
    JointFrictionSpec,
    JointStopSpec,
    CylindricalSpec,
    FixedSpec,
    ForceElementSpec,
    ForceSpec,
    Inertia,
    JointSpec,
    MarkerSpec,
    ModelFile,
    Orientation,
    PartSpec,
    PlanarSpec,
    PrismaticSpec,
    RevoluteSpec,
    RotationalSpringDamperSpec,
    ScrewSpec,
    SimulateSpec,
    Six,
    SphericalSpec,
    SpringDamperSpec,
    TorqueSpec,
    UniversalSpec,
    Vec3,
    Vec6,
    _array_type,
    _AxisJointSpec,
    _JointSpec,
    _Spec,
)
from .modelwrite import (  # noqa: F401
    _clean,
    _Dumper,
    _end_name,
    _Flow,
    _flowify,
    _FlowMap,
    _force_to_dict,
    _is_identity,
    _six_out,
    _vec,
    dump_model,
    model_to_dict,
)

__all__ = ["load_model", "load_model_file", "model_from_dict", "model_to_dict", "dump_model"]


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
        t = t if isinstance(t, str) else None  # `type: []` is the user's error, not a key to look up
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
    except yaml.reader.ReaderError as exc:  # a character YAML forbids (NUL, control codes): its line
        pos = exc.position if isinstance(exc.position, int) else 0
        line = text[:pos].count("\n") + 1
        code = exc.character if isinstance(exc.character, int) else ord(str(exc.character)[:1] or "\0")
        raise ModelError(f"{source}:{line}: YAML error: character #x{code:04x} is not allowed in a YAML file; "
                         "remove it (or save the file as plain UTF-8 text).") from None
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
            lambda p=p: model.add_part(p.name, p.mass, p.inertia, p.position, p.rotation(), p.velocity, p.angular_velocity),
        )
    for n, m in enumerate(spec.markers):
        part = _lookup(model, where, ("markers", n, "part"), m.part, ("part",), " Define the part under 'parts:' first.")
        guard(("markers", n), lambda m=m, part=part: model.add_marker(part, m.name, m.position, m.rotation()))
    for n, js in enumerate(spec.joints):
        _build_joint(model, where, ("joints", n), js, guard)
    for n, fs in enumerate(spec.forces):
        _build_force(model, where, ("forces", n), fs, guard)
    from ..model.couplers import Coupler

    for n, cs in enumerate(spec.couplers):
        path = ("couplers", n)
        j1 = _lookup(model, where, path + ("joint_1",), cs.joint_1, ("joint",), " Define it under 'joints:'.")
        j2 = _lookup(model, where, path + ("joint_2",), cs.joint_2, ("joint",), " Define it under 'joints:'.")
        guard(path, lambda cs=cs, j1=j1, j2=j2: model.add_coupler(Coupler(cs.name, j1, j2, cs.ratio, dof=cs.dof)))
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
    elif isinstance(fs, JointStopSpec | JointFrictionSpec):
        from ..model.couplers import JointFriction, JointStop

        joint = _lookup(model, where, path + ("joint",), fs.joint, ("joint",), " Joints must come before forces.")
        kw = fs.model_dump(exclude={"type", "name", "joint"})
        cls = JointStop if isinstance(fs, JointStopSpec) else JointFriction
        make = lambda: cls(fs.name, joint, **kw)  # noqa: E731
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
