"""Contacts against a plane (ground, or a plane fixed to any part): IMPACT normal force and
Adams-style Coulomb friction with stiction (seed 002 IMPACT; Adams CONTACT)."""

from __future__ import annotations

from ..errors import ModelError
from ._validate import finite_scalar
from .parts import Marker


class SphereContact:
    """A sphere of ``radius`` centred at ``marker`` against a plane.

    The plane is the x-y plane of ``plane`` (a marker; its z axis is the outward normal) or the
    ground plane z = 0. Normal force (IMPACT in penetration form, g = penetration):
    F_n = max(0, k g^e + STEP(g, 0, 0, d, c) ġ); friction −μ(|v_t|) F_n v_t/|v_t| with μ rising
    from 0 to ``mu_static`` at ``v_stiction`` and falling to ``mu_dynamic`` at ``v_friction``,
    so a foot can stand still on a slope (creeping at most at about v_stiction · tan/μ_s).

    Parameters
    ----------
    radius : float [m], ≥ 0 (0 gives a point contact)
    stiffness : float [N/m^e], > 0       exponent : float [-], ≥ 1 (1.5 Hertz)
    damping : float [N s/m], ≥ 0         penetration : float [m], > 0, depth of full damping
    mu_static, mu_dynamic : float [-], 0 ≤ mu_dynamic ≤ mu_static
    v_stiction, v_friction : float [m/s], 0 < v_stiction < v_friction
    """

    kind = "sphere"

    def __init__(
        self, name, marker, radius=0.0, stiffness=1e6, exponent=1.5, damping=1e3, penetration=1e-4,
        mu_static=0.0, mu_dynamic=0.0, v_stiction=1e-3, v_friction=1e-2, plane=None,
    ):
        who = f"{type(self).__name__} '{name}'"
        if not isinstance(marker, Marker):
            raise ModelError(f"{who}: marker must be a Marker on the contacting part, got {marker!r}.")
        if plane is not None and not isinstance(plane, Marker):
            raise ModelError(f"{who}: plane must be a Marker (its z axis is the plane normal) or None for the ground.")
        self.name, self.marker, self.plane = name, marker, plane
        self.radius = finite_scalar(f"{who} radius", radius, nonnegative=True, unit="m")
        self.stiffness = finite_scalar(f"{who} stiffness", stiffness, positive=True, unit="N/m^e")
        self.exponent = finite_scalar(f"{who} exponent", exponent, unit="-")
        if self.exponent < 1.0:
            raise ModelError(f"{who} exponent must be ≥ 1 (1.5 for Hertz, 1 for linear), got {self.exponent}.")
        self.damping = finite_scalar(f"{who} damping", damping, nonnegative=True, unit="N s/m")
        self.penetration = finite_scalar(f"{who} penetration", penetration, positive=True, unit="m")
        self.mu_static = finite_scalar(f"{who} mu_static", mu_static, nonnegative=True)
        self.mu_dynamic = finite_scalar(f"{who} mu_dynamic", mu_dynamic, nonnegative=True)
        if self.mu_dynamic > self.mu_static:
            raise ModelError(f"{who}: mu_dynamic ({self.mu_dynamic}) must not exceed mu_static ({self.mu_static}).")
        self.v_stiction = finite_scalar(f"{who} v_stiction", v_stiction, positive=True, unit="m/s")
        self.v_friction = finite_scalar(f"{who} v_friction", v_friction, positive=True, unit="m/s")
        if not self.v_stiction < self.v_friction:
            raise ModelError(
                f"{who}: transition velocities out of order: v_stiction ({self.v_stiction}) must be below "
                f"v_friction ({self.v_friction})."
            )

    def __repr__(self):
        return f"{type(self).__name__}({self.name!r})"


class PointContact(SphereContact):
    """A point (``marker`` origin) against a plane; a SphereContact of radius 0."""

    kind = "point"

    def __init__(self, name, marker, **kw):
        kw["radius"] = 0.0
        super().__init__(name, marker, **kw)


class CylinderContact(SphereContact):
    """The edge circle of a cylinder (centre ``marker`` origin, axis its z, ``radius``) against a plane.

    The contact point is the point of the circle deepest below the plane; use it for a wheel,
    a rolling foot, or the massless rigid cylinder at the FLEGX link tip (seed 002).
    """

    kind = "cylinder"
