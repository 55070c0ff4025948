"""Elements that act on joint coordinates: the Coupler constraint and the JointStop force.

- :class:`Coupler` (Adams COUPLER / GEAR): θ₁ = r θ₂ between the coordinates of two joints, a
  constraint with its reaction torque (or force) in the results.
- :class:`JointStop` (Adams BISTOP used as a force): a unilateral stop on a joint coordinate,
  reported like a contact.
"""

from __future__ import annotations

import numpy as np

from ..errors import ModelError
from ._validate import finite_scalar
from .forces import AbstractForceElement
from .joints import AbstractJoint


def _joint_dof(who, joint, dof):
    if not isinstance(joint, AbstractJoint):
        raise ModelError(f"{who}: expected a joint (Revolute, Prismatic, Cylindrical, ...), got {joint!r}.")
    if dof is None:
        if joint.dof_rotation and joint.dof_translation:
            raise ModelError(f"{who}: joint '{joint.name}' ({joint.kind}) rotates and translates; give dof='rotation' or 'translation'.")
        dof = "rotation" if joint.dof_rotation else "translation" if joint.dof_translation else None
    if dof is None:
        raise ModelError(
            f"{who}: joint '{joint.name}' ({joint.kind}) has no rotation about or translation along its axis "
            "(use a Revolute, Prismatic or Cylindrical joint)."
        )
    if dof not in ("rotation", "translation") or (dof == "rotation" and not joint.dof_rotation) or (
        dof == "translation" and not joint.dof_translation
    ):
        raise ModelError(f"{who}: joint '{joint.name}' ({joint.kind}) has no {dof!r} degree of freedom.")
    return dof


def joint_coordinate_at_pose(joint, dof):
    """The joint coordinate (I relative to J) at the modelled pose [rad or m], plain numpy."""
    RI, RJ = joint.marker_i.orientation, joint.marker_j.orientation
    if dof == "rotation":
        return float(np.arctan2(RI[:, 0] @ RJ[:, 1], RI[:, 0] @ RJ[:, 0]))
    return float(RJ[:, 2] @ (joint.marker_i.position - joint.marker_j.position))


class Coupler:
    """Ties the coordinate of one joint to another's: θ₁ − θ₁⁰ = r (θ₂ − θ₂⁰) (Adams COUPLER/GEAR).

    θ is each joint's coordinate, I relative to J (rotation about z_J [rad] for a Revolute,
    translation along z_J [m] for a Prismatic), and θ⁰ its value at the modelled pose. A gear
    pair of speed ratio r = ω₁/ω₂ = N₂/N₁ (joint 1 on the pinion) is a Coupler of ratio r; the
    ideal gear transmits power without loss: τ₂ = −r τ₁ for the reactions.

    The constraint is one row, Φ = wrap(θ₁ − r θ₂ − c) (c from the modelled pose; the wrap
    keeps it valid while the fast joint 1 turns through many revolutions). The slow joint 2
    must stay within ±π of its modelled pose (its angle is single-valued there).

    Reactions: ``result.coupler(name)`` gives ``torque_1`` (on joint 1's part I about z_J1)
    and ``torque_2`` (on joint 2's part I about z_J2) [N m] (``force_1``/``force_2`` [N] for
    prismatic joints), with τ₂ = −r τ₁ exactly.

    Parameters
    ----------
    name : str
    joint_1, joint_2 : joint objects or names (both rotational or both translational)
    ratio : float [-], non-zero   r in θ₁ = r θ₂
    dof : "rotation" or "translation", optional (needed for Cylindrical joints)
    """

    kind = "coupler"

    def __init__(self, name, joint_1, joint_2, ratio, dof=None):
        if not isinstance(name, str) or not name:
            raise ModelError(f"Coupler needs a non-empty name, got {name!r}.")
        self.name = name
        self.joint_1_ref, self.joint_2_ref = joint_1, joint_2
        self.ratio = finite_scalar(f"Coupler '{name}' ratio", ratio)
        if self.ratio == 0.0:
            raise ModelError(f"Coupler '{name}': ratio is zero, which would lock joint 1; give r ≠ 0 in θ₁ = r θ₂.")
        self.dof = dof
        self.equations = [("cpl",)]
        self.marker_i = self.marker_j = None

    @property
    def n_equations(self) -> int:
        return 1

    def resolve(self, joint_1, joint_2):
        who = f"Coupler '{self.name}'"
        if joint_1 is joint_2:
            raise ModelError(f"{who}: joint_1 and joint_2 are the same joint '{joint_1.name}'.")
        d1 = _joint_dof(who, joint_1, self.dof)
        d2 = _joint_dof(who, joint_2, self.dof)
        if d1 != d2:
            raise ModelError(
                f"{who}: joint '{joint_1.name}' is coupled by its {d1} and joint '{joint_2.name}' by its {d2}; "
                "a Coupler ties two rotations or two translations (same kind). For a rack and pinion use two "
                "Couplers through an intermediate joint, or give dof= for a Cylindrical joint."
            )
        self.joint_1, self.joint_2, self.dof = joint_1, joint_2, d1
        self.marker_i, self.marker_j = joint_1.marker_i, joint_1.marker_j
        self.offset = joint_coordinate_at_pose(joint_1, d1) - self.ratio * joint_coordinate_at_pose(joint_2, d1)

    def __repr__(self):
        return f"Coupler({self.name!r}, ratio={self.ratio:g})"


class _JointForce(AbstractForceElement):
    """A force element on one joint's coordinate (markers I and J of the joint, set by the model)."""

    def resolve(self, joint):
        self.dof = _joint_dof(f"{type(self).__name__} '{self.name}'", joint, self.dof)
        self.joint = joint
        self.i, self.j = joint.marker_i, joint.marker_j

    def markers(self):
        return [m for m in (self.i, self.j) if m is not None]


class JointStop(_JointForce):
    """A unilateral stop on a joint coordinate (Adams BISTOP as a force; e.g. a leg extension stop).

    With x the joint coordinate (I relative to J, [m] or [rad]) and the penetration beyond the
    limits ``p = x − upper`` (x > upper) or ``p = lower − x`` (x < lower), the stop pushes back
    with the IMPACT law (seed 002; :func:`proleg.contact_law.normal_force`)::

        F = k p^e + STEP(p, 0, 0, d_max, c) ṗ,   clipped at 0 (a stop never pulls),

    along/about z_J on part I (reaction on J). Between the limits it exerts nothing. Outputs as
    a contact: ``force`` (signed, on I along/about z_J), ``penetration``, ``penetration_rate``,
    ``in_contact`` (the active flag), ``coordinate``.

    Parameters
    ----------
    name : str
    joint : joint object or name (Revolute, Prismatic, Cylindrical with ``dof=``)
    lower, upper : float or None [m or rad]   limits of the coordinate (at least one)
    stiffness : float [N/m^e or N m/rad^e], > 0
    exponent : float [-], ≥ 1, default 1.0
    damping : float [N s/m or N m s/rad], ≥ 0, default 0
    penetration : float [m or rad], > 0, default 1e-3   d_max, where the full damping is reached
    """

    kind = "joint_stop"

    def __init__(self, name, joint, lower=None, upper=None, stiffness=1e5, exponent=1.0, damping=0.0, penetration=1e-3, dof=None):
        super().__init__(name)
        who = f"JointStop '{name}'"
        self.joint = joint
        self.dof = dof
        if lower is None and upper is None:
            raise ModelError(f"{who}: give lower= and/or upper= (the coordinate's limits).")
        self.lower = -np.inf if lower is None else finite_scalar(f"{who} lower", lower)
        self.upper = np.inf if upper is None else finite_scalar(f"{who} upper", upper)
        if not self.lower < self.upper:
            raise ModelError(f"{who}: lower ({self.lower:g}) must be below upper ({self.upper:g}).")
        self.stiffness = finite_scalar(f"{who} stiffness", stiffness, positive=True)
        self.exponent = finite_scalar(f"{who} exponent", exponent)
        if self.exponent < 1.0:
            raise ModelError(f"{who}: exponent {self.exponent:g} < 1 makes the force's slope infinite at contact; use e ≥ 1.")
        self.damping = finite_scalar(f"{who} damping", damping, nonnegative=True)
        self.penetration = finite_scalar(f"{who} penetration", penetration, positive=True)
        self.i = self.j = None

    def resolve(self, joint):
        super().resolve(joint)
        x0 = joint_coordinate_at_pose(joint, self.dof)
        if not self.lower - 1e-12 <= x0 <= self.upper + 1e-12:
            raise ModelError(
                f"JointStop '{self.name}': joint '{joint.name}' starts at {x0:g} outside [{self.lower:g}, {self.upper:g}]; "
                "move the limits or the modelled pose."
            )


class JointFriction(_JointForce):
    """Coulomb (stiction) and viscous friction in a joint: τ = −τ_s tanh(θ̇/ω_s) − c θ̇ on I about z_J.

    The Coulomb part is smoothed over the slip rate ω_s (tanh), so the force is continuous and the
    implicit integrator converges; below ω_s the joint creeps instead of sticking. Reaction on J.
    Outputs: ``torque`` [N m] (force [N] for a prismatic joint), ``rate``, ``power`` (≤ 0).

    Parameters
    ----------
    name : str
    joint : joint object or name (Revolute, Prismatic, Cylindrical with ``dof=``)
    friction : float [N m or N], ≥ 0     τ_s, the Coulomb (stiction) torque or force
    damping : float [N m s/rad or N s/m], ≥ 0   c
    slip_rate : float [rad/s or m/s], > 0, default 0.01   ω_s
    """

    kind = "joint_friction"

    def __init__(self, name, joint, friction=0.0, damping=0.0, slip_rate=0.01, dof=None):
        super().__init__(name)
        who = f"JointFriction '{name}'"
        self.joint, self.dof = joint, dof
        self.friction = finite_scalar(f"{who} friction", friction, nonnegative=True)
        self.damping = finite_scalar(f"{who} damping", damping, nonnegative=True)
        self.slip_rate = finite_scalar(f"{who} slip_rate", slip_rate, positive=True)
        self.i = self.j = None
