"""Motions (imposed joint coordinates), actuators, and discrete controllers."""

from __future__ import annotations

import numpy as np

from ..errors import ModelError
from ._validate import finite_array, finite_scalar
from .parts import Marker

# 20-point Gauss-Legendre rule on [0, 1] for velocity/acceleration-level motions.
_GL_X, _GL_W = np.polynomial.legendre.leggauss(20)
_GL_X = 0.5 * (_GL_X + 1.0)
_GL_W = 0.5 * _GL_W


class Motion:
    """Imposed motion of a joint coordinate (a rheonomic constraint; Adams MOTION).

    Give exactly one of ``displacement(t)`` [m or rad], ``velocity(t)`` or ``acceleration(t)``
    (JAX-traceable functions of time, or of ``(t, state)`` where ``state.variable(name)`` reads a
    design variable: a :class:`~proleg.model.laws.SplineLaw`, ``Step5Chain`` or ``FourierLaw``,
    whose knots a study then sweeps without recompiling). The coordinate is that of the joint's marker I relative
    to J: the angle about z_J for a Revolute/Cylindrical (``dof="rotation"``) or the translation
    along z_J for a Prismatic/Cylindrical (``dof="translation"``). Velocity and acceleration
    forms are integrated from the modelled pose (20-point Gauss-Legendre, exact for polynomials
    up to degree 39), with ``initial_velocity`` for the acceleration form. The driving force or
    torque is reported by ``result.motion(name).effort``.

    ``breakpoints``: times [s] where the law or its first or second derivative jumps (the ends
    of a :func:`proleg.fn.step` transition, the corners of a piecewise law). The integrator
    steps to each exactly instead of interpolating across it (solvers/driver.py).
    """

    def __init__(self, name, joint, displacement=None, velocity=None, acceleration=None, dof=None, initial_velocity=0.0, breakpoints=()):
        self.name = name
        self.joint_ref = joint
        given = [x is not None for x in (displacement, velocity, acceleration)]
        if sum(given) != 1:
            raise ModelError(f"Motion '{name}': give exactly one of displacement=, velocity= or acceleration= (functions of t).")
        for what, f in (("displacement", displacement), ("velocity", velocity), ("acceleration", acceleration)):
            if f is not None and not callable(f):
                raise ModelError(f"Motion '{name}': {what} must be a function of time t, got {f!r}.")
        self.displacement, self.velocity, self.acceleration = displacement, velocity, acceleration
        self.dof = dof
        self.initial_velocity = finite_scalar(f"Motion '{name}' initial_velocity", initial_velocity)
        self.breakpoints = tuple(float(b) for b in finite_array(f"Motion '{name}' breakpoints [s]", breakpoints).ravel())
        self.marker_i = self.marker_j = None
        self.equations = []

    @property
    def n_equations(self):
        return 1

    def resolve(self, joint):
        if self.dof is None:
            self.dof = "rotation" if joint.dof_rotation and not joint.dof_translation else (
                "translation" if joint.dof_translation and not joint.dof_rotation else None
            )
            if self.dof is None:
                if joint.dof_rotation:
                    raise ModelError(
                        f"Motion '{self.name}': joint '{joint.name}' ({joint.kind}) has both a rotation and a translation; "
                        "give dof='rotation' or dof='translation'."
                    )
                raise ModelError(
                    f"Motion '{self.name}': joint '{joint.name}' ({joint.kind}) has no rotational or translational "
                    "degree of freedom about/along its axis that a motion could drive (use a Revolute, Prismatic or Cylindrical)."
                )
        if self.dof == "rotation" and not joint.dof_rotation or self.dof == "translation" and not joint.dof_translation:
            raise ModelError(
                f"Motion '{self.name}': joint '{joint.name}' ({joint.kind}) has no {self.dof} degree of freedom to drive."
            )
        if self.dof not in ("rotation", "translation"):
            raise ModelError(f"Motion '{self.name}': dof must be 'rotation' or 'translation', got {self.dof!r}.")
        self.joint = joint
        self.marker_i, self.marker_j = joint.marker_i, joint.marker_j
        rot = self.dof == "rotation"
        self.equations = [("drv", rot, self.function(), "angle" if rot else "translation")]

    def function(self):
        """The displacement law: ``f(t)``, or ``f(t, state)`` when the given function reads the
        state's design variables (a law of two arguments)."""
        import jax.numpy as jnp

        from .forces import _callable_arity

        if self.displacement is not None:
            return self.displacement
        x, w = jnp.asarray(_GL_X), jnp.asarray(_GL_W)
        g = self.velocity if self.velocity is not None else self.acceleration
        if _callable_arity(g) >= 2:
            def f(tt, s):
                return g(tt, s)
        else:
            def f(tt, s):
                return g(tt)
        if self.velocity is not None:
            def disp(t, s=None):
                return t * jnp.sum(w * jnp.stack([jnp.asarray(f(t * xi, s)) for xi in _GL_X]))
        else:
            v0 = self.initial_velocity

            def disp(t, s=None):
                return v0 * t + t * t * jnp.sum(w * (1.0 - x) * jnp.stack([jnp.asarray(f(t * xi, s)) for xi in _GL_X]))
        if _callable_arity(g) >= 2:
            return lambda t, s: disp(t, s)
        return lambda t: disp(t)

    def __repr__(self):
        return f"Motion({self.name!r})"


class Battery:
    """A battery shared by the DC motor drives that name it (seed 003, Eq. 9 with the total current).

    An ideal source V_nom behind a series resistance R_s: the terminal voltage is
    ``V_s = V_nom − R_s Σ i_s`` over every drive on it, which sets each drive's saturation
    (:mod:`proleg.drives.battery`). Outputs (``result.element(name)``): ``voltage`` [V],
    ``current`` [A] (total, positive discharging), ``power`` [W] (V_s · current, delivered at the
    terminals), ``internal_loss`` [W] (R_s · current²). Parameters ``"<name>.V_nom"`` and
    ``"<name>.R_s"`` can be swept.

    Parameters
    ----------
    name : str
    V_nom : float [V], > 0     open-circuit voltage (seed 003: 37.17 V, least-squares fit)
    R_s : float [Ω], ≥ 0       series resistance (seed 003: 0.13 Ω)
    """

    kind = "battery"

    def __init__(self, name="battery", V_nom=37.17, R_s=0.13):
        if not isinstance(name, str) or not name:
            raise ModelError(f"Battery needs a non-empty name, got {name!r}.")
        self.name = name
        self.V_nom = finite_scalar(f"Battery '{name}' V_nom", V_nom, positive=True, unit="V")
        self.R_s = finite_scalar(f"Battery '{name}' R_s", R_s, nonnegative=True, unit="Ohm")

    def __repr__(self):
        return f"Battery({self.name!r}, V_nom={self.V_nom:g} V, R_s={self.R_s:g} Ohm)"


class JointActuator:
    """A torque (rotational joint) or force (prismatic joint) on marker I about/along z_J, reaction on J.

    ``effort`` is a constant, a function ``f(t)`` / ``f(t, state)``, or None when a controller
    drives it (``PID(..., actuator=name)``). With ``drive=`` (a :class:`proleg.drives.DCMotorDrive`)
    the commanded leg torque is saturated by the motor, amplifier and battery (seed 003 Eqs. 3-14):
    by the drive's own battery model (``drive.V_nom``, ``drive.R_s``), or, with ``battery=`` (a
    :class:`Battery`), by a battery shared with every other drive that names it (Eq. 9 with the
    total current). With ``motor_side=True`` the joint is the motor shaft (e.g. the drive gear of
    a gear train modelled with a :class:`~proleg.model.couplers.Coupler`): the commanded torque
    is still the leg-referred one, the drive reads the leg speed as the joint rate / β, and the
    joint receives the delivered leg torque / β (the gear losses α/β stay in the drive law).
    ``limit`` clips the effort symmetrically [N m or N]. With ``gear=`` (a
    :class:`proleg.drives.GearTrain`) the command is the motor-side torque and the joint receives
    ratio · η · τ (motor driving) or ratio · τ / η_back (back-driven), by the direction of power flow.
    """

    kind = "joint_actuator"

    def __init__(self, name, joint, effort=None, limit=None, drive=None, dof=None, gear=None, gear_speed_eps=1e-3, battery=None, motor_side=False):
        self.name, self.joint_ref, self.effort, self.drive, self.dof = name, joint, effort, drive, dof
        self.gear, self.gear_speed_eps = gear, gear_speed_eps
        if gear is not None and not (getattr(gear, "ratio", 0) and float(gear.ratio) != 0):
            raise ModelError(f"JointActuator '{name}': gear ratio must be non-zero, got {getattr(gear, 'ratio', None)!r}.")
        if battery is not None and not isinstance(battery, Battery):
            raise ModelError(f"JointActuator '{name}': battery must be a proleg.Battery, got {battery!r}.")
        if (battery is not None or motor_side) and drive is None:
            raise ModelError(f"JointActuator '{name}': battery= and motor_side= need drive= (a DCMotorDrive).")
        self.battery, self.motor_side = battery, bool(motor_side)
        self.limit = None if limit is None else finite_scalar(f"JointActuator '{name}' limit", limit, positive=True)
        if effort is not None and not callable(effort):
            self.effort_value = finite_scalar(f"JointActuator '{name}' effort", effort)
        else:
            self.effort_value = 0.0
        self.controller = None


class TranslationalActuator:
    """A force along the line I–J (a hydraulic cylinder's force): positive pushes I away from J.

    ``force`` is a constant, ``f(t)`` / ``f(t, state)``, or None when a controller drives it.
    """

    kind = "translational_actuator"

    def __init__(self, name, i, j, force=None):
        for role, m in (("i", i), ("j", j)):
            if not isinstance(m, Marker):
                raise ModelError(f"TranslationalActuator '{name}': {role} must be a Marker, got {m!r}.")
        self.name, self.i, self.j, self.force = name, i, j, force
        self.force_value = 0.0 if (force is None or callable(force)) else finite_scalar(f"TranslationalActuator '{name}' force", force)
        self.controller = None


class HydraulicActuator:
    """Hydraulic cylinder as a spring-damper whose set force is moved by the servo (seed 000, Table 2).

    Between rod marker I and cylinder marker J: f = −k (ℓ − ℓ0) − c ℓ̇ + F_cmd along the line J→I
    (positive pushes apart). ℓ0 is the modelled length (``free_length`` overrides it). F_cmd
    comes from a controller (``PID(..., actuator=name, lever_arm=...)``: joint torque / lever
    arm), optionally through a first-order servo-valve lag of ``valve_time_constant`` [s]
    (discretised exactly at the controller's sample period).

    Parameters
    ----------
    stiffness : float [N/m]   damping : float [N s/m]   (seed 000 Table 2: identified k and c)
    """

    kind = "hydraulic_actuator"

    def __init__(self, name, i, j, stiffness, damping, free_length=None, valve_time_constant=None, force_limit=None):
        for role, m in (("i", i), ("j", j)):
            if not isinstance(m, Marker):
                raise ModelError(f"HydraulicActuator '{name}': {role} must be a Marker, got {m!r}.")
        self.name, self.i, self.j = name, i, j
        self.stiffness = finite_scalar(f"HydraulicActuator '{name}' stiffness", stiffness, nonnegative=True, unit="N/m")
        self.damping = finite_scalar(f"HydraulicActuator '{name}' damping", damping, nonnegative=True, unit="N s/m")
        ell = float(np.linalg.norm(i.position - j.position))
        if ell < 1e-9:
            raise ModelError(f"HydraulicActuator '{name}': markers I and J coincide; the line of action is undefined.")
        self.free_length = ell if free_length is None else finite_scalar(f"HydraulicActuator '{name}' free_length", free_length, positive=True)
        self.valve_time_constant = (
            None if valve_time_constant is None else finite_scalar(f"HydraulicActuator '{name}' valve_time_constant", valve_time_constant, positive=True, unit="s")
        )
        self.force_limit = None if force_limit is None else finite_scalar(f"HydraulicActuator '{name}' force_limit", force_limit, positive=True)
        self.controller = None


class PID:
    """Discrete PID joint servo with zero-order hold (seed 000: P = 150 or 300 N m/rad, D = 6 N m s/rad).

    Every ``period`` [s] (1 kHz default) it samples the joint coordinate θ (I relative to J) and
    its rate, and holds u = kp (θ_set − θ) + ki ∫(θ_set − θ) dt − kd θ̇ [N m or N] (derivative on
    the measurement, no kick). u drives ``actuator`` (a JointActuator, TranslationalActuator or
    HydraulicActuator, by name); with a cylinder, the force command is u / ``lever_arm(θ)`` [m]
    (a float or a function of θ). Without ``actuator`` the PID applies u on its own joint.
    ``setpoint``: a constant, a function of t, or of ``(t, state)`` (a design-variable law such
    as :class:`~proleg.model.laws.SplineLaw`); ``None`` holds the initial coordinate.
    ``output_limit`` clips u.
    """

    kind = "pid"
    #: the sample period shapes the step loop (the driver samples on its clock): structure, keyed
    #: exactly by the compile cache, not model data
    _structure_fields = ("period",)

    def __init__(self, name, joint, kp, kd=0.0, ki=0.0, setpoint=None, period=1e-3, actuator=None, lever_arm=None, output_limit=None, dof=None):
        who = f"PID '{name}'"
        self.name, self.joint_ref, self.actuator_ref, self.dof = name, joint, actuator, dof
        self.kp = finite_scalar(f"{who} kp", kp)
        self.kd = finite_scalar(f"{who} kd", kd)
        self.ki = finite_scalar(f"{who} ki", ki)
        neg = [f"{k} = {v:g}" for k, v in (("kp", self.kp), ("kd", self.kd), ("ki", self.ki)) if v < 0]
        if neg:
            import warnings

            from ..errors import ProlegWarning

            warnings.warn(
                f"{who}: negative gain {', '.join(neg)}; u = kp (θ_set − θ) + ki ∫ − kd θ̇ then pushes away from the "
                "setpoint (positive feedback). Give gains ≥ 0, or swap the joint's markers I and J to reverse its sign.",
                ProlegWarning, stacklevel=2,
            )
        self.period = finite_scalar(f"{who} period", period, unit="s")
        if not self.period > 0:
            raise ModelError(f"{who}: the sample period must be positive [s], got {self.period}. 1e-3 is a 1 kHz servo.")
        self.setpoint = setpoint
        if setpoint is not None and not callable(setpoint):
            finite_scalar(f"{who} setpoint", setpoint)
        if lever_arm is not None and not callable(lever_arm):
            lever_arm = finite_scalar(f"{who} lever_arm", lever_arm, unit="m")
            if lever_arm == 0:
                raise ModelError(f"{who}: lever_arm is zero.")
        self.lever_arm = lever_arm
        self.output_limit = None if output_limit is None else finite_scalar(f"{who} output_limit", output_limit, positive=True)


class DiscreteController:
    """A general sampled controller: ``update(t, state, z) -> (z_new, outputs)`` every ``period``.

    ``z0``: initial internal state (1D array); ``outputs`` is a dict actuator name → command,
    held until the next sample. ``state`` gives the same accessors as force functions plus
    ``state.joint_angle(name)``, ``state.joint_rate(name)``, ``state.contact_force(name)``.
    Internal state is carried in the solver state, so jit, vmap and jacfwd work through it.
    The :class:`StateMachine` is built on it.
    """

    kind = "discrete"
    #: the sample period shapes the step loop (the driver samples on its clock): structure, keyed
    #: exactly by the compile cache, not model data
    _structure_fields = ("period",)

    def __init__(self, name, update, z0, outputs, period=1e-3):
        self.name, self.update = name, update
        self.z0 = np.atleast_1d(np.asarray(z0, float))
        self.outputs = list(outputs)
        self.period = finite_scalar(f"DiscreteController '{name}' period", period, unit="s")
        if not self.period > 0:
            raise ModelError(f"DiscreteController '{name}': the sample period must be positive [s], got {self.period}.")
        if not callable(update):
            raise ModelError(f"DiscreteController '{name}': update must be a function (t, state, z) -> (z, outputs).")


class StateMachine(DiscreteController):
    """A sampled finite-state controller: each state has its own control law; guards switch states.

    Parameters
    ----------
    states : dict name -> law(t, state, mem) -> dict actuator name -> command
    transitions : list of (from_state, to_state, guard(t, state, mem) -> bool); the first guard
        that holds (in list order) fires at a sample; events such as touchdown
        (``state.contact_force("foot") > 5``), lift-off or a joint-angle limit are guards.
    initial : name of the initial state
    outputs : actuator names the laws drive (a law may leave some out: they get 0)
    memory : number of extra scalars ``mem`` a law or guard may read (kept 0 here; the time the
        current state was entered is available as ``state.t - entered``: ``mem[0]``)

    The active state index is ``result.controller(name).state[:, 0]``. Everything is traced
    (guards with jnp, no Python ``if`` on values), so jit, vmap and jacfwd work through it.
    """

    kind = "discrete"

    def __init__(self, name, states, transitions, initial, outputs, period=1e-3):
        if initial not in states:
            raise ModelError(f"StateMachine '{name}': initial state '{initial}' is not one of {list(states)}.")
        for tr in transitions:
            if len(tr) != 3 or tr[0] not in states or tr[1] not in states or not callable(tr[2]):
                raise ModelError(f"StateMachine '{name}': transition {tr!r} must be (from, to, guard) with known states {list(states)}.")
        self.state_names = list(states)
        self.laws = [states[k] for k in self.state_names]
        self.transitions = [(self.state_names.index(a), self.state_names.index(b), g) for a, b, g in transitions]
        outs = list(outputs)

        def update(t, view, z):
            import jax.numpy as jnp

            mode, entered = z[0], z[1]
            mem = jnp.stack([entered])
            new_mode = mode
            fired = jnp.asarray(False)
            for a, b, guard in self.transitions:
                hit = (~fired) & (mode == a) & jnp.asarray(guard(t, view, mem), bool)
                new_mode = jnp.where(hit, b, new_mode)
                fired = fired | hit
            entered = jnp.where(new_mode != mode, t, entered)
            mem = jnp.stack([entered])
            cmds = {o: jnp.zeros(()) for o in outs}
            for k, law in enumerate(self.laws):
                vals = law(t, view, mem)
                for o in outs:
                    if o in vals:
                        cmds[o] = jnp.where(new_mode == k, jnp.asarray(vals[o], jnp.float64), cmds[o])
            return jnp.stack([new_mode, entered]), cmds

        super().__init__(name, update, [float(self.state_names.index(initial)), 0.0], outs, period)
