"""The YAML model file's schema (pydantic): one model class per file section and element type.

:class:`ModelFile` is the whole file; ``PartSpec``, ``MarkerSpec``, the joint specs (tagged by
``type``: ``JointSpec``) and the force-element specs (``ForceElementSpec``) mirror the keyword
arguments of the Python builders, all values SI. ``_JOINT_SPECS`` / ``_FORCE_SPECS`` map each
``type`` to its spec and ``_JOINT_CLASSES`` to the joint class it builds. The file format and
its reading are described in :mod:`proleg.io.modelfile`, which imports everything here back
(the names stay importable from there).
"""

from __future__ import annotations

from typing import Annotated, Any, Literal

import numpy as np
from pydantic import BaseModel, BeforeValidator, ConfigDict, Field, model_validator

from ..model import joints as _j

SECTIONS = ("parts", "markers", "joints", "forces", "couplers")


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


RPY_HELP = ("[roll, pitch, yaw] [deg]: rotations about the fixed ground axes x, then y, then z "
            "(URDF's rpy, Adams' space-fixed 123), R = Rz(yaw) Ry(pitch) Rx(roll); instead of orientation")


class _Oriented(_Spec):
    """An orientation given as a matrix or quaternion (``orientation``) or as roll-pitch-yaw in
    degrees (``rpy_deg``, convention in :data:`RPY_HELP`), not both."""

    orientation: Orientation | None = Field(None, description="3x3 rotation matrix or unit quaternion (scalar first)")
    rpy_deg: Vec3 | None = Field(None, description=RPY_HELP)

    @model_validator(mode="after")
    def _one_orientation(self):
        if self.orientation is not None and self.rpy_deg is not None:
            raise ValueError("give either orientation (matrix or quaternion) or rpy_deg, not both")
        return self

    def rotation(self):
        """The orientation as given (matrix, quaternion or None), or the matrix of ``rpy_deg``."""
        if self.rpy_deg is not None:
            from ..spatial.rotation import matrix_from_rpy_deg

            return matrix_from_rpy_deg(self.rpy_deg)
        return self.orientation


class PartSpec(_Oriented):
    """``Model.add_part``: a rigid body."""

    name: str = Field(description="part name, unique")
    mass: float = Field(gt=0, description="[kg], > 0")
    inertia: Inertia = Field(description="[Ixx, Iyy, Izz] or 3x3 [kg m^2], about the COM in part axes")
    position: Vec3 = Field(description="COM position [m] in ground")
    velocity: Vec3 | None = Field(None, description="initial COM velocity [m/s] in ground")
    angular_velocity: Vec3 | None = Field(None, description="initial angular velocity [rad/s] in ground")


class MarkerSpec(_Oriented):
    """``Model.add_marker``: a frame fixed to a part, given at its ground pose."""

    name: str = Field(description="marker name, unique")
    part: str = Field(description="name of the part carrying the marker (or ground)")
    position: Vec3 = Field(description="[m] in ground at the modelled pose")


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


class JointStopSpec(_Spec):
    type: Literal["joint_stop"]
    name: str = Field(description="force element name, unique")
    joint: str = Field(description="the joint whose coordinate is limited")
    lower: float | None = Field(None, description="[m or rad] lower limit of the coordinate")
    upper: float | None = Field(None, description="[m or rad] upper limit of the coordinate")
    stiffness: float = Field(1e5, gt=0, description="[N/m^e or N m/rad^e], > 0")
    exponent: float = Field(1.0, ge=1, description="[-], >= 1")
    damping: float = Field(0.0, ge=0, description="[N s/m or N m s/rad], >= 0")
    penetration: float = Field(1e-3, gt=0, description="[m or rad] depth of full damping, > 0")


class JointFrictionSpec(_Spec):
    type: Literal["joint_friction"]
    name: str = Field(description="force element name, unique")
    joint: str = Field(description="the joint with friction")
    friction: float = Field(0.0, ge=0, description="[N m or N] Coulomb torque or force, >= 0")
    damping: float = Field(0.0, ge=0, description="[N m s/rad or N s/m] viscous, >= 0")
    slip_rate: float = Field(0.01, gt=0, description="[rad/s or m/s] smoothing rate, > 0")


class CouplerSpec(_Spec):
    """A gear constraint θ₁ = r θ₂ between two joints' coordinates (Adams COUPLER)."""

    name: str = Field(description="coupler name, unique")
    joint_1: str = Field(description="the first (fast, for r > 1) joint")
    joint_2: str = Field(description="the second joint")
    ratio: float = Field(description="r in q1 = r q2, non-zero")
    dof: Literal["rotation", "translation"] | None = Field(None, description="needed for cylindrical joints")


ForceElementSpec = Annotated[
    SpringDamperSpec | RotationalSpringDamperSpec | BushingSpec | ForceSpec | TorqueSpec | JointStopSpec | JointFrictionSpec,
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
    couplers: list[CouplerSpec] = Field(default_factory=list, description="gear constraints between joints")
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
    "joint_stop": JointStopSpec,
    "joint_friction": JointFrictionSpec,
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
