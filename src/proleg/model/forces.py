"""Force elements between markers I and J (Adams convention).

Convention, for every two-marker element: the force acts on marker I and is computed from the
displacement of I relative to J (expressed in J where a frame matters); the equal and opposite
reaction, with its moment arm, acts on J.
"""

from __future__ import annotations

import inspect

import numpy as np

from ..errors import ModelError
from ._validate import finite_array, finite_scalar
from .parts import Marker, Part


def _check_marker(elem: str, role: str, obj):
    if not isinstance(obj, Marker):
        raise ModelError(f"{elem}: {role} must be a Marker (create one with model.add_marker), got {obj!r}.")
    return obj


class AbstractForceElement:
    kind = "force"

    def __init__(self, name: str):
        if not isinstance(name, str) or not name:
            raise ModelError(f"{type(self).__name__} needs a non-empty name, got {name!r}.")
        self.name = name

    def markers(self) -> list[Marker]:
        return []

    def __repr__(self):
        return f"{type(self).__name__}({self.name!r})"


class SpringDamper(AbstractForceElement):
    """Translational spring-damper along the line from J to I.

    Force on I: F_I = f u, u = (r_I − r_J)/ℓ, f = −k (ℓ − ℓ0) − c ℓ̇ + f0 (positive f pushes the
    markers apart); the reaction −F_I acts on J.

    Parameters
    ----------
    i, j : Marker
    stiffness : float [N/m], ≥ 0
    damping : float [N s/m], ≥ 0
    free_length : float [m], ≥ 0
    preload : float [N], force at the free length (positive = pushing apart)
    """

    kind = "spring_damper"

    def __init__(self, name, i, j, stiffness=0.0, damping=0.0, free_length=0.0, preload=0.0):
        super().__init__(name)
        self.i = _check_marker(f"SpringDamper '{name}'", "i", i)
        self.j = _check_marker(f"SpringDamper '{name}'", "j", j)
        self.stiffness = finite_scalar(f"SpringDamper '{name}' stiffness", stiffness, nonnegative=True, unit="N/m")
        self.damping = finite_scalar(f"SpringDamper '{name}' damping", damping, nonnegative=True, unit="N s/m")
        self.free_length = finite_scalar(f"SpringDamper '{name}' free_length", free_length, nonnegative=True, unit="m")
        self.preload = finite_scalar(f"SpringDamper '{name}' preload", preload, unit="N")
        if self.i.part is self.j.part:
            raise ModelError(f"SpringDamper '{name}' connects part '{self.i.part.name}' to itself.")
        if np.linalg.norm(self.i.position - self.j.position) < 1e-9:
            raise ModelError(
                f"SpringDamper '{name}': markers I and J coincide at the modelled pose, so its direction is "
                "undefined. Use a Bushing for a zero-length connection."
            )

    def markers(self):
        return [self.i, self.j]


class RotationalSpringDamper(AbstractForceElement):
    """Torsion spring-damper about z_J (e.g. a joint axis).

    Torque on I about z_J: t = −k (θ − θ0) − c θ̇ + t0 with θ = atan2(x_I·y_J, x_I·x_J) the
    rotation of I relative to J; the reaction acts on J. Give ``joint=`` (a Revolute or
    Cylindrical joint, using its markers) or two markers whose z axes are aligned.

    Parameters
    ----------
    stiffness : float [N m/rad]     damping : float [N m s/rad]
    free_angle : float [rad]        preload : float [N m]
    """

    kind = "rotational_spring_damper"

    def __init__(self, name, i=None, j=None, *, joint=None, stiffness=0.0, damping=0.0, free_angle=0.0, preload=0.0):
        super().__init__(name)
        self.joint = joint
        if joint is None:
            self.i = _check_marker(f"RotationalSpringDamper '{name}'", "i", i)
            self.j = _check_marker(f"RotationalSpringDamper '{name}'", "j", j)
        else:
            self.i = self.j = None
        self.stiffness = finite_scalar(f"RotationalSpringDamper '{name}' stiffness", stiffness, nonnegative=True, unit="N m/rad")
        self.damping = finite_scalar(f"RotationalSpringDamper '{name}' damping", damping, nonnegative=True, unit="N m s/rad")
        self.free_angle = finite_scalar(f"RotationalSpringDamper '{name}' free_angle", free_angle, unit="rad")
        self.preload = finite_scalar(f"RotationalSpringDamper '{name}' preload", preload, unit="N m")

    def markers(self):
        return [m for m in (self.i, self.j) if m is not None]


def _six(name, what, value, unit_hint, allow_full=True):
    shapes = [(6,), (6, 6)] if allow_full else [(6,)]
    arr = finite_array(
        f"Bushing '{name}' {what}",
        value,
        shapes,
        hint=f"expected (6,) or (6, 6) [{unit_hint}]. Pass a 6-vector, or Bushing.isotropic(k_trans, k_rot).",
    )
    if arr.ndim == 1:
        if np.any(arr < 0):
            raise ModelError(f"Bushing '{name}' {what} has a negative entry {arr.tolist()}; every diagonal value must be ≥ 0.")
        return np.diag(arr)
    if np.any(np.diag(arr) < 0):
        raise ModelError(f"Bushing '{name}' {what} has a negative diagonal {np.diag(arr).tolist()}; it must be ≥ 0.")
    return arr


class Bushing(AbstractForceElement):
    """Linear 6-DOF bushing between markers I and J (seed 000, Eq. 3; formulation note §3).

    Force on I: [f; t] = −K ([d; θ] − [d0; θ0]) − C [ḋ; ω_rel] + [f0; t0], all in J axes, with d
    the translation of marker I relative to marker J and θ = (AX, AY, AZ) its small rotation
    (Adams' projected angles). The reaction −f (and −t − δ × F, the moment arm) acts on J.

    Parameters
    ----------
    stiffness : (6,) or (6, 6) [N/m ×3, N m/rad ×3]   diagonal, or full "field" matrix
    damping   : (6,) or (6, 6) [N s/m ×3, N m s/rad ×3]
    preload   : (6,), default 0 [N ×3, N m ×3]
    free      : (6,), default 0 [m ×3, rad ×3], the displacement at which the elastic force vanishes

    Keep the tilt angles AX and AY below about 10° (the rotational law is the small-angle one);
    AZ may be large when its stiffness is zero (a compliant pin).
    """

    kind = "bushing"

    def __init__(self, name, i, j, stiffness, damping=None, preload=None, free=None):
        super().__init__(name)
        self.i = _check_marker(f"Bushing '{name}'", "i", i)
        self.j = _check_marker(f"Bushing '{name}'", "j", j)
        if self.i.part is self.j.part:
            raise ModelError(f"Bushing '{name}' connects part '{self.i.part.name}' to itself.")
        self.stiffness = _six(name, "stiffness", stiffness, "N/m ×3, N m/rad ×3")
        self.damping = _six(name, "damping", np.zeros(6) if damping is None else damping, "N s/m ×3, N m s/rad ×3")
        self.preload = finite_array(f"Bushing '{name}' preload", np.zeros(6) if preload is None else preload, (6,))
        self.free = finite_array(f"Bushing '{name}' free", np.zeros(6) if free is None else free, (6,))

    @staticmethod
    def isotropic(k_trans: float, k_rot: float) -> np.ndarray:
        """A (6,) diagonal with ``k_trans`` on the three translations and ``k_rot`` on the rotations."""
        return np.array([k_trans] * 3 + [k_rot] * 3, dtype=float)

    def markers(self):
        return [self.i, self.j]


def _callable_arity(fn) -> int:
    try:
        sig = inspect.signature(fn)
    except (TypeError, ValueError):
        return 1
    return len([p for p in sig.parameters.values() if p.default is inspect.Parameter.empty])


class _PartLoad(AbstractForceElement):
    unit = "N"

    def __init__(self, name, part, value, at=None):
        super().__init__(name)
        if not isinstance(part, Part | Marker):
            raise ModelError(f"{type(self).__name__} '{name}': part must be a Part or Marker, got {part!r}.")
        self.marker_in = part if isinstance(part, Marker) else None
        self.part = part.part if isinstance(part, Marker) else part
        self.at = None if at is None else finite_array(f"{type(self).__name__} '{name}' at", at, (3,))
        if callable(value):
            self.fn = value
            self.arity = _callable_arity(value)
            self.value = None
        else:
            self.fn = None
            self.value = finite_array(f"{type(self).__name__} '{name}' value", value, (3,), hint=f"[{self.unit}] in ground")
        self.marker = None


class Force(_PartLoad):
    """A force [N] in ground components on a part, applied at ``at`` (ground point at the modelled
    pose; default the COM) or at a marker.

    ``value`` is a constant (3,) or a JAX-traceable function ``f(t)`` or ``f(t, state)`` returning
    (3,), where ``state`` gives ``state.position(part)``, ``state.velocity(part)``,
    ``state.orientation(part)``, ``state.angular_velocity(part)``, ``state.marker_position(marker)``.
    """

    kind = "force"


class Torque(_PartLoad):
    """A torque [N m] in ground components on a part; constant (3,) or ``f(t)``/``f(t, state)``."""

    kind = "torque"
    unit = "N m"


class RotationalBacklash(RotationalSpringDamper):
    """Rotational compliance with backlash (seed 003 Model II hip unit: belt + gear play).

    Torque on I about z_J: zero inside the dead band |θ − θ0| ≤ ``half_gap``; outside,
    −k (θ − θ0 ∓ half_gap) − c θ̇ (damping only while engaged). The transition is smoothed over
    ``width`` [rad] (C1 contact gate; exact outside ``half_gap ± width/2``).
    """

    kind = "rotational_backlash"

    def __init__(self, name, i=None, j=None, *, joint=None, stiffness=0.0, damping=0.0, half_gap=0.0, width=None, free_angle=0.0):
        super().__init__(name, i, j, joint=joint, stiffness=stiffness, damping=damping, free_angle=free_angle)
        self.half_gap = finite_scalar(f"RotationalBacklash '{name}' half_gap", half_gap, nonnegative=True, unit="rad")
        w = 0.2 * self.half_gap if width is None else width
        self.width = finite_scalar(f"RotationalBacklash '{name}' width", w, nonnegative=True, unit="rad")
        if self.width > 2 * self.half_gap:
            raise ModelError(f"RotationalBacklash '{name}': width ({self.width}) must be ≤ 2·half_gap ({2 * self.half_gap}).")
