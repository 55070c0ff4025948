"""Fuzzing of every input format (issue 34, Hypothesis): model YAML files, URDF files, study files
and CLI argument lists. Each input gives a valid result or a documented proleg error — never a
raw exception, a hang (every example has a deadline) or a half-written output file.

- model YAML: generated valid models load and round-trip (``dump_model`` → ``load_model_file``
  gives the same dict), from chains on revolute/prismatic/cylindrical joints to models using
  every section (oriented parts and markers, initial velocities, every joint and force type,
  couplers); mutated files (a line deleted, duplicated or garbled, a value replaced
  by junk, the text cut) give a Model or a ModelError naming the file, and its line wherever
  the file parsed as a mapping;
- URDF: random link graphs (cycles, two parents, a joint to itself or to a missing link),
  unknown joint types, missing, zero, negative or non-numeric inertias, missing meshes, and
  XML cut at random points;
- study files: random specs around a valid one, loaded (parse and assemble only, nothing runs);
- CLI: random argument lists for every command, with the simulation and study runners
  replaced by a stub, so that no example compiles JAX.

The fast suite runs a few hundred examples in all; the ``slow`` tests 10,000 per format.
"""

from __future__ import annotations

import re
import shutil
import tempfile
import warnings
from pathlib import Path

import numpy as np
import pytest
import yaml
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

import proleg as pl
from proleg.errors import DataError, ModelError
from proleg.io.modelfile import dump_model, load_model_file, model_to_dict
from proleg.io.urdf import load_urdf

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
# A deadline of a minute: a hang fails, a loaded shared machine does not.
FAST = settings(max_examples=60, deadline=60000, suppress_health_check=list(HealthCheck), derandomize=True)
SLOW = settings(max_examples=10_000, deadline=60000, suppress_health_check=list(HealthCheck))
DOCUMENTED = (ModelError, DataError)


def _tmpdir() -> Path:
    return Path(tempfile.mkdtemp(prefix="proleg-fuzz-"))


def outcome(fn):
    """fn() or the documented error it raised; any other exception fails the test."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            return fn()
        except DOCUMENTED as exc:
            return exc


# ------------------------------------------------------------------------------------------
# model YAML
# ------------------------------------------------------------------------------------------
pos = st.floats(-2.0, 2.0, allow_nan=False).map(lambda x: round(x, 6))
unit_axes = st.sampled_from([[1, 0, 0], [0, 1, 0], [0, 0, 1], [0, 0.6, 0.8], [1, 1, 0]])


@st.composite
def model_dicts(draw):
    """A valid model: a chain of 1–4 parts on revolute/prismatic joints, a spring maybe."""
    n = draw(st.integers(1, 4))
    parts, joints = [], []
    for k in range(n):
        a, b = draw(st.floats(0.01, 1.0)), draw(st.floats(0.01, 1.0))
        c = draw(st.floats(abs(a - b) + 1e-3, a + b - 1e-3)) if a + b - abs(a - b) > 2e-3 else a
        parts.append({"name": f"p{k}", "mass": round(draw(st.floats(0.05, 20.0)), 6), "inertia": [a, b, c],
                      "position": [k + 0.5, 0.0, draw(pos)]})
        joints.append({"type": draw(st.sampled_from(["revolute", "prismatic", "cylindrical"])), "name": f"j{k}",
                       "i": "ground" if k == 0 else f"p{k - 1}", "j": f"p{k}", "at": [float(k), 0.0, 0.0],
                       "axis": draw(unit_axes)})
    d = {"name": draw(st.from_regex(r"[a-z][a-z0-9_]{0,10}", fullmatch=True)), "gravity": [0, 0, -draw(st.floats(0, 20))],
         "parts": parts, "joints": joints}
    if draw(st.booleans()):
        d["markers"] = [{"name": "tip", "part": f"p{n - 1}", "position": [n + 0.5, 0, 0]},
                        {"name": "anchor", "part": "ground", "position": [n + 0.5, 0, -1]}]
        d["forces"] = [{"type": "spring_damper", "name": "spring", "i": "tip", "j": "anchor",
                        "stiffness": draw(st.floats(0, 1e4)), "damping": draw(st.floats(0, 10)), "free_length": 1.0}]
    if draw(st.booleans()):
        d["simulate"] = {"t_end": draw(st.floats(0.01, 10)), "dt_output": 0.01}
    return d


angles = st.lists(st.floats(-180.0, 180.0, allow_nan=False).map(lambda x: round(x, 4)), min_size=3, max_size=3)
ONE_AXIS_JOINTS = ["revolute", "prismatic", "cylindrical", "screw", "planar", "spherical", "fixed", "universal"]


@st.composite
def rich_model_dicts(draw):
    """A valid model using every section of the file: parts with orientations (rpy_deg or a unit
    quaternion) and initial velocities, oriented markers, every joint type (screw pitch,
    universal cross-pin axes), every force type (spring_damper, rotational_spring_damper on a
    joint, bushing with 6-lists or a symmetric 6x6, force and torque with or without ``at``,
    joint_stop, joint_friction) and couplers between revolute joints."""
    d = draw(model_dicts())
    for part in d["parts"]:
        how = draw(st.sampled_from(["none", "rpy", "quat"]))
        if how == "rpy":
            part["rpy_deg"] = draw(angles)
        elif how == "quat":
            q = np.array(draw(st.lists(st.floats(-1.0, 1.0), min_size=4, max_size=4)))
            if np.linalg.norm(q) > 0.1:
                part["orientation"] = [float(x) for x in q / np.linalg.norm(q)]
        if draw(st.booleans()):
            part["velocity"] = [draw(pos) for _ in range(3)]
        if draw(st.booleans()):
            part["angular_velocity"] = [draw(pos) for _ in range(3)]
    for joint in d["joints"]:
        kind = draw(st.sampled_from(ONE_AXIS_JOINTS))
        joint["type"] = kind
        if kind == "screw":
            joint["pitch"] = draw(st.sampled_from([0.01, -0.002, 0.5]))
        if kind == "universal":
            a = joint.pop("axis")
            a = np.asarray(a, float) / np.linalg.norm(a)
            b = np.cross(a, [0.0, 0.0, 1.0] if abs(a[2]) < 0.9 else [1.0, 0.0, 0.0])
            joint["axis_i"], joint["axis_j"] = [float(x) for x in a], [float(x) for x in b / np.linalg.norm(b)]
    markers = d.setdefault("markers", [])
    forces = d.setdefault("forces", [])
    names = {m["name"] for m in markers}
    for k in range(draw(st.integers(0, 2))):
        part = draw(st.sampled_from(["ground"] + [p["name"] for p in d["parts"]]))
        for end in ("bi", "bj"):
            m = {"name": f"{end}{k}", "part": part if end == "bi" else "ground", "position": [draw(pos) for _ in range(3)]}
            if draw(st.booleans()):
                m["rpy_deg"] = draw(angles)
            markers.append(m)
            names.add(m["name"])
        if part == "ground":  # a bushing between two ground markers is refused: put I on a part
            markers[-2]["part"] = d["parts"][-1]["name"]
        diag = [round(draw(st.floats(1.0, 1e6)), 3) for _ in range(6)]
        if draw(st.booleans()):
            stiff = diag
        else:
            a = np.diag(diag)
            a[0, 1] = a[1, 0] = 0.1 * min(diag[0], diag[1])
            stiff = a.tolist()
        b = {"type": "bushing", "name": f"bush{k}", "i": f"bi{k}", "j": f"bj{k}", "stiffness": stiff}
        if draw(st.booleans()):
            b["damping"] = [round(draw(st.floats(0.0, 100.0)), 3) for _ in range(6)]
        if draw(st.booleans()):
            b["preload"] = [round(draw(st.floats(-10.0, 10.0)), 3) for _ in range(6)]
        forces.append(b)
    rot = [j["name"] for j in d["joints"] if j["type"] in ("revolute", "cylindrical")]
    one = [j["name"] for j in d["joints"] if j["type"] in ("revolute", "prismatic")]
    if rot and draw(st.booleans()):
        forces.append({"type": "rotational_spring_damper", "name": "rsd", "joint": draw(st.sampled_from(rot)),
                       "stiffness": draw(st.floats(0, 1e3)), "damping": draw(st.floats(0, 5)), "free_angle": draw(pos)})
    if one and draw(st.booleans()):
        forces.append({"type": "joint_stop", "name": "stop", "joint": draw(st.sampled_from(one)),  # 0 (the pose) inside
                       "lower": -draw(st.floats(0.01, 1.5)), "upper": draw(st.floats(0.01, 1.5)),
                       "exponent": draw(st.sampled_from([1.0, 1.5, 2.0]))})
    if one and draw(st.booleans()):
        forces.append({"type": "joint_friction", "name": "fric", "joint": draw(st.sampled_from(one)),
                       "friction": draw(st.floats(0, 10)), "damping": draw(st.floats(0, 1))})
    for kind in ("force", "torque"):
        if draw(st.booleans()):
            f = {"type": kind, "name": f"{kind}0", "part": draw(st.sampled_from([p["name"] for p in d["parts"]])),
                 "value": [draw(pos) for _ in range(3)]}
            if draw(st.booleans()):
                f["at"] = [draw(pos) for _ in range(3)]
            forces.append(f)
    revs = [j["name"] for j in d["joints"] if j["type"] == "revolute"]
    if len(revs) >= 2 and draw(st.booleans()):
        d["couplers"] = [{"name": "gear", "joint_1": revs[0], "joint_2": revs[1], "ratio": draw(st.sampled_from([2.0, -0.5, 3.7]))}]
    if not markers:
        d.pop("markers")
    if not forces:
        d.pop("forces")
    return d


JUNK = ["", "-1", "0", "nan", ".inf", "1e400", "null", "[]", "{}", "[1, 2]", "heavy", "'", "\"", "{a: 1", "[1, [2]]",
        "!!python/object:os.system", "&a", "*a", "- x", ": :", "\t", "true", "0x1F", "ground", "p0", "j0", "revolute",
        "{type: revolute}", "ü", "\x00", "-0.0", "1_000", "~", "? x", "%YAML 1.2"]


@st.composite
def broken_model_texts(draw):
    """A valid model file with one to three mutations."""
    text = yaml.safe_dump(draw(model_dicts()), sort_keys=False, default_flow_style=None)
    for _ in range(draw(st.integers(1, 3))):
        lines = text.splitlines()
        how = draw(st.sampled_from(["delete", "duplicate", "replace_value", "insert", "cut", "indent", "swap_key"]))
        i = draw(st.integers(0, max(0, len(lines) - 1))) if lines else 0
        if how == "delete" and lines:
            del lines[i]
        elif how == "duplicate" and lines:
            lines.insert(i, lines[i])
        elif how == "insert":
            lines.insert(i, draw(st.sampled_from(JUNK + ["extra: 1", "parts: 3", "  - {name: p0, mass: 1}"])))
        elif how == "indent" and lines:
            lines[i] = draw(st.sampled_from(["  ", " ", "\t", ""])) + lines[i].lstrip()
        elif how == "swap_key" and lines:
            lines[i] = re.sub(r"\b(name|mass|inertia|position|type|axis|at|i|j|stiffness|parts|joints)\b",
                              draw(st.sampled_from(["nme", "mass", "type", "axes", "inertia", "j", "x"])), lines[i], count=1)
        elif how == "replace_value":
            tokens = list(re.finditer(r"-?\d+(\.\d+)?(e-?\d+)?|\b[a-z_][a-z0-9_]*\b", text))
            if tokens:
                m = tokens[draw(st.integers(0, len(tokens) - 1))]
                text = text[: m.start()] + draw(st.sampled_from(JUNK)) + text[m.end():]
                continue
        elif how == "cut":
            text = text[: draw(st.integers(0, len(text)))]
            continue
        text = "\n".join(lines) + "\n"
    return text


def same_tree(a, b, path="model"):
    """Equal structure and strings; numbers equal to 1e-12 relative: a marker's orientation is
    rebuilt from its normalised axis on every load, a few ulps from the one written."""
    if isinstance(a, dict):
        assert isinstance(b, dict) and list(a) == list(b), f"{path}: keys {list(a)} vs {list(b)}"
        for k in a:
            same_tree(a[k], b[k], f"{path}.{k}")
    elif isinstance(a, (list, tuple)) and not all(isinstance(x, (int, float)) for x in a):
        assert isinstance(b, (list, tuple)) and len(a) == len(b), f"{path}: {a} vs {b}"
        for k, (x, y) in enumerate(zip(a, b)):
            same_tree(x, y, f"{path}[{k}]")
    elif isinstance(a, str) or a is None or isinstance(a, bool):
        assert a == b, f"{path}: {a!r} vs {b!r}"
    else:
        x, y = np.asarray(a, float), np.asarray(b, float)
        assert x.shape == y.shape, path
        np.testing.assert_allclose(x, y, rtol=1e-12, atol=1e-12 * max(1.0, float(np.abs(x).max(initial=0))), err_msg=path)


def check_roundtrip(d):
    tmp = _tmpdir()
    try:
        path = tmp / "model.yaml"
        path.write_text(yaml.safe_dump(d, sort_keys=False))
        model, sim = load_model_file(path)
        assert [p.name for p in model.parts] == [p["name"] for p in d["parts"]]
        # exact: a float written by yaml (repr) and parsed back is the same float on any machine
        np.testing.assert_allclose([p.mass for p in model.parts], [p["mass"] for p in d["parts"]], rtol=0, atol=0)
        out = dump_model(model, tmp / "back.yaml", simulate=sim)
        back, sim2 = load_model_file(out)
        same_tree(model_to_dict(model, sim), model_to_dict(back, sim2))
        assert not list(tmp.glob(".*"))  # no temporary file left beside the output
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def check_broken_model(text):
    tmp = _tmpdir()
    try:
        path = tmp / "model.yaml"
        path.write_text(text, encoding="utf-8", errors="surrogateescape")
        got = outcome(lambda: load_model_file(path))
        if isinstance(got, Exception):
            msg = str(got)
            assert str(path) in msg, msg
            try:
                parsed = yaml.safe_load(text)
            except yaml.YAMLError:
                parsed = None
            if isinstance(parsed, dict) and parsed or "YAML" in msg:
                assert re.search(re.escape(str(path)) + r":\d+", msg), f"no line number: {msg}"
        else:
            model, _ = got  # may have no parts (a file cut after its name): assemble refuses that
            assert isinstance(model, pl.Model)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


@FAST
@given(model_dicts())
def test_valid_model_files_round_trip(d):
    check_roundtrip(d)


@FAST
@given(rich_model_dicts())
def test_valid_model_files_with_every_element_round_trip(d):
    check_roundtrip(d)


_LIST_TYPED = """name: a
parts:
- {name: p0, mass: 1.0, inertia: [1.0, 1.0, 1.0], position: [0.5, 0.0, 0.0]}
joints:
- {type: [], name: j0, i: ground, j: p0, at: [0.0, 0.0, 0.0], axis: [0, 1, 0]}
"""


@FAST
@given(broken_model_texts())
@example(_LIST_TYPED)  # the 10,000-example run found it: an unhashable type raised TypeError
@example(_LIST_TYPED.replace("joints:", "forces:").replace("type: []", "type: {a: 1}"))
def test_broken_model_files_give_model_error_with_line(text):
    check_broken_model(text)


@pytest.mark.slow
@SLOW
@given(st.one_of(model_dicts(), rich_model_dicts()))
def test_valid_model_files_round_trip_10k(d):
    check_roundtrip(d)


@pytest.mark.slow
@SLOW
@given(broken_model_texts())
def test_broken_model_files_10k(text):
    check_broken_model(text)


# ------------------------------------------------------------------------------------------
# URDF
# ------------------------------------------------------------------------------------------
NUM = st.one_of(st.sampled_from(["0", "1", "-1", "0.01", "1e-9", "nan", "inf", "", "abc", "1 2", "1e400"]),
                st.floats(-10, 10).map(lambda x: f"{x:.4g}"))
JOINT_TYPES = ["revolute", "continuous", "prismatic", "fixed", "floating", "planar", "ball", "screw", "", "REVOLUTE"]


@st.composite
def urdf_texts(draw):
    n = draw(st.integers(1, 5))
    names = [f"l{k}" for k in range(n)]
    out = ['<?xml version="1.0"?>', f'<robot name="{draw(st.sampled_from(["r", "", "x y"]))}">']
    for k, ln in enumerate(names):
        kind = draw(st.sampled_from(["good", "none", "mass_only", "zero", "junk", "mesh", "no_name"]))
        if kind == "no_name":
            out.append("<link>")
        else:
            out.append(f'<link name="{ln}">')
        if kind == "good" or kind == "mesh":
            out.append('<inertial><origin xyz="0 0 -0.1" rpy="0 0 0"/><mass value="1.0"/>'
                       '<inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.001"/></inertial>')
        elif kind == "mass_only":
            out.append(f'<inertial><mass value="{draw(NUM)}"/></inertial>')
        elif kind == "zero":
            out.append('<inertial><mass value="0"/><inertia ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"/></inertial>')
        elif kind == "junk":
            vals = [draw(NUM) for _ in range(7)]
            out.append(f'<inertial><origin xyz="{draw(NUM)} 0 0"/><mass value="{vals[0]}"/><inertia ixx="{vals[1]}" ixy="{vals[2]}" '
                       f'ixz="{vals[3]}" iyy="{vals[4]}" iyz="{vals[5]}" izz="{vals[6]}"/></inertial>')
        if kind == "mesh":
            fn = draw(st.sampled_from(["missing.stl", "package://nopkg/meshes/x.dae", "file:///nonexistent/y.obj", ""]))
            out.append(f'<visual><geometry><mesh filename="{fn}" scale="{draw(NUM)} 1 1"/></geometry></visual>')
        if draw(st.booleans()):
            out.append(f'<collision><geometry><sphere radius="{draw(NUM)}"/></geometry></collision>')
        out.append("</link>")
    for k in range(draw(st.integers(0, n + 1))):
        parent = draw(st.sampled_from(names + ["missing", ""]))
        child = draw(st.sampled_from(names + ["missing"]))
        jt = draw(st.sampled_from(JOINT_TYPES))
        body = [f'<parent link="{parent}"/>' if draw(st.integers(0, 9)) else "", f'<child link="{child}"/>',
                f'<origin xyz="0 0 {draw(NUM)}" rpy="{draw(NUM)} 0 0"/>']
        if draw(st.booleans()):
            body.append(f'<axis xyz="{draw(st.sampled_from(["0 1 0", "0 0 0", "1", "a b c", "nan 0 0"]))}"/>')
        if draw(st.booleans()):
            body.append(f'<limit lower="{draw(NUM)}" upper="{draw(NUM)}" effort="{draw(NUM)}" velocity="1"/>')
        if draw(st.booleans()):
            body.append(f'<dynamics damping="{draw(NUM)}" friction="{draw(NUM)}"/>')
        if draw(st.integers(0, 9)) == 0:
            body.append(f'<mimic joint="j{draw(st.integers(0, n))}"/>')
        out.append(f'<joint name="j{k}" type="{jt}">' + "".join(body) + "</joint>")
    out.append("</robot>")
    text = "\n".join(out)
    if draw(st.integers(0, 4)) == 0:  # malformed XML
        text = text[: draw(st.integers(0, len(text)))]
    return text


def check_urdf(text, floating):
    tmp = _tmpdir()
    try:
        path = tmp / "robot.urdf"
        path.write_text(text)
        got = outcome(lambda: load_urdf(path, floating_base=floating))
        if isinstance(got, Exception):
            assert str(path) in str(got) or "URDF" in str(got), str(got)
        else:
            assert isinstance(got, pl.Model)
            for p in got.parts:  # an accepted link is physical
                assert p.mass > 0 and np.all(np.isfinite(p.inertia)) and np.all(np.linalg.eigvalsh(p.inertia) >= 0)
            outcome(lambda: pl.assemble(got))  # assembling is a documented error at worst
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


_NAN_SPHERE = """<?xml version="1.0"?>
<robot name="r">
<link name="l0">
<inertial><origin xyz="0 0 -0.1" rpy="0 0 0"/><mass value="1.0"/><inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.001"/></inertial>
<collision><geometry><sphere radius="nan"/></geometry></collision>
</link>
</robot>"""


@FAST
@given(urdf_texts(), st.booleans())
@example(_NAN_SPHERE, True)  # the 10,000-example run found it: a NaN foot radius raised LinAlgError
def test_urdf_files(text, floating):
    check_urdf(text, floating)


@pytest.mark.slow
@SLOW
@given(urdf_texts(), st.booleans())
def test_urdf_files_10k(text, floating):
    check_urdf(text, floating)


# ------------------------------------------------------------------------------------------
# study files (parse and assemble; nothing runs)
# ------------------------------------------------------------------------------------------
def _study_value():
    return st.one_of(st.sampled_from([None, "", "x", 0, -1, 1, 1.5, [], {}, [1], [1, 2], [1, "a"], {"range": [1]},
                                      {"range": ["a", 2]}, {"log": [0, 1]}, {"log": [-1, 1]}, {"choices": []},
                                      {"choices": [1, 2]}, {"fixed": 3}, {"range": [10, 1]}, {"range": [1, 2], "log": [1, 2]},
                                      "r.part('lower').position[-1, 0]", "r.", "(", "1 +", True]),
                     st.floats(allow_nan=True, allow_infinity=True))


@st.composite
def study_specs(draw):
    spec = yaml.safe_load((EXAMPLES / "pendulum_study.yaml").read_text())
    spec["model"] = str(EXAMPLES / "double_pendulum.yaml")
    spec.pop("store", None)
    for _ in range(draw(st.integers(0, 3))):
        what = draw(st.sampled_from(["space", "outputs", "simulate", "design", "top", "drop", "model"]))
        if what == "space":
            spec.setdefault("space", {})
            if not isinstance(spec["space"], dict):
                spec["space"] = {}
            spec["space"][draw(st.sampled_from(["spring.stiffness", "spring.damping", "nope", "upper.mass", ""]))] = draw(_study_value())
        elif what == "outputs":
            spec["outputs"] = draw(st.one_of(st.just({}), st.dictionaries(st.sampled_from(["a", "key", "status", "x"]), _study_value(), max_size=2)))
        elif what == "simulate":
            spec["simulate"] = draw(st.one_of(st.just({}), st.dictionaries(st.sampled_from(["t_end", "dt_output", "bogus"]), _study_value(), max_size=2)))
        elif what == "design":
            spec["design"] = draw(st.one_of(_study_value(), st.fixed_dictionaries(
                {"kind": st.sampled_from(["lhs", "grid", "sobol", "table", "x"]), "n": _study_value()})))
        elif what == "top":
            spec[draw(st.sampled_from(["executor", "workers", "batch_size", "lanes", "robot", "robot_args", "name", "extra"]))] = draw(_study_value())
        elif what == "drop":
            spec.pop(draw(st.sampled_from(["model", "space", "outputs", "simulate", "design"])), None)
        else:
            spec["model"] = draw(st.sampled_from(["missing.yaml", "", str(EXAMPLES / "four_bar.yaml"), str(EXAMPLES)]))
    return spec


def check_study(spec):
    from proleg.study.studyfile import load_study_file

    tmp = _tmpdir()
    try:
        path = tmp / "s.study.yaml"
        path.write_text(yaml.safe_dump(spec) if not isinstance(spec, str) else spec)
        got = outcome(lambda: load_study_file(path))
        if not isinstance(got, Exception):
            study, kw = got
            assert isinstance(study, pl.study.Study) and "design" in kw
            outcome(lambda: study.design(kw["design"], kw["n"], kw["seed"]))  # the design is made or refused cleanly
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def _huge_design(kind):
    spec = yaml.safe_load((EXAMPLES / "pendulum_study.yaml").read_text())
    spec["model"] = str(EXAMPLES / "double_pendulum.yaml")
    spec.pop("store", None)
    spec["design"] = {"kind": kind, "n": 2.82834477918851e16}
    return spec


@FAST
@given(study_specs())
# the 10,000-example run found these: numpy raised MemoryError allocating 201 PiB for the design
@example(_huge_design("lhs"))
@example(_huge_design("grid"))
def test_study_files(spec):
    check_study(spec)


@FAST
@given(st.text(max_size=200))
def test_study_file_text(text):
    check_study(text)


@pytest.mark.slow
@SLOW
@given(st.one_of(study_specs(), st.text(max_size=300)))
def test_study_files_10k(spec):
    check_study(spec)


# ------------------------------------------------------------------------------------------
# CLI argument lists
# ------------------------------------------------------------------------------------------
class _Reached(Exception):
    """The stub of a simulation or a study run was called: the arguments were accepted."""


def _scenario_stub(out_dir):
    raise _Reached()


@pytest.fixture(scope="module")
def cli_env():
    yield from make_cli_env()


def make_cli_env():
    """typer's runner over proleg's app, with simulate, Study.run and the scenarios stubbed."""
    from typer.testing import CliRunner

    from proleg.cli import main as cli

    mp = pytest.MonkeyPatch()

    def stub(*a, **k):
        raise _Reached()

    mp.setattr(pl, "simulate", stub)
    mp.setattr(pl.study.Study, "run", stub)
    mp.setattr(cli, "SCENARIOS", {k: (__name__, "_scenario_stub", v[2]) for k, v in cli.SCENARIOS.items()})
    tmp = _tmpdir()
    (tmp / "bad.yaml").write_text("name: x\nparts: [1\n")
    (tmp / "bad.urdf").write_text("<robot><link name='a'/><joint")
    (tmp / "bad.parquet").write_bytes(b"PAR1garbage")
    (tmp / "store").mkdir()
    (tmp / "store" / "study.json").write_text("{not json")
    (tmp / "data.csv").write_text("t,x\n0,1\n1,nan\n")
    yield CliRunner(), cli.app, tmp
    mp.undo()
    shutil.rmtree(tmp, ignore_errors=True)


COMMANDS = [["info"], ["simulate"], ["run"], ["view"], ["prbm"], ["study", "run"], ["study", "status"], ["study", "report"],
            ["identify", "hysteresis"], ["identify", "drop"], ["identify", "battery"], ["identify", "fit"], ["identify", "modal"],
            ["validate"], [], ["--version"], ["--help"], ["nonsense"]]
OPTIONS = ["--json", "--t-end", "--dt-output", "--out", "--rtol", "--fixed-base", "--model", "--no-open", "--executor",
           "--workers", "--lanes", "--store", "--scheduler", "--no-report", "--out-dir", "--help", "-x", "--"]


def cli_args(tmp):
    files = [str(EXAMPLES / "double_pendulum.yaml"), str(EXAMPLES / "pendulum_study.yaml"), str(tmp / "bad.yaml"),
             str(tmp / "bad.urdf"), str(tmp / "bad.parquet"), str(tmp / "store"), str(tmp / "data.csv"), str(tmp / "missing.yaml"),
             str(tmp), str(Path(__file__).parent / "data" / "two_link.urdf")]
    words = st.one_of(st.sampled_from(files + OPTIONS + ["0", "-1", "nan", "1e400", "abc", "", "hyq-drop", "list", "1 kN", "5 mm"]),
                      st.text(max_size=8))
    return st.tuples(st.sampled_from(COMMANDS), st.lists(words, max_size=6)).map(lambda t: [*t[0], *t[1]])


def check_cli(cli_env, args):
    runner, app, tmp = cli_env
    out = tmp / "out"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = runner.invoke(app, args, catch_exceptions=True)
    exc = res.exception
    assert exc is None or isinstance(exc, (SystemExit, _Reached)), f"{args}: raw {type(exc).__name__}: {exc}"
    if res.exit_code not in (0, 1, 2) and not isinstance(exc, _Reached):
        pytest.fail(f"{args}: exit code {res.exit_code}\n{res.output[-2000:]}")
    assert "Traceback" not in res.output, f"{args}:\n{res.output[-2000:]}"
    assert not [p for p in tmp.rglob(".tmp*")], "a half-written file was left"
    shutil.rmtree(out, ignore_errors=True)


def test_cli_arguments(cli_env):
    @FAST
    @given(cli_args(cli_env[2]))
    def run(args):
        check_cli(cli_env, args)

    run()


@pytest.mark.slow
def test_cli_arguments_10k(cli_env):
    @SLOW
    @given(cli_args(cli_env[2]))
    def run(args):
        check_cli(cli_env, args)

    run()
