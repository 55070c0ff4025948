"""The Model: a mutable, named collection of parts, markers, joints and force elements."""

from __future__ import annotations

import numpy as np

from ..errors import ModelError
from ._validate import finite_array, finite_scalar
from .forces import AbstractForceElement, Force, RotationalSpringDamper, Torque
from .joints import AbstractJoint
from .parts import Marker, Part, make_marker


class Model:
    """A mechanism description in Adams vocabulary, SI units.

    >>> model = Model("pendulum", gravity=(0, 0, -9.81))
    >>> bob = model.add_part("bob", mass=1.0, inertia=(1e-3, 1e-3, 1e-3), position=(1, 0, 0))
    """

    #: What a trace of the assembled model may read (proleg.compile_cache): the elements. A
    #: builder's notes attached to a model (``model.hyq``, ``model.urdf``: parameter tables,
    #: sources) describe it for reports and are not part of its structure key.
    _traced_fields = (
        "name", "gravity", "ground", "parts", "markers", "joints", "forces", "contacts", "motions",
        "controllers", "actuators", "couplers", "batteries", "variables", "laws",
    )

    def __init__(self, name: str = "model", gravity=(0.0, 0.0, -9.81)):
        self.name = name
        self.gravity = finite_array(f"Model '{name}' gravity", gravity, (3,))
        self.ground = Part("ground", 0.0, np.eye(3), np.zeros(3), is_ground=True)
        self.parts: list[Part] = []
        self.markers: list[Marker] = []
        self.joints: list[AbstractJoint] = []
        self.forces: list[AbstractForceElement] = []
        self.contacts: list = []
        self.motions: list = []
        self.controllers: list = []
        self.actuators: list = []
        self.couplers: list = []
        self.batteries: list = []
        self.variables: dict = {}
        self._names: dict[str, object] = {}

    # -- names -------------------------------------------------------------------------------
    def _claim(self, kind: str, name: str, obj):
        key = f"{kind}:{name}"
        if key in self._names:
            raise ModelError(f"{kind} '{name}' is defined twice in model '{self.name}'; names must be unique.")
        self._names[key] = obj

    def _check_part(self, part, who: str):
        if part is self.ground:
            return
        if not isinstance(part, Part) or not any(p is part for p in self.parts):
            pname = getattr(part, "name", repr(part))
            raise ModelError(f"{who}: part '{pname}' is not in model '{self.name}'. Add it with model.add_part first.")

    def _check_marker(self, marker, who: str):
        if not any(m is marker for m in self.markers):
            raise ModelError(
                f"{who}: marker '{getattr(marker, 'name', marker)}' is not in model '{self.name}'. "
                "Create it with model.add_marker."
            )

    # -- building ----------------------------------------------------------------------------
    def add_part(self, name, mass, inertia, position, orientation=None, velocity=None, angular_velocity=None) -> Part:
        """Add a rigid part; see :class:`Part` for units. Returns the part."""
        if name == "ground":
            raise ModelError("Part name 'ground' is reserved for model.ground.")
        self._claim("Part", name, None)
        part = Part.build(name, mass, inertia, position, orientation, velocity, angular_velocity)
        self._names[f"Part:{name}"] = part
        self.parts.append(part)
        return part

    def add_marker(self, part, name, position=None, orientation=None, *, node=None) -> Marker:
        """Add a marker on ``part`` at a ground-frame ``position`` (modelled pose); returns it.

        On a :class:`FlexibleBody` give ``node=`` (an FE node) or a position on a node.
        """
        self._check_part(part, f"Marker '{name}'")
        self._claim("Marker", name, None)
        if getattr(part, "is_flexible", False):
            k = node if node is not None else part.nearest_node(position)
            m = part.node_marker(name, k, orientation)
        else:
            if position is None:
                raise ModelError(f"Marker '{name}': give position=(x, y, z) in ground coordinates.")
            m = make_marker(name, part, position, orientation)
        self._names[f"Marker:{name}"] = m
        self.markers.append(m)
        return m

    def _resolve_end(self, joint: AbstractJoint, obj, R, suffix: str) -> Marker:
        if isinstance(obj, Marker):
            self._check_marker(obj, f"{type(joint).__name__} '{joint.name}'")
            return obj
        self._check_part(obj, f"{type(joint).__name__} '{joint.name}'")
        return self.add_marker(obj, f"{joint.name}.{suffix}", joint.at, R)

    def add_joint(self, joint: AbstractJoint) -> AbstractJoint:
        """Add a joint; markers are created at ``joint.at`` when parts were given."""
        if not isinstance(joint, AbstractJoint):
            raise ModelError(f"add_joint expects a joint (Revolute, Prismatic, ...), got {joint!r}.")
        self._claim("Joint", joint.name, joint)
        Ri, Rj = joint.frames() if (isinstance(joint.i_in, Part) or isinstance(joint.j_in, Part)) else (None, None)
        joint.marker_i = self._resolve_end(joint, joint.i_in, Ri, "I")
        joint.marker_j = self._resolve_end(joint, joint.j_in, Rj, "J")
        self.joints.append(joint)
        return joint

    def add_force(self, element: AbstractForceElement) -> AbstractForceElement:
        """Add a force element (SpringDamper, RotationalSpringDamper, Bushing, Force, Torque, ...)."""
        if not isinstance(element, AbstractForceElement):
            raise ModelError(f"add_force expects a force element, got {element!r}.")
        self._claim("Force", element.name, element)
        who = f"{type(element).__name__} '{element.name}'"
        for m in element.markers():
            self._check_marker(m, who)
        if isinstance(element, RotationalSpringDamper) and element.joint is not None:
            j = element.joint
            if isinstance(j, str):
                j = self.joint(j)
            if not (j.dof_rotation):
                raise ModelError(f"{who}: joint '{j.name}' has no rotational degree of freedom about its axis.")
            element.joint = j
            element.i, element.j = j.marker_i, j.marker_j
        from .couplers import _JointForce

        if isinstance(element, _JointForce):  # JointStop, JointFriction, SlideFriction
            j = element.joint if isinstance(element.joint, AbstractJoint) else self.joint(element.joint)
            if not any(x is j for x in self.joints):
                raise ModelError(f"{who}: joint '{j.name}' is not in model '{self.name}'. Add it with model.add_joint first.")
            element.resolve(j)
        if isinstance(element, Force | Torque):
            if element.marker_in is not None:
                self._check_marker(element.marker_in, who)
                element.marker = element.marker_in
            else:
                self._check_part(element.part, who)
                at = element.part.position if element.at is None else element.at
                element.marker = self.add_marker(element.part, f"{element.name}.at", at)
        self.forces.append(element)
        return element

    def add_flexible_body(self, name, reduced, frame_node, position, orientation=None, damping_ratio=0.0, velocity=None, angular_velocity=None, stress=None):
        """Add a Craig-Bampton flexible body (:class:`proleg.model.flexible.FlexibleBody`); returns it."""
        from .flexible import FlexibleBody

        if name == "ground":
            raise ModelError("Part name 'ground' is reserved for model.ground.")
        self._claim("Part", name, None)
        body = FlexibleBody(name, reduced, frame_node, position, orientation, damping_ratio, velocity, angular_velocity, stress)
        self._names[f"Part:{name}"] = body
        self.parts.append(body)
        return body

    def add_contact(self, contact):
        """Add a contact (SphereContact, PointContact, CylinderContact); a ground plane z = 0 by default."""
        from .contacts import SphereContact

        if not isinstance(contact, SphereContact):
            raise ModelError(f"add_contact expects a contact element (SphereContact, ...), got {contact!r}.")
        self._claim("Contact", contact.name, contact)
        who = f"{type(contact).__name__} '{contact.name}'"
        self._check_marker(contact.marker, who)
        if contact.plane is None:
            contact.plane = self.add_marker(self.ground, f"{contact.name}.plane", (0.0, 0.0, 0.0))
        else:
            self._check_marker(contact.plane, who)
        if contact.plane.part is contact.marker.part:
            raise ModelError(f"{who}: the contact marker and the plane are on the same part '{contact.plane.part.name}'.")
        self.contacts.append(contact)
        return contact

    def add_variable(self, name: str, value: float, unit: str = "", description: str = "") -> str:
        """Add a design variable (Adams VARIABLE / design variable): a named scalar parameter that
        controllers and state-dependent functions read with ``state.variable(name)``.

        It becomes the system parameter ``name`` (``system.with_params({name: value})``), so it
        can be swept, vmapped, differentiated and identified like a stiffness, without
        recompiling. Returns the name.
        """
        if not isinstance(name, str) or not name.isidentifier():
            raise ModelError(f"Variable name must be an identifier (letters, digits, _), got {name!r}.")
        self._claim("Variable", name, None)
        self.variables[name] = (finite_scalar(f"Variable '{name}'", value, unit=unit), unit, description)
        return name

    def add_law(self, law):
        """Add a motion law whose knots or coefficients are design variables
        (:class:`~proleg.model.laws.SplineLaw`, :class:`~proleg.model.laws.Step5Chain`,
        :class:`~proleg.model.laws.FourierLaw`): registers its variables; returns the law, to
        give to a Motion, a PID set point or an actuator's effort."""
        from .laws import AbstractLaw

        if not isinstance(law, AbstractLaw):
            raise ModelError(f"add_law expects a SplineLaw, Step5Chain or FourierLaw, got {law!r}.")
        self._claim("Law", law.name, law)
        return law.add_to(self)

    def add_coupler(self, coupler):
        """Add a :class:`~proleg.model.couplers.Coupler` (θ₁ = r θ₂ between two joints' coordinates)."""
        from .couplers import Coupler

        if not isinstance(coupler, Coupler):
            raise ModelError(f"add_coupler expects a Coupler, got {coupler!r}.")
        self._claim("Coupler", coupler.name, coupler)
        js = []
        for ref in (coupler.joint_1_ref, coupler.joint_2_ref):
            j = ref if isinstance(ref, AbstractJoint) else self.joint(ref)
            if not any(x is j for x in self.joints):
                raise ModelError(f"Coupler '{coupler.name}': joint '{j.name}' is not in model '{self.name}'. Add it first.")
            js.append(j)
        coupler.resolve(*js)
        self.couplers.append(coupler)
        return coupler

    def add_battery(self, battery):
        """Add a :class:`~proleg.model.control.Battery` (done for you by a JointActuator that names one)."""
        from .control import Battery

        if not isinstance(battery, Battery):
            raise ModelError(f"add_battery expects a Battery, got {battery!r}.")
        if any(b is battery for b in self.batteries):
            return battery
        self._claim("Battery", battery.name, battery)
        self.batteries.append(battery)
        return battery

    def add_motion(self, motion):
        """Add an imposed joint motion (a rheonomic constraint)."""
        from .control import Motion

        if not isinstance(motion, Motion):
            raise ModelError(f"add_motion expects a Motion, got {motion!r}.")
        self._claim("Motion", motion.name, motion)
        joint = motion.joint_ref if isinstance(motion.joint_ref, AbstractJoint) else self.joint(motion.joint_ref)
        motion.resolve(joint)
        self.motions.append(motion)
        return motion

    def add_actuator(self, actuator):
        """Add a JointActuator, TranslationalActuator or HydraulicActuator."""
        from .control import HydraulicActuator, JointActuator, TranslationalActuator

        if not isinstance(actuator, JointActuator | TranslationalActuator | HydraulicActuator):
            raise ModelError(f"add_actuator expects an actuator element, got {actuator!r}.")
        self._claim("Actuator", actuator.name, actuator)
        who = f"{type(actuator).__name__} '{actuator.name}'"
        if isinstance(actuator, JointActuator):
            joint = actuator.joint_ref if isinstance(actuator.joint_ref, AbstractJoint) else self.joint(actuator.joint_ref)
            dof = actuator.dof or ("rotation" if joint.dof_rotation else "translation" if joint.dof_translation else None)
            if dof is None or (dof == "rotation" and not joint.dof_rotation) or (dof == "translation" and not joint.dof_translation):
                raise ModelError(f"{who}: joint '{joint.name}' ({joint.kind}) has no {dof or 'free'} degree of freedom to actuate.")
            actuator.joint, actuator.dof = joint, dof
            actuator.i, actuator.j = joint.marker_i, joint.marker_j
            if actuator.battery is not None:
                self.add_battery(actuator.battery)
        else:
            self._check_marker(actuator.i, who)
            self._check_marker(actuator.j, who)
        self.actuators.append(actuator)
        return actuator

    def add_controller(self, controller):
        """Add a sampled controller (PID, DiscreteController, StateMachine)."""
        from .control import PID, DiscreteController

        if not isinstance(controller, PID | DiscreteController):
            raise ModelError(f"add_controller expects a controller (PID, DiscreteController), got {controller!r}.")
        self._claim("Controller", controller.name, controller)
        if isinstance(controller, PID):
            joint = controller.joint_ref if isinstance(controller.joint_ref, AbstractJoint) else self.joint(controller.joint_ref)
            dof = controller.dof or ("rotation" if joint.dof_rotation else "translation" if joint.dof_translation else None)
            if dof is None:
                raise ModelError(f"PID '{controller.name}': joint '{joint.name}' ({joint.kind}) has no degree of freedom to servo.")
            controller.joint, controller.dof = joint, dof
            if controller.actuator_ref is None:
                from .control import JointActuator

                act = JointActuator(f"{controller.name}.actuator", joint, dof=dof)
                self.add_actuator(act)
                controller.actuator_ref = act.name
        self.controllers.append(controller)
        return controller

    def _constraint_owners_extra(self):
        return list(self.motions) + list(self.couplers)

    # -- lookup ------------------------------------------------------------------------------
    def _get(self, kind, name):
        try:
            return self._names[f"{kind}:{name}"]
        except KeyError:
            have = sorted(k.split(":", 1)[1] for k in self._names if k.startswith(kind + ":"))
            raise ModelError(f"No {kind.lower()} named '{name}' in model '{self.name}'. Known: {have}") from None

    def part(self, name: str) -> Part:
        return self.ground if name == "ground" else self._get("Part", name)

    def marker(self, name: str) -> Marker:
        return self._get("Marker", name)

    def joint(self, name: str) -> AbstractJoint:
        return self._get("Joint", name)

    def force(self, name: str) -> AbstractForceElement:
        return self._get("Force", name)

    def __repr__(self):
        return (
            f"Model({self.name!r}: {len(self.parts)} parts, {len(self.joints)} joints, "
            f"{len(self.forces)} force elements, {len(self.contacts)} contacts)"
        )
