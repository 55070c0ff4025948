"""Model files (proleg.io.modelfile): the examples load, a dump loads back to the same model,
and every kind of mistake raises a ModelError naming the file, element and field."""

from pathlib import Path

import numpy as np
import pytest

from proleg.errors import ModelError
from proleg.io.modelfile import dump_model, load_model, load_model_file, model_from_dict, model_to_dict
from proleg.model.forces import Bushing, Force, RotationalSpringDamper, SpringDamper, Torque
from proleg.model.joints import Cylindrical, Fixed, Planar, Prismatic, Revolute, Screw, Spherical, Universal

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
DOUBLE_PENDULUM = EXAMPLES / "double_pendulum.yaml"
FOUR_BAR = EXAMPLES / "four_bar.yaml"
# Round-off of marker poses (rotations, 3×3 products through BLAS, sin/cos of libm): 64 eps ×
# 1 m, the size of these models (1.4e-14 m; ~30 ulp of their 0.1 to 2 m coordinates), and 64 eps
# on unit vectors. A misplaced marker or a swapped axis is off by ≥ 1e-3.
TOL = 64 * np.finfo(float).eps


def _allclose_tree(a, b, atol=1e-12):
    """Compare two model-file dicts: same keys and strings, numbers to ``atol`` (marker poses are
    stored relative to their part, so a round trip reproduces them to round-off only)."""
    if isinstance(a, dict):
        assert isinstance(b, dict) and list(a) == list(b), (a, b)
        for k in a:
            _allclose_tree(a[k], b[k], atol)
    elif isinstance(a, list) and a and isinstance(a[0], dict):
        assert len(a) == len(b)
        for x, y in zip(a, b, strict=True):
            _allclose_tree(x, y, atol)
    elif isinstance(a, str) or a is None:
        assert a == b
    else:
        np.testing.assert_allclose(np.asarray(a, float), np.asarray(b, float), rtol=0, atol=atol)


# -- examples ---------------------------------------------------------------------------------
def test_double_pendulum_example():
    model, sim = load_model_file(DOUBLE_PENDULUM)
    assert model.name == "double_pendulum"
    assert [p.name for p in model.parts] == ["upper", "lower"]
    assert [p.mass for p in model.parts] == [1.0, 1.0]
    # exact: numbers parsed from the file, no arithmetic
    np.testing.assert_array_equal(model.part("lower").inertia, np.diag([0.01, 0.09, 0.09]))
    np.testing.assert_array_equal(model.gravity, [0, 0, -9.81])
    assert [type(j) for j in model.joints] == [Revolute, Revolute]
    elbow = model.joint("elbow")
    np.testing.assert_allclose(elbow.marker_i.position, [1, 0, 0], atol=TOL)
    np.testing.assert_allclose(elbow.marker_j.position, [1, 0, 0], atol=TOL)
    spring = model.force("spring")
    assert isinstance(spring, SpringDamper)
    assert (spring.stiffness, spring.damping, spring.free_length) == (50.0, 0.5, 1.0)
    # The spring starts at its free length: tip (2, 0, 0) to anchor (2, 0, -1).
    assert np.linalg.norm(spring.i.position - spring.j.position) == pytest.approx(1.0, abs=TOL)
    assert sim == {"t_end": 2.0, "dt_output": 0.001}
    assert load_model(DOUBLE_PENDULUM).name == "double_pendulum"


def test_four_bar_example_closes_at_modelled_pose():
    model = load_model(FOUR_BAR)
    assert len(model.parts) == 3 and len(model.joints) == 4
    assert all(isinstance(j, Revolute) for j in model.joints)
    for j in model.joints:
        np.testing.assert_allclose(j.axis, [0, 1, 0])
    at = {j.name: j.at for j in model.joints}
    links = {"crank": ("A", "B", 0.1), "coupler": ("B", "C", 0.35), "rocker": ("D", "C", 0.3)}
    # Link lengths from the joint positions, ground link included, to round-off (TOL).
    assert np.linalg.norm(at["D"] - at["A"]) == pytest.approx(0.4, abs=TOL)
    for name, (a, b, length) in links.items():
        part = model.part(name)
        assert np.linalg.norm(at[b] - at[a]) == pytest.approx(length, abs=TOL)
        assert part.mass == pytest.approx(1.0 * length, rel=TOL)  # 1 kg/m
        np.testing.assert_allclose(part.position, (at[a] + at[b]) / 2, atol=TOL)  # COM at midpoint
        # Slender rod about the COM, part x along the link: Iyy = Izz = m L^2 / 12.
        np.testing.assert_allclose(np.diag(part.inertia)[1:], part.mass * length**2 / 12, rtol=1e-12)
        # Both joint markers sit on the part's x axis at ±L/2: the orientation matches the link.
        local = sorted(
            (m.local_position for m in model.markers if m.part is part and m.name[-2:] in (".I", ".J")),
            key=lambda p: p[0],
        )
        np.testing.assert_allclose(local, [[-length / 2, 0, 0], [length / 2, 0, 0]], atol=TOL)
    # Each pin: the I and J markers coincide and their z axes are both along the pin.
    for j in model.joints:
        np.testing.assert_allclose(j.marker_i.position, j.marker_j.position, atol=TOL)
        np.testing.assert_allclose(j.marker_i.orientation[:, 2], [0, 1, 0], atol=TOL)
        np.testing.assert_allclose(j.marker_j.orientation[:, 2], [0, 1, 0], atol=TOL)


# -- every element type, and the round trip -------------------------------------------------------
def _all_elements() -> dict:
    part = lambda name, x: {"name": name, "mass": 1.0, "inertia": [0.1, 0.2, 0.25], "position": [x, 0, 0]}  # noqa: E731
    return {
        "name": "zoo",
        "gravity": [0, 0, -9.81],
        "parts": [
            part("a", 1.0),
            {**part("b", 2.0), "orientation": [np.cos(0.15), 0, 0, np.sin(0.15)], "velocity": [0.1, 0, 0]},
            {**part("c", 3.0), "inertia": [[0.1, 0.01, 0], [0.01, 0.2, 0], [0, 0, 0.25]], "angular_velocity": [0, 0, 1]},
            part("d", 4.0),
            part("e", 5.0),
            part("f", 6.0),
            part("g", 7.0),
            part("h", 8.0),
        ],
        "markers": [
            {"name": "mg", "part": "ground", "position": [9, 0, 0]},
            {"name": "mh", "part": "h", "position": [9, 0, 0], "orientation": [[0, -1, 0], [1, 0, 0], [0, 0, 1]]},
            {"name": "mb", "part": "b", "position": [2, 0.5, 0]},
        ],
        "joints": [
            {"type": "revolute", "name": "ja", "i": "a", "j": "ground", "at": [1, 0, 0], "axis": [0, 0, 1]},
            {"type": "translational", "name": "jb", "i": "b", "j": "ground", "at": [2, 0, 0], "axis": [1, 0, 0]},
            {"type": "cylindrical", "name": "jc", "i": "c", "j": "ground", "at": [3, 0, 0], "axis": [0, 1, 0]},
            {"type": "screw", "name": "jd", "i": "d", "j": "ground", "at": [4, 0, 0], "axis": [0, 0, 1], "pitch": 0.01},
            {"type": "planar", "name": "je", "i": "e", "j": "ground", "at": [5, 0, 0], "axis": [0, 0, 1]},
            {"type": "spherical", "name": "jf", "i": "f", "j": "ground", "at": [6, 0, 0]},
            {"type": "universal", "name": "jg", "i": "g", "j": "ground", "at": [7, 0, 0], "axis_i": [1, 0, 0], "axis_j": [0, 1, 0]},
            {"type": "fixed", "name": "jh", "i": "mh", "j": "mg"},
        ],
        "forces": [
            {"type": "spring_damper", "name": "s", "i": "mb", "j": "mg", "stiffness": 10.0, "preload": 2.0},
            {"type": "rotational_spring_damper", "name": "rs", "joint": "ja", "stiffness": 3.0, "damping": 0.1},
            {"type": "rotational_spring_damper", "name": "rs2", "i": "jc.I", "j": "jc.J", "free_angle": 0.2},
            {"type": "bushing", "name": "bu", "i": "mb", "j": "mg", "stiffness": [1e5, 1e5, 1e5, 10, 10, 10],
             "damping": (np.eye(6) + 0.01 * np.ones((6, 6))).tolist(), "preload": [0, 0, 1, 0, 0, 0], "free": [0, 0, 0, 0, 0, 0.1]},
            {"type": "force", "name": "push", "part": "a", "value": [0, 0, -5], "at": [1.2, 0, 0]},
            {"type": "torque", "name": "twist", "part": "mb", "value": [0, 0, 0.5]},
        ],
        "simulate": {"t_end": 1.0},
    }


def test_every_element_type_builds():
    model = model_from_dict(_all_elements())
    kinds = [type(j) for j in model.joints]
    assert kinds == [Revolute, Prismatic, Cylindrical, Screw, Planar, Spherical, Universal, Fixed]
    assert model.joint("jd").pitch == 0.01
    assert [type(f) for f in model.forces] == [SpringDamper, RotationalSpringDamper, RotationalSpringDamper, Bushing, Force, Torque]
    assert model.force("rs").i is model.joint("ja").marker_i
    bu = model.force("bu")
    np.testing.assert_array_equal(bu.stiffness, np.diag([1e5, 1e5, 1e5, 10, 10, 10]))
    assert bu.damping[0, 1] == 0.01
    b = model.part("b")
    np.testing.assert_allclose(b.orientation[:, 0], [np.cos(0.3), np.sin(0.3), 0], atol=TOL)  # 0.3 rad about z
    np.testing.assert_array_equal(b.velocity, [0.1, 0, 0])
    assert model.force("twist").marker is model.marker("mb")


@pytest.mark.parametrize("source", ["zoo", DOUBLE_PENDULUM, FOUR_BAR])
def test_round_trip(tmp_path, source):
    if source == "zoo":
        model, sim = model_from_dict(_all_elements()), {"t_end": 1.0}
    else:
        model, sim = load_model_file(source)
    path = dump_model(model, tmp_path / "model.yaml", simulate=sim)
    again, sim2 = load_model_file(path)
    assert sim2 == sim
    _allclose_tree(model_to_dict(model), model_to_dict(again))
    # Joint-created markers are not written; they are re-created with the same names.
    assert [m.name for m in again.markers] == [m.name for m in model.markers]


def test_dump_refuses_function_loads(tmp_path):
    model = model_from_dict(_all_elements())
    model.add_force(Force("gust", model.part("a"), lambda t: (0.0, 0.0, t)))
    with pytest.raises(ModelError, match="Force 'gust' has a function value"):
        dump_model(model, tmp_path / "x.yaml")


# -- errors ---------------------------------------------------------------------------------------
ERRORS = [
    # (what is replaced, by what, the message must match)
    ("axis: [0, 1, 0]}\n  - {type: revolute, name: elbow", "axis: [0, 1, 0}\n  - {type: revolute, name: elbow",
     r"model\.yaml:16:\d+: YAML syntax error"),
    ("at: [1, 0, 0], axis", "at: [1, 0, 0], axes",
     r"model\.yaml:17: joints\[1\] 'elbow' field 'axes': unknown field 'axes'\. Did you mean 'axis'\?"),
    ("name: upper, mass: 1.0", "name: upper, mass: heavy",
     r"model\.yaml:10: parts\[0\] 'upper' field 'mass': .*valid number.*'heavy'.*\[kg\]"),
    ("at: [1, 0, 0], axis: [0, 1, 0]", "at: [1, 0, 0], axis: [0, 1]",
     r"joints\[1\] 'elbow' field 'axis': expected a 3-list .* got shape \(2,\)"),
    ("i: upper, j: lower", "i: upper, j: lowr",
     r"joints\[1\] 'elbow' field 'j': no part or marker named 'lowr' .*Did you mean 'lower'\?"),
    ("i: tip, j: anchor", "i: tip, j: ancor",
     r"model\.yaml:19: forces\[0\] 'spring' field 'j': no marker named 'ancor'.*Did you mean 'anchor'\?"),
    ("{name: anchor, part: ground", "{name: anchor, part: grund",
     r"markers\[1\] 'anchor' field 'part': no part named 'grund'.*Did you mean 'ground'\?"),
    ("inertia: [0.01, 0.09, 0.09], position: [1.5", "inertia: [0.01, 0.09, 0.01], position: [1.5",
     r"model\.yaml:11: parts\[1\] 'lower' field 'inertia': Part 'lower' inertia violates the triangle inequality"),
    ("at: [1, 0, 0], axis: [0, 1, 0]", "at: [1, 0, 0], axis: [0, 0, 0]",
     r"joints\[1\] 'elbow' field 'axis': Revolute 'elbow' axis has zero length"),
    ("type: revolute, name: elbow", "type: revolut, name: elbow",
     r"joints\[1\] 'elbow': unknown joint type 'revolut'\. Did you mean 'revolute'\?"),
    ("name: lower, mass: 1.0, ", "name: lower, ",
     r"parts\[1\] 'lower' field 'mass': required field 'mass' is missing\. Add mass:"),
    ("name: upper, mass: 1.0", "name: upper, mass: 1.0, mass: 2.0",
     r"parts\[0\] 'upper' field 'mass': key 'mass' appears twice"),
    ("name: elbow", "name: shoulder",
     r"joints\[1\] 'shoulder' field 'name': Joint 'shoulder' is defined twice"),
    ("units: SI", "units: mm", r"field 'units': units 'mm' is not supported"),
    ("stiffness: 50.0", "stiffness: -50.0",
     r"forces\[0\] 'spring' field 'stiffness': .*greater than or equal to 0.*\[N/m\]"),
    ("stiffness: 50.0", "stiffness: .nan", r"forces\[0\] 'spring' field 'stiffness': .*finite"),
    ("at: [1, 0, 0], axis: [0, 1, 0]", "axis: [0, 1, 0]",
     r"joints\[1\] 'elbow' field 'i': 'upper' is a part; to connect parts give at"),
    ("at: [1, 0, 0], axis: [0, 1, 0]", "at: [1, 0, 0]",
     r"joints\[1\] 'elbow' field 'axis': a revolute joint between parts needs axis"),
    ("t_end: 2.0", "t_end: -2.0", r"simulate field 't_end': .*greater than 0"),
    ("name: upper,", "name: 12,", r"parts\[0\] field 'name': expected a name"),
]


@pytest.mark.parametrize(("old", "new", "match"), ERRORS, ids=[m[:40] for _, _, m in ERRORS])
def test_errors_name_file_element_and_field(tmp_path, old, new, match):
    text = DOUBLE_PENDULUM.read_text()
    assert old in text
    path = tmp_path / "model.yaml"
    path.write_text(text.replace(old, new, 1))
    with pytest.raises(ModelError, match=match):
        load_model(path)


def test_several_problems_are_listed_together(tmp_path):
    path = tmp_path / "model.yaml"
    path.write_text(DOUBLE_PENDULUM.read_text().replace("mass: 1.0", "mass: -1.0"))
    with pytest.raises(ModelError, match="2 problems") as info:
        load_model(path)
    assert "parts[0] 'upper' field 'mass'" in str(info.value)
    assert "parts[1] 'lower' field 'mass'" in str(info.value)


def test_dict_errors_name_the_source():
    d = _all_elements()
    d["forces"][1]["joint"] = "jb"  # prismatic: no rotation to put a torsion spring on
    with pytest.raises(ModelError, match=r"<zoo>: forces\[1\] 'rs': .*joint 'jb' has no rotational"):
        model_from_dict(d, source="<zoo>")
    d = _all_elements()
    d["forces"][2] = {"type": "rotational_spring_damper", "name": "rs2", "i": "jc.I"}
    with pytest.raises(ModelError, match=r"forces\[2\] 'rs2': give joint: .* or both i and j"):
        model_from_dict(d)
    d = _all_elements()
    d["forces"][3]["stiffness"] = [1, 2, 3]
    with pytest.raises(ModelError, match=r"forces\[3\] 'bu' field 'stiffness': expected a 6-list or a 6x6 list"):
        model_from_dict(d)
    with pytest.raises(ModelError, match="expected a mapping at the top level"):
        model_from_dict([1, 2])


def test_missing_and_empty_files(tmp_path):
    with pytest.raises(ModelError, match="does not exist"):
        load_model(tmp_path / "nope.yaml")
    (tmp_path / "empty.yaml").write_text("# nothing\n")
    with pytest.raises(ModelError, match="empty.yaml: the model file is empty"):
        load_model(tmp_path / "empty.yaml")
    (tmp_path / "bare.yaml").write_text("name: bare\nparts:\njoints:\n")
    assert load_model(tmp_path / "bare.yaml").parts == []
