"""Model errors are raised at build or assembly time as ModelError, naming the element."""

import numpy as np
import pytest

import proleg as pl


@pytest.fixture
def model():
    m = pl.Model("err")
    m.add_part("body", mass=1.0, inertia=(0.01, 0.02, 0.025), position=(0, 0, 0))
    return m


def _markers(model):
    body = model.part("body")
    mi = model.add_marker(body, "m_body", position=(0, 0, 0))
    mj = model.add_marker(model.ground, "m_ground", position=(0, 0, 1))
    return mi, mj


# -- parts ---------------------------------------------------------------------------------------
@pytest.mark.parametrize("mass", [0.0, -1.0])
def test_non_positive_mass(model, mass):
    with pytest.raises(pl.ModelError, match="'thigh'.*mass"):
        model.add_part("thigh", mass=mass, inertia=(1, 1, 1), position=(0, 0, 0))


@pytest.mark.parametrize(
    "inertia, why",
    [
        ([[1.0, 0.1, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]], "not symmetric"),
        ([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, -1.0]], "not positive definite"),
        ((1.0, 0.0, 1.0), "not positive definite"),
        ((1.0, 1.0, 3.0), "triangle"),
        ([[1.0, 2.0, 0.0], [2.0, 1.0, 0.0], [0.0, 0.0, 1.0]], "not positive definite"),
    ],
)
def test_bad_inertia(model, inertia, why):
    with pytest.raises(pl.ModelError, match=f"'shank'.*{why}"):
        model.add_part("shank", mass=1.0, inertia=inertia, position=(0, 0, 0))


def test_inertia_triangle_inequality_full_tensor(model):
    """Principal moments (1, 1, 3) rotated into a full tensor still violate I3 ≤ I1 + I2."""
    from scipy.spatial.transform import Rotation

    R = Rotation.from_rotvec([0.3, 0.2, -0.4]).as_matrix()
    J = R @ np.diag([1.0, 1.0, 3.0]) @ R.T
    with pytest.raises(pl.ModelError, match="'foot'.*triangle"):
        model.add_part("foot", mass=1.0, inertia=J, position=(0, 0, 0))


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_position(model, bad):
    with pytest.raises(pl.ModelError, match="'hip'.*position"):
        model.add_part("hip", mass=1.0, inertia=(1, 1, 1), position=(0, bad, 0))


def test_non_finite_mass_and_velocity(model):
    with pytest.raises(pl.ModelError, match="'hip'"):
        model.add_part("hip", mass=np.nan, inertia=(1, 1, 1), position=(0, 0, 0))
    with pytest.raises(pl.ModelError, match="'knee'.*velocity"):
        model.add_part("knee", mass=1.0, inertia=(1, 1, 1), position=(0, 0, 0), velocity=(np.inf, 0, 0))


def test_duplicate_names(model):
    with pytest.raises(pl.ModelError, match="'body'"):
        model.add_part("body", mass=1.0, inertia=(1, 1, 1), position=(1, 0, 0))
    _markers(model)
    with pytest.raises(pl.ModelError, match="'m_body'"):
        model.add_marker(model.part("body"), "m_body", position=(0, 0, 0))
    model.add_joint(pl.Spherical("ball", model.part("body"), model.ground, at=(0, 0, 0)))
    with pytest.raises(pl.ModelError, match="'ball'"):
        model.add_joint(pl.Spherical("ball", model.part("body"), model.ground, at=(0, 0, 0)))
    mi, mj = model.marker("m_body"), model.marker("m_ground")
    model.add_force(pl.SpringDamper("spring", mi, mj, stiffness=1.0))
    with pytest.raises(pl.ModelError, match="'spring'"):
        model.add_force(pl.SpringDamper("spring", mi, mj, stiffness=2.0))


# -- markers and joints --------------------------------------------------------------------------
def test_marker_on_foreign_part(model):
    other = pl.Model("other")
    stranger = other.add_part("stranger", mass=1.0, inertia=(1, 1, 1), position=(0, 0, 0))
    with pytest.raises(pl.ModelError, match="'stranger'"):
        model.add_marker(stranger, "tip", position=(0, 0, 0))
    with pytest.raises(pl.ModelError, match="'stranger'"):
        model.add_joint(pl.Revolute("pin", stranger, model.ground, at=(0, 0, 0), axis=(0, 1, 0)))


def test_joint_between_part_and_itself(model):
    body = model.part("body")
    with pytest.raises(pl.ModelError, match="'elbow'.*itself"):
        pl.Revolute("elbow", body, body, at=(0, 0, 0), axis=(0, 1, 0))
    mi, _ = _markers(model)
    mk = model.add_marker(body, "m_body2", position=(0, 0, 0.1))
    with pytest.raises(pl.ModelError, match="'elbow'.*itself"):
        pl.Revolute("elbow", mi, mk)


@pytest.mark.parametrize("cls", [pl.Revolute, pl.Prismatic, pl.Cylindrical, pl.Planar])
def test_zero_length_axis(model, cls):
    with pytest.raises(pl.ModelError, match="'wrist'.*axis"):
        cls("wrist", model.part("body"), model.ground, at=(0, 0, 0), axis=(0, 0, 0))


def test_non_finite_joint_location(model):
    with pytest.raises(pl.ModelError, match="'wrist'"):
        pl.Revolute("wrist", model.part("body"), model.ground, at=(0, np.nan, 0), axis=(0, 1, 0))


# -- force elements ------------------------------------------------------------------------------
@pytest.mark.parametrize("what", ["stiffness", "damping"])
@pytest.mark.parametrize("value", [np.ones(3), np.ones((3, 3)), np.ones(7), np.ones((6, 5))])
def test_bushing_wrong_shape(model, what, value):
    mi, mj = _markers(model)
    kw = {"stiffness": np.ones(6), what: value}
    with pytest.raises(pl.ModelError, match=f"'knee_pin' {what}.*shape"):
        pl.Bushing("knee_pin", mi, mj, **kw)


@pytest.mark.parametrize("what", ["stiffness", "damping"])
@pytest.mark.parametrize("full", [False, True])
def test_bushing_negative_diagonal(model, what, full):
    mi, mj = _markers(model)
    diag = np.array([1e4, 1e4, -1e4, 10.0, 10.0, 10.0])
    value = np.diag(diag) if full else diag
    kw = {"stiffness": np.ones(6), what: value}
    with pytest.raises(pl.ModelError, match=f"'knee_pin' {what}.*negative"):
        pl.Bushing("knee_pin", mi, mj, **kw)


@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_non_finite_stiffness(model, bad):
    mi, mj = _markers(model)
    with pytest.raises(pl.ModelError, match="'knee_pin' stiffness"):
        pl.Bushing("knee_pin", mi, mj, stiffness=[1.0, 1.0, bad, 1.0, 1.0, 1.0])
    with pytest.raises(pl.ModelError, match="'spring' stiffness"):
        pl.SpringDamper("spring", mi, mj, stiffness=bad)
    with pytest.raises(pl.ModelError, match="'spring' damping"):
        pl.SpringDamper("spring", mi, mj, stiffness=1.0, damping=bad)


def test_negative_spring_stiffness(model):
    mi, mj = _markers(model)
    with pytest.raises(pl.ModelError, match="'spring' stiffness"):
        pl.SpringDamper("spring", mi, mj, stiffness=-5.0)


def test_force_with_non_finite_value(model):
    with pytest.raises(pl.ModelError, match="'push'"):
        pl.Force("push", model.part("body"), value=(0.0, np.nan, 0.0))


# -- analyses ------------------------------------------------------------------------------------
def test_equilibrium_of_unconnected_part(model):
    """'loose' has neither a joint nor a force element: no static equilibrium exists."""
    body = model.part("body")
    model.add_joint(pl.Revolute("pin", body, model.ground, at=(0, 0, 0.1), axis=(0, 1, 0)))
    model.add_part("loose", mass=1.0, inertia=(1, 1, 1), position=(2, 0, 0))
    with pytest.warns(pl.ProlegWarning, match=r"\['loose'\] are attached to nothing"):
        system = pl.assemble(model)
    with pytest.raises(pl.ModelError, match="'loose'"):
        pl.solve_equilibrium(system)
