"""Lower-pair joints (seed 000 Table 1; Haug 1989 basic constraints; formulation note §2).

Every joint connects marker I (on the first part) to marker J (on the second part), Adams
style. Give two parts plus ``at=``/``axis=`` in ground coordinates at the modelled pose (the
markers are created for you, both with their z axis along ``axis``), or two markers.

The joint coordinate (used by motions and outputs) is the motion of I relative to J:
rotation angle ``atan2(x_I·y_J, x_I·x_J)`` about z_J and translation ``z_Jᵀ(r_I − r_J)``.
Reactions are reported on part I (``result.joint(name).force``) in ground components.
"""

from __future__ import annotations

import numpy as np

from ..errors import ModelError
from ._validate import finite_array, finite_scalar, unit_vector
from .parts import Marker, Part

# Primitive equations, as (kind, args) with axes 0 = x, 1 = y, 2 = z:
#   ("sph", k): component k of d = r_J − r_I (ground)      ("dot1", a, b): a_I · b_J
#   ("dot2", a): a_I · d                                   ("screw",): z_J·(r_I − r_J) − ℓ θ
_SPH = [("sph", 0), ("sph", 1), ("sph", 2)]
_CYL = [("dot1", 0, 2), ("dot1", 1, 2), ("dot2", 0), ("dot2", 1)]


class AbstractJoint:
    """Base class: ``name``, the two connected parts or markers, ``at``/``axis`` in ground coordinates."""

    kind = "joint"
    equations: list = []
    dof_translation = False  # has a translational joint coordinate along z
    dof_rotation = False  # has a rotational joint coordinate about z
    needs_axis = True

    def __init__(self, name: str, i, j, at=None, axis=None):
        if not isinstance(name, str) or not name:
            raise ModelError(f"{type(self).__name__} needs a non-empty name, got {name!r}.")
        self.name = name
        self.i_in, self.j_in = i, j
        for role, obj in (("first", i), ("second", j)):
            if not isinstance(obj, Part | Marker):
                raise ModelError(
                    f"{type(self).__name__} '{name}': the {role} connected element must be a Part or a Marker, got {obj!r}."
                )
        pi = i.part if isinstance(i, Marker) else i
        pj = j.part if isinstance(j, Marker) else j
        if pi is pj:
            raise ModelError(
                f"{type(self).__name__} '{name}' connects part '{pi.name}' to itself; a joint needs two different parts."
            )
        self.at = None if at is None else finite_array(f"{type(self).__name__} '{name}' at", at, (3,))
        self.axis = None if axis is None else unit_vector(f"{type(self).__name__} '{name}' axis", axis)
        if isinstance(i, Part) or isinstance(j, Part):
            if self.at is None:
                raise ModelError(
                    f"{type(self).__name__} '{name}': give at=(x, y, z) in ground coordinates when connecting parts "
                    "(or connect two markers)."
                )
            if self.needs_axis and self.axis is None and type(self).__name__ != "Universal":
                raise ModelError(f"{type(self).__name__} '{name}': give axis=(ax, ay, az) in ground coordinates.")
        self.marker_i: Marker | None = None
        self.marker_j: Marker | None = None

    @property
    def n_equations(self) -> int:
        return len(self.equations)

    def frames(self):
        """Ground-frame orientations of the I and J markers to create (z along the axis)."""
        from ..spatial.rotation import frame_from_axis

        R = frame_from_axis(self.axis if self.axis is not None else (0, 0, 1))
        return R, R

    def __repr__(self):
        return f"{type(self).__name__}({self.name!r})"


class Revolute(AbstractJoint):
    """Revolute (pin): 5 equations; rotation about the common z axis."""

    kind = "revolute"
    equations = _SPH + [("dot1", 0, 2), ("dot1", 1, 2)]
    dof_rotation = True


class Spherical(AbstractJoint):
    """Spherical (ball): 3 equations, coincident origins."""

    kind = "spherical"
    equations = _SPH
    needs_axis = False


class Cylindrical(AbstractJoint):
    """Cylindrical: 4 equations; rotation about and translation along the z axis."""

    kind = "cylindrical"
    equations = _CYL
    dof_rotation = True
    dof_translation = True


class Prismatic(AbstractJoint):
    """Prismatic (translational): 5 equations; translation along the z axis."""

    kind = "prismatic"
    equations = _CYL + [("dot1", 0, 1)]
    dof_translation = True


Translational = Prismatic


class Screw(AbstractJoint):
    """Screw: cylindrical + z_Jᵀ(r_I − r_J) = ℓ θ, with ``pitch`` [m/rev] (ℓ = pitch / 2π per radian).

    The angle θ = atan2(x_I·y_J, x_I·x_J) is single-valued: keep |θ| < π (less than half a turn
    from the modelled pose).
    """

    kind = "screw"
    equations = _CYL + [("screw",)]
    dof_rotation = True

    def __init__(self, name, i, j, at=None, axis=None, pitch=None):
        super().__init__(name, i, j, at, axis)
        if pitch is None:
            raise ModelError(f"Screw '{name}': give pitch=[m per revolution].")
        self.pitch = finite_scalar(f"Screw '{name}' pitch", pitch, unit="m/rev")
        if self.pitch == 0:
            raise ModelError(f"Screw '{name}' pitch is zero; use a Revolute joint instead.")


class Planar(AbstractJoint):
    """Planar: 3 equations; I moves in the plane through J normal to z_J."""

    kind = "planar"
    equations = [("dot1", 0, 2), ("dot1", 1, 2), ("dot2", 2)]


class Fixed(AbstractJoint):
    """Fixed (weld): 6 equations."""

    kind = "fixed"
    equations = _SPH + [("dot1", 0, 2), ("dot1", 1, 2), ("dot1", 0, 1)]
    needs_axis = False


class Universal(AbstractJoint):
    """Universal (Hooke): coincident origins and z_I ⟂ z_J, 4 equations.

    ``axis_i`` is the cross-pin axis fixed in the first part, ``axis_j`` the one fixed in the
    second; they must be perpendicular at the modelled pose.
    """

    kind = "universal"
    equations = _SPH + [("dot1", 2, 2)]
    needs_axis = False

    def __init__(self, name, i, j, at=None, axis_i=None, axis_j=None):
        super().__init__(name, i, j, at, None)
        if isinstance(i, Part) or isinstance(j, Part):
            if axis_i is None or axis_j is None:
                raise ModelError(f"Universal '{name}': give axis_i and axis_j (the two cross-pin axes, ground coordinates).")
            self.axis_i = unit_vector(f"Universal '{name}' axis_i", axis_i)
            self.axis_j = unit_vector(f"Universal '{name}' axis_j", axis_j)
            if abs(self.axis_i @ self.axis_j) > 1e-6:
                raise ModelError(f"Universal '{name}': axis_i and axis_j must be perpendicular at the modelled pose.")

    def frames(self):
        from ..spatial.rotation import frame_from_axis

        Ri = frame_from_axis(self.axis_i)
        Rj = frame_from_axis(self.axis_j, xhint=self.axis_i)
        return Ri, Rj


JOINT_TYPES = {c.kind: c for c in (Revolute, Spherical, Cylindrical, Prismatic, Screw, Planar, Fixed, Universal)}
