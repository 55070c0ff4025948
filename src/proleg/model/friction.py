"""Friction in a sliding (prismatic) joint that grows with the joint's side load.

:class:`SlideFriction` is the translational-joint form of the Adams FRICTION statement (MSC
Adams/Solver reference, FRICTION statement and "Translational joint" block diagram): the
friction force along the joint axis is μ(v) times a normal load built from the joint's reaction
force normal to the axis, its bending moment divided by the overlap of the sliding parts, and a
preload, with stick–slip regularised by two transition velocities so that the implicit,
error-controlled integrator sees a continuous (C1) law.
"""

from __future__ import annotations

from ..errors import ModelError
from ._validate import finite_scalar
from .couplers import _JointForce


class SlideFriction(_JointForce):
    """Stiction, Coulomb and viscous friction in a prismatic joint under its side load.

    Force on part I along z_J (reaction on J), with v the slide rate of I relative to J::

        F = −( μ(v) N + c v ),    N = F_pre + |R⊥| + |M⊥| / overlap

    **Friction coefficient** (Adams stick–slip, cubic STEPs of seed 002 Eq. 18):
    μ = STEP(v, −v_s, −μ_s, v_s, μ_s) for |v| ≤ v_s (stiction: the joint creeps at most at
    ≈ v_s · F_t / (μ_s N) while the applied force F_t stays below μ_s N), then
    sign(v) STEP(|v|, v_s, μ_s, v_d, μ_d) up to v_d and μ_d sign(v) beyond (sliding).

    **Normal load.** R is the force the joint exerts on part I, M its moment about the bearing
    centre (the point ``bearing_offset`` along z_J from marker J), both taken perpendicular to
    the axis (R⊥ = R − (R·z)z, M⊥ likewise); ``overlap`` is the length over which the parts
    slide in each other (Adams INITIAL_OVERLAP: "the joint's bending moment is divided by overlap
    to compute the bending moment's contribution"). proleg's force laws see positions and
    velocities but not the Lagrange multipliers, so R and M are the **quasi-static** reaction:
    minus the resultant of every other load on part I (elements, contacts, actuators, gravity),
    with part I's own inertia neglected. That is exact for a slider whose carrier does not
    accelerate sideways (a block on a fixed incline) and, for a telescopic leg, misses only the
    lower leg's own m a⊥ (small against the toe's ground reaction). Other SlideFriction elements
    on the same part are not counted in its resultant (they act along their own axes).

    Outputs: ``force`` [N] (on I along z_J), ``normal_load`` N [N], ``side_force`` |R⊥| [N],
    ``bending_moment`` |M⊥| [N m], ``mu`` [-], ``rate`` v [m/s], ``power`` F v [W] (≤ 0; its
    negative is in the result's dissipated energy).

    Parameters
    ----------
    name : str
    joint : Prismatic (or Cylindrical) joint, or its name
    mu_static, mu_dynamic : float [-], 0 ≤ μ_d ≤ μ_s
    v_stiction : float [m/s], > 0, default 1e-3    v_s (Adams STICTION_TRANSITION_VELOCITY)
    v_friction : float [m/s], > v_s, default 1e-2  v_d, where the dynamic coefficient is reached
    damping : float [N s/m], ≥ 0, default 0        c, viscous friction (lubricant, seals)
    preload : float [N], ≥ 0, default 0            F_pre (interference fit, seals)
    overlap : float [m] or None                    bending moment arm; None ignores the moment
    bearing_offset : float [m], default 0           bearing centre along z_J from marker J

    Choosing values: v_s is the creep speed scale while stuck; the law's slope μ_s N / v_s is a
    stiff damper the integrator must resolve. 1e-3 m/s sticks a leg to well under a millimetre
    per second; 1e-4 sticks better and costs steps. Keep v_d ≈ 3–10 v_s.
    """

    kind = "slide_friction"

    def __init__(self, name, joint, mu_static=0.0, mu_dynamic=None, v_stiction=1e-3, v_friction=1e-2, damping=0.0, preload=0.0,
                 overlap=None, bearing_offset=0.0):
        super().__init__(name)
        who = f"SlideFriction '{name}'"
        self.joint, self.dof = joint, "translation"
        self.mu_static = finite_scalar(f"{who} mu_static", mu_static, nonnegative=True)
        self.mu_dynamic = self.mu_static if mu_dynamic is None else finite_scalar(f"{who} mu_dynamic", mu_dynamic, nonnegative=True)
        if self.mu_dynamic > self.mu_static:
            raise ModelError(f"{who}: mu_dynamic ({self.mu_dynamic:g}) exceeds mu_static ({self.mu_static:g}); give μ_d ≤ μ_s.")
        self.v_stiction = finite_scalar(f"{who} v_stiction", v_stiction, positive=True)
        self.v_friction = finite_scalar(f"{who} v_friction", v_friction, positive=True)
        if not self.v_stiction < self.v_friction:
            raise ModelError(f"{who}: v_stiction ({self.v_stiction:g} m/s) must be below v_friction ({self.v_friction:g} m/s).")
        self.damping = finite_scalar(f"{who} damping", damping, nonnegative=True)
        self.preload = finite_scalar(f"{who} preload", preload, nonnegative=True)
        if overlap is None:
            self.overlap, self.use_moment = 1.0, False
        else:
            self.overlap, self.use_moment = finite_scalar(f"{who} overlap", overlap, positive=True), True
        self.bearing_offset = finite_scalar(f"{who} bearing_offset", bearing_offset)
        self.i = self.j = None

    def resolve(self, joint):
        if not joint.dof_translation:
            raise ModelError(
                f"SlideFriction '{self.name}': joint '{joint.name}' ({joint.kind}) does not slide; use a Prismatic or "
                "Cylindrical joint (for a revolute joint use JointFriction)."
            )
        super().resolve(joint)
