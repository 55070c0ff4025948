"""Simulation results: time histories of parts, markers, joints, force elements and energies."""

from __future__ import annotations

import weakref
from dataclasses import dataclass
from functools import cached_property

import jax
import jax.numpy as jnp
import numpy as np

from ..assembly.constraints import joint_angle, joint_translation
from ..assembly.system import StateView, System, constraint_jacobian, constraints, kinematic_energy_terms, kinematics
from ..compile_cache import cached_jit, jit, tracing
from ..errors import ModelError, Status
from ..spatial.rotation import L_of_p, euler_zyx_deg
from ..solvers.initial import kkt_accelerations
from .joint_motion import QUANTITIES as JOINT_UNITS
from .joint_motion import joint_motion, marker_histories


class PartResult:
    """Time histories of one part (ground frame).

    position (n, 3) [m] COM · quaternion (n, 4) Euler parameters, scalar first · orientation
    (n, 3, 3) part axes → ground · euler_deg (n, 3) yaw-pitch-roll (Z-Y'-X'') [deg] · velocity
    (n, 3) [m/s] · angular_velocity (n, 3) [rad/s] · acceleration (n, 3) [m/s²] ·
    angular_acceleration (n, 3) [rad/s²]

    On concrete results everything is NumPy (no JAX dispatch, so no compilation on access);
    accelerations come from the post-processing compiled with the run (:attr:`Result.qdd`).
    """

    def __init__(self, result, name, b):
        self._res, self.name, self._b = result, name, b
        q = result._host("q")[:, 7 * b : 7 * b + 7]
        v = result._host("v")[:, 7 * b : 7 * b + 7]
        self._p = q[:, 3:]
        self.position = q[:, :3]
        self.quaternion = self._p
        self.velocity = v[:, :3]
        self.angular_velocity = _omega(self._p, v[:, 3:])

    @cached_property
    def orientation(self):
        from ..spatial.rotation import A_of_p

        return A_of_p(self._p)  # NumPy on a NumPy record (no JAX dispatch), jax.numpy when traced

    @cached_property
    def euler_deg(self):
        return None if isinstance(self._p, jax.core.Tracer) else euler_zyx_deg(np.asarray(self._p))

    @cached_property
    def acceleration(self):
        return self._res.qdd[:, 7 * self._b : 7 * self._b + 3]

    @cached_property
    def angular_acceleration(self):
        return _omega(self._p, self._res.qdd[:, 7 * self._b + 3 : 7 * self._b + 7])  # Ġṗ = 0


def _omega(p, pd):
    """ω = 2 G(p) ṗ = 2 (e0 ė − ė0 e + e × ė) (ground components), NumPy or JAX."""
    xp = jnp if isinstance(p, jax.core.Tracer) or isinstance(pd, jax.core.Tracer) else np
    e0, e, ed0, ed = p[:, :1], p[:, 1:], pd[:, :1], pd[:, 1:]
    return 2.0 * (e0 * ed - ed0 * e + xp.cross(e, ed))


@dataclass
class JointResult:
    """Reaction and motion of joint ``name`` (or motion, or coupler): the reaction on its part I
    (the first part), at marker I's origin, and the motion of marker I relative to marker J.

    ``force``/``torque`` [N, N m] in ground components; ``force_local``/``torque_local`` in
    marker-I axes; ``angle`` [rad], ``angular_velocity`` [rad/s] and ``angular_acceleration``
    [rad/s²] of I relative to J about z_J; ``translation`` [m], ``velocity`` [m/s] and
    ``acceleration`` [m/s²] along z_J (analyses/joint_motion.py has the formulas: each the time
    derivative of the one before, from the parts' accelerations of the equations of motion).
    All (n,) but the forces and torques (n, 3).
    """

    name: str
    force: np.ndarray
    torque: np.ndarray
    force_local: np.ndarray
    torque_local: np.ndarray
    angle: np.ndarray
    translation: np.ndarray
    angular_velocity: np.ndarray | None = None
    angular_acceleration: np.ndarray | None = None
    velocity: np.ndarray | None = None
    acceleration: np.ndarray | None = None


class ElementResult(dict):
    """Named per-element outputs (e.g. ``force``, ``deformation``, ``power``) as attributes."""

    def __getattr__(self, k):
        try:
            return self[k]
        except KeyError:
            raise AttributeError(f"element output '{k}' not available; have {sorted(self)}") from None


class Result:
    """Output of :func:`proleg.simulate`. Arrays are numpy (jax arrays under transformations)."""

    def __init__(self, system: System, t, q, v, w, z, *, stats=None, status=Status.SUCCESS, message="success", integrator=None):
        self.system = system
        self.t = np.asarray(t)
        self.q, self.v, self.w, self.z = q, v, w, z
        self.coordinates = "absolute"  # what the integrator ran on (simulate sets it)
        self.stats = {
            "steps": int(stats[0]) if stats is not None else 0,
            "rejected": int(stats[1]) if stats is not None else 0,
            "newton_iterations": int(stats[2]) if stats is not None else 0,
            "jacobians": int(stats[3]) if stats is not None and len(stats) > 3 else 0,
        }
        self.status = status
        self.message = message
        self.initial_changes = []  # parts whose pose/velocity the initial-conditions analysis changed
        self.integrator = integrator

    @property
    def ok(self) -> bool:
        return self.status == Status.SUCCESS

    def __len__(self):
        return len(self.t)

    def _np(self, x):
        return x if isinstance(x, jax.core.Tracer) else np.asarray(x)

    def _host(self, key):
        """``q``, ``v``, ``w`` or ``z`` as NumPy (once) on a concrete result; as is under tracing."""
        x = getattr(self, key)
        if isinstance(x, jax.core.Tracer):
            return x
        cache = self.__dict__.setdefault("_host_cache", {})
        if key not in cache or cache[key][0] is not x:
            cache[key] = (x, np.asarray(x))
        return cache[key][1]

    # -- accelerations, multipliers, reactions, element outputs, energies (note §5) -------------
    _compiled_post = None  # simulate(): the post-processing compiled with the run (or a Future of it)

    @cached_property
    def _post(self):
        args = (self.system, self.q, self.v, self.t, self.z)
        fn = self._compiled_post
        if hasattr(fn, "result"):
            fn = fn.result()
        if tracing(args):
            return post_batch(*args)
        out = None
        if fn is not None:
            try:
                out = fn(*args)
            except (TypeError, ValueError):  # shapes differ (a failed run, a partial result)
                out = None
        out = post_batch(*args) if out is None else out
        return jax.tree_util.tree_map(np.asarray, out)

    @property
    def qdd(self):
        return self._post["qdd"]

    @property
    def lam(self):
        return self._post["lam"]

    # -- names: which accessor reads what ---------------------------------------------------------
    def _kinds_of(self, key) -> list[tuple[str, str]]:
        """(what ``key`` names in the model, the accessor that reads it), for every element called
        ``key`` (a name may be a part's and a marker's at once)."""
        topo = self.system.topo
        out = []
        if key in topo.body_names:
            out.append(("a part", "part"))
        out += [_owner_kind(o) for o in topo.ct.owners if o.name == key]
        for g in topo.groups + topo.extensions:
            if key in getattr(g, "names", ()):
                out.append(_group_kind(g))
        flex = topo.flex
        if flex is not None and key in flex.names:
            out.append(("a flexible body", "deformation"))
        if key in topo.marker_names:
            out.append(("a marker", "marker"))
        return list(dict.fromkeys(out))

    def _names_of(self, accessor) -> list[str]:
        """The names ``result.<accessor>(name)`` accepts."""
        topo = self.system.topo
        if accessor == "part":
            return list(topo.body_names)
        if accessor == "marker":
            return list(topo.marker_names)
        if accessor in ("joint", "motion", "coupler"):
            owners = topo.ct.owners
            if accessor == "joint":
                return [o.name for o in owners]
            return [o.name for o in owners if _owner_kind(o)[1] == accessor]
        return [n for g in topo.groups + topo.extensions for n in getattr(g, "names", ())
                if accessor == "element" or _group_kind(g)[1] == accessor]

    def _not_found(self, key, accessor):
        """ModelError for ``result.<accessor>(key)`` where ``key`` is not of that kind: what it is
        and which accessor reads it, or the close matches; and the names the accessor accepts."""
        import difflib

        what, plural = _ACCESSOR_WORDS[accessor]
        model = self.system.topo.name
        names = self._names_of(accessor)
        others = [(w, a) for w, a in self._kinds_of(key) if a != accessor]
        if others:
            uses = " or ".join(f"result.{a}('{key}')" for _, a in others)
            msg = f"'{key}' is {' and '.join(w for w, _ in others)} of '{model}', not {_article(what)}: use {uses}."
        else:
            msg = f"No {what} named '{key}' in the result of '{model}'."
            close = difflib.get_close_matches(str(key), names, n=3, cutoff=0.5)
            if close:
                msg += f" Close matches: {close}."
        msg += f" Known {plural}: {names}." if names else f" The model has no {plural}."
        raise ModelError(msg)

    def _index(self, names, name, what, accessor=None):
        key = getattr(name, "name", name)
        if key not in names:
            self._not_found(key, accessor or what)
        return names.index(key)

    # -- parts ---------------------------------------------------------------------------------
    def part(self, name) -> PartResult:
        b = self._index(self.system.topo.body_names, name, "part")
        return PartResult(self, str(getattr(name, "name", name)), b)

    # -- markers -------------------------------------------------------------------------------
    @cached_property
    def _marker_kin(self):
        return _marker_batch(self.system, self.q, self.v)

    def marker(self, name):
        m = self._index(self.system.topo.marker_names, name, "marker")
        mk = self._marker_kin
        return ElementResult(position=self._np(mk.r[:, m]), velocity=self._np(mk.v[:, m]), orientation=self._np(mk.R[:, m]), angular_velocity=self._np(mk.w[:, m]))

    # -- joints --------------------------------------------------------------------------------
    @property
    def _reactions(self):
        return self._post["reactions"]

    def joint(self, name) -> JointResult:
        owners = [o.name for o in self.system.topo.ct.owners]
        k = self._index(owners, name, "joint", "joint")
        F, T, Fl, Tl, ang, tr = (x[:, k] for x in self._reactions)
        mo = self._owner_motion[k]
        return JointResult(str(getattr(name, "name", name)), *(self._np(x) for x in (F, T, Fl, Tl, ang, tr)),
                           **{q: mo[q] for q in ("angular_velocity", "angular_acceleration", "velocity", "acceleration")})

    @cached_property
    def _owner_motion(self) -> list[dict]:
        """analyses/joint_motion.py's six quantities for every constraint owner (joints, motions,
        couplers), in ``topo.ct.owners`` order."""
        mi, mj = _owner_markers(self.system.topo)
        kin = marker_histories(self, mi + mj)
        return [joint_motion(kin[a], kin[b]) for a, b in zip(mi, mj)]

    # -- force elements ------------------------------------------------------------------------
    @property
    def _element_outputs(self):
        return self._post["outputs"]

    def element_units(self):
        """{group kind: {output: unit}}, read by tracing the outputs once per model
        (``jax.eval_shape``: no compilation; simulate() does it in its outputs thread)."""
        return element_units(self.system, np.shape(self.z)[1])

    def element(self, name) -> ElementResult:
        """Outputs of the force element (or contact, actuator, controller) called ``name``."""
        return self._element(name, "element")

    def _element(self, name, accessor):
        key = getattr(name, "name", name)
        for g in self.system.topo.groups + self.system.topo.extensions:
            if key in getattr(g, "names", ()) and accessor in ("element", _group_kind(g)[1]):
                if g.kind == "controller":
                    return self.controller(key)
                k = g.names.index(key)
                return ElementResult({n: self._np(a[:, k]) for n, a in self._element_outputs[g.kind].items()})
        self._not_found(key, accessor)

    force = element

    def deformation(self, name):
        """Deformation coordinates η (n, n_eta) of a flexible body."""
        fg = self.system.topo.flex
        if fg is None or name not in fg.names:
            raise ModelError(f"No flexible body named '{name}' in the result.")
        k = fg.names.index(name)
        return self._host("q")[:, fg.off[k] : fg.off[k] + fg.bodies[k].n_eta]

    def stress(self, name) -> ElementResult:
        """Stress recovery of a flexible body built with ``stress=(points, fn)``: ``tensor`` (n, k, 3, 3)
        [Pa] and ``von_mises`` (n, k) [Pa] at its stress points."""
        body = self.system.topo.flex.bodies[self.system.topo.flex.names.index(name)] if self.system.topo.flex and name in self.system.topo.flex.names else None
        if body is None or body.stress_modes is None:
            raise ModelError(f"Flexible body '{name}' has no stress points: build it with stress=(points, fn).")
        sig = np.einsum("kabj,nj->nkab", body.stress_modes, np.asarray(self.deformation(name)))
        dev = sig - np.trace(sig, axis1=-2, axis2=-1)[..., None, None] * np.eye(3) / 3.0
        vm = np.sqrt(1.5 * np.sum(dev * dev, axis=(-2, -1)))
        return ElementResult(tensor=sig, von_mises=vm, points=body.stress_points)

    def contact(self, name) -> ElementResult:
        """normal_force (n,), friction_force (n, 3), force (n, 3) on the contacting part (= the GRF a
        force plate measures), penetration, penetration_rate, slip_velocity, in_contact, point.
        A name that is not a contact's is a ModelError saying what it is and what reads it."""
        return self._element(name, "contact")

    def actuator(self, name) -> ElementResult:
        """Outputs of a JointActuator (effort, command, coordinate, rate, power; a drive's current,
        voltages, ...), TranslationalActuator or HydraulicActuator (force, axial_force, command,
        length, velocity, power). A controller's name is a ModelError pointing to
        :meth:`controller` (what the servo commands), as is any other name that is not an actuator's."""
        return self._element(name, "actuator")

    def controller(self, name) -> ElementResult:
        """``output`` (the held command u [N m or N]) and ``state`` (the controller's z slice)."""
        key = getattr(name, "name", name)
        for g in self.system.topo.extensions:
            if g.kind == "controller" and key in g.names:
                k = g.names.index(key)
                off, size = g.slices[k]
                zs = self._host("z")[:, off : off + size]
                e = g.elements[k]
                out = zs[:, 0] if e.kind == "pid" else zs[:, e.z0.size :]
                res = ElementResult(output=self._np(out), state=self._np(zs))
                if e.kind == "pid":
                    res["command"] = self._np(zs[:, 2])
                return res
        self._not_found(key, "controller")

    def motion(self, name) -> ElementResult:
        """``effort``: the force [N] or torque [N m] the motion applies to the joint's part I along/about z."""
        key = getattr(name, "name", name)
        if key not in self._names_of("motion"):
            self._not_found(key, "motion")
        jr = self.joint(name)
        owners = self.system.topo.ct.owners
        m = next(o for o in owners if o.name == key)
        eff = jr.torque_local[:, 2] if m.dof == "rotation" else jr.force_local[:, 2]
        coord = jr.angle if m.dof == "rotation" else jr.translation
        return ElementResult(effort=self._np(eff), coordinate=self._np(coord), force=jr.force, torque=jr.torque)

    def coupler(self, name) -> ElementResult:
        """Reactions of a :class:`~proleg.model.couplers.Coupler` θ₁ = r θ₂, from its multiplier λ:
        ``torque_1`` on joint 1's part I about z_J1 (−λ) and ``torque_2`` on joint 2's part I
        about z_J2 (+r λ) [N m] (forces [N] for translations), ``coordinate_1``/``coordinate_2``."""
        key = getattr(name, "name", name)
        ct = self.system.topo.ct
        owners = [o.name for o in ct.owners]
        k = self._index(owners, key, "coupler", "coupler")
        cp = ct.owners[k]
        if getattr(cp, "kind", "") != "coupler":
            self._not_found(key, "coupler")
        rows = np.flatnonzero(ct.row_owner == k)
        if rows.size == 0:
            raise ModelError(f"Coupler '{key}': its equation was removed as redundant; its reaction is indeterminate.")
        lam = self._np(self.lam[:, int(rows[0])])
        start = ct.n_rows - ct.nbody - ct.cp_param.size  # the coupler rows come just before the normalizations
        ratio = float(np.asarray(self.system.params["coupler_ratio"])[ct.cp_param[int(rows[0]) - start]])
        c1, c2 = self.joint(cp.joint_1.name), self.joint(cp.joint_2.name)
        rot = cp.dof == "rotation"
        q1, q2 = (c1.angle, c2.angle) if rot else (c1.translation, c2.translation)
        key1, key2 = ("torque_1", "torque_2") if rot else ("force_1", "force_2")
        return ElementResult({key1: -lam, key2: ratio * lam, "coordinate_1": q1, "coordinate_2": q2, "multiplier": lam})

    # -- energies ------------------------------------------------------------------------------
    @cached_property
    def energy(self) -> ElementResult:
        """kinetic, potential, dissipated, input and total = T + V + dissipated − input [J]."""
        T, V = self._post["energy"]
        w = self._host("w")
        D, W = w[:, 0], w[:, 1]
        return ElementResult(kinetic=self._np(T), potential=self._np(V), dissipated=self._np(D), input=self._np(W), total=self._np(T + V + D - W))

    def constraint_residual(self):
        """max |Φ| at each output time."""
        return self._np(_residual_batch(self.system, self.q, jnp.asarray(self.t)))

    # -- export ----------------------------------------------------------------------------------
    def to_frame(self):
        """A pandas DataFrame with units in the column names (``"lower.x [m]"``): time; each part's
        position, Euler parameters, yaw-pitch-roll, velocity and angular velocity; each revolute,
        screw, cylindrical and prismatic joint's coordinate, rate and acceleration
        (``knee.angular_acceleration [rad/s²]``, :meth:`_joint_coordinate_columns`); every joint's
        and motion's reaction; every element's outputs (a joint element's in the unit of its own
        degree of freedom: ``knee_motor.effort [N m]``); every controller's output and command
        (``knee_servo.output [N m]``, :meth:`_controller_columns`); the energies."""
        import pandas as pd

        cols = {"time [s]": self.t}
        for name in self.system.topo.body_names:
            pr = self.part(name)
            for k, ax in enumerate("xyz"):
                cols[f"{name}.{ax} [m]"] = pr.position[:, k]
            for k in range(4):
                cols[f"{name}.e{k}"] = pr.quaternion[:, k]
            for k, ax in enumerate(("yaw", "pitch", "roll")):
                cols[f"{name}.{ax} [deg]"] = pr.euler_deg[:, k]
            for k, ax in enumerate("xyz"):
                cols[f"{name}.v{ax} [m/s]"] = pr.velocity[:, k]
            for k, ax in enumerate("xyz"):
                cols[f"{name}.w{ax} [rad/s]"] = pr.angular_velocity[:, k]
        cols.update(self._joint_coordinate_columns())
        for o in self.system.topo.ct.owners:
            jr = self.joint(o.name)
            for k, ax in enumerate("xyz"):
                cols[f"{o.name}.F{ax} [N]"] = jr.force[:, k]
            for k, ax in enumerate("xyz"):
                cols[f"{o.name}.T{ax} [N m]"] = jr.torque[:, k]
        units = self.element_units()
        for g in self.system.topo.groups + self.system.topo.extensions:
            if not (len(g) and hasattr(g, "outputs")) or g.kind == "controller":
                continue
            for k_el, n in enumerate(g.names):
                er = self.element(n)
                for key, arr in er.items():
                    u = _one_unit(units[g.kind][key], getattr(g, "rot", None), k_el)
                    arr = np.asarray(arr)
                    if arr.ndim == 1:
                        cols[f"{n}.{key} [{u}]"] = arr
                    else:
                        for k in range(arr.shape[1]):
                            cols[f"{n}.{key}_{'xyzabc'[k] if arr.shape[1] <= 6 else k} [{u}]"] = arr[:, k]
        cols.update(self._controller_columns(self._actuator_units()))
        e = self.energy
        for k in ("kinetic", "potential", "dissipated", "input", "total"):
            cols[f"energy.{k} [J]"] = e[k]
        df = pd.DataFrame(cols)
        df.attrs["proleg.viewer"] = viewer_topology(self.system)
        return df

    def _joint_coordinate_columns(self) -> dict:
        """The coordinate, rate and acceleration of every revolute, screw, cylindrical and
        prismatic joint: ``NAME.angle [rad]``, ``NAME.angular_velocity [rad/s]`` and
        ``NAME.angular_acceleration [rad/s²]`` (rotation of marker I relative to J about z_J, as
        :meth:`joint`'s ``angle``: zero at the modelled pose, or the URDF's position and sign for
        an imported joint, in (−π, π]), ``NAME.translation [m]``, ``NAME.velocity [m/s]`` and
        ``NAME.acceleration [m/s²]`` (along z_J). Each is the time derivative of the one before
        (analyses/joint_motion.py), the accelerations from the parts' accelerations of the
        equations of motion (:attr:`qdd`), not from differences of outputs."""
        topo = self.system.topo
        rot, trans = ("revolute", "screw", "cylindrical"), ("prismatic", "cylindrical")
        if isinstance(self.q, jax.core.Tracer):
            return {}
        index = {id(o): k for k, o in enumerate(topo.ct.owners)}
        joints = [j for j in topo.joints if getattr(j, "kind", "") in rot + trans and id(j) in index]
        if not joints:
            return {}
        motion = self._owner_motion
        cols = {}
        for j in joints:
            mo = motion[index[id(j)]]
            keys = (("angle", "angular_velocity", "angular_acceleration") if j.kind in rot else ()) + (
                ("translation", "velocity", "acceleration") if j.kind in trans else ())
            for q in keys:
                cols[f"{j.name}.{q} [{JOINT_UNITS[q]}]"] = np.asarray(mo[q])
        return cols

    def _controller_columns(self, units) -> dict:
        """``NAME.output [N m]`` (or [N]) of every controller — what a PID holds, u, in the unit of
        its joint (N m about a rotation, N along a translation) — and ``NAME.command [unit]``,
        what its actuator receives (u / lever_arm for a cylinder [N]); a DiscreteController's
        or StateMachine's ``NAME.output_ACTUATOR [unit]`` per actuator it drives, in that
        actuator's unit."""
        cols = {}
        for g in self.system.topo.extensions:
            if g.kind != "controller" or not len(g):
                continue
            k_pid = 0
            for e in g.elements:
                res = self.controller(e.name)
                if e.kind == "pid":
                    u_out = "N m" if bool(g.pid_rot[k_pid]) else "N"
                    k_pid += 1
                    cols[f"{e.name}.output [{u_out}]"] = np.asarray(res["output"])
                    cols[f"{e.name}.command [{units.get(e.actuator_ref, u_out)}]"] = np.asarray(res["command"])
                else:
                    out = np.asarray(res["output"]).reshape(len(self.t), -1)
                    for k, a in enumerate(e.outputs):
                        cols[f"{e.name}.output_{a} [{units.get(a, '-')}]"] = out[:, k]
        return cols

    def _actuator_units(self) -> dict:
        """{actuator name: unit of its command}: N m for a JointActuator on a rotation, N otherwise."""
        out = {}
        for g in self.system.topo.extensions:
            if g.kind in _ACTUATOR_KINDS:
                rot = getattr(g, "rot", np.zeros(len(g), bool))
                out.update({n: ("N m" if bool(r) else "N") for n, r in zip(g.names, rot)})
        return out

    def to_parquet(self, path):
        """Write :meth:`to_frame` to Parquet (pyarrow); returns the path.

        Missing folders are created; the file is written under a temporary name and renamed into
        place (atomic on POSIX), so a killed process never leaves half a file. An unwritable
        target is a :class:`~proleg.errors.DataError` before the table is computed.
        """
        from .checks import writable

        path = writable(path, "to_parquet")
        df = self.to_frame()  # its attrs (the viewer's joint and spring markers) go into the file's metadata
        _atomic_parquet(df, path)
        return path

    def plot(self, *columns, ax=None):
        """Quick look: plot columns of :meth:`to_frame` (substring match) against time, one
        y axis per unit, so that a height [m] and a force [N] are both readable.

        Without ``ax``: one subplot per unit, stacked and sharing the time axis, each labelled
        with its unit. With ``ax``: the first unit on ``ax``, each further unit on a twin axis of
        it (``ax.twinx()``; a third or more offset to the right). Returns the first (top) axis;
        ``ax.figure`` is the whole figure and ``ax.figure.axes`` lists every axis. A name that
        matches no column is a :class:`~proleg.errors.ProlegWarning` naming the closest columns
        (nothing is plotted for it).
        """
        import matplotlib

        matplotlib.use("Agg", force=False)
        import matplotlib.pyplot as plt

        df = self.to_frame()
        for s in columns:
            if not any(s in c for c in df.columns):
                import difflib

                from .checks import warn

                near = difflib.get_close_matches(s, list(df.columns), n=3, cutoff=0.3)
                warn(f"Result.plot: '{s}' matches no output column of '{self.system.topo.name}'"
                     + (f"; closest: {near}" if near else "") + ". result.to_frame().columns lists them.")
        sel = [c for c in df.columns if any(s in c for s in columns)] if columns else list(df.columns[1:4])
        sel = [c for c in sel if c != "time [s]"]
        by_unit = {}
        for c in sel:
            by_unit.setdefault(_column_unit(c), []).append(c)
        n = max(len(by_unit), 1)
        if ax is None:
            fig, axes = plt.subplots(n, 1, figsize=(7, 2.2 + 1.8 * n), sharex=True, squeeze=False)
            axes = list(axes[:, 0])
            axes[-1].set_xlabel("time [s]")
        else:
            axes = [ax] + [ax.twinx() for _ in range(n - 1)]
            for k, tw in enumerate(axes[2:], start=1):
                tw.spines["right"].set_position(("axes", 1.0 + 0.12 * k))
            ax.set_xlabel("time [s]")
        t = df["time [s]"]
        cycle = matplotlib.rcParams["axes.prop_cycle"].by_key().get("color", ["C0"])
        k_line = 0
        for a, (unit, cols) in zip(axes, by_unit.items()):
            for c in cols:
                a.plot(t, df[c], label=c, color=cycle[k_line % len(cycle)])
                k_line += 1
            a.set_ylabel(f"[{unit}]")
        if ax is None:
            for a in axes:
                if a.lines:
                    a.legend(fontsize=7)
                a.grid(alpha=0.3)
        else:
            lines = [ln for a in axes for ln in a.lines]
            if lines:
                ax.legend(lines, [ln.get_label() for ln in lines], fontsize=7)
            ax.grid(alpha=0.3)
        return axes[0]

    def __repr__(self):
        return f"Result({self.system.topo.name!r}: {len(self.t)} outputs to t = {self.t[-1]:.4g} s, {self.stats['steps']} steps, {self.message})"


# accessor → (what one name is, what the names are), for the errors of the accessors
_ACCESSOR_WORDS = {
    "part": ("part", "parts"), "marker": ("marker", "markers"), "joint": ("joint or motion", "joints and motions"),
    "motion": ("motion", "motions"), "coupler": ("coupler", "couplers"), "contact": ("contact", "contacts"),
    "actuator": ("actuator", "actuators"), "controller": ("controller", "controllers"),
    "element": ("force element, contact, actuator or controller", "elements"),
}
_ACTUATOR_KINDS = ("joint_actuator", "translational_actuator", "hydraulic_actuator")


def _column_unit(column: str) -> str:
    """The unit of a :meth:`Result.to_frame` column, ``"lower.z [m]"`` → ``"m"``; "-" if none."""
    if column.endswith("]") and " [" in column:
        return column[column.rindex(" [") + 2 : -1]
    return "-"


def _one_unit(unit: str, rot, k: int) -> str:
    """A joint element's output unit for its own degree of freedom: ``"N m|N"`` (rotation or
    translation) becomes ``"N m"`` on a rotation (``rot[k]``), ``"N"`` on a translation."""
    if "|" not in unit or rot is None:
        return unit
    options = unit.split("|")
    rotational = [o for o in options if "rad" in o or "N m" in o]
    other = [o for o in options if o not in rotational]
    if bool(rot[k]):
        return rotational[0] if rotational else unit
    return other[0] if other else unit


def _article(what: str) -> str:
    return ("an " if what[:1] in "aeiou" else "a ") + what


def _group_kind(g) -> tuple[str, str]:
    """(what an element of group ``g`` is, the Result accessor that reads it)."""
    if g.kind == "contact":
        return "a contact", "contact"
    if g.kind == "controller":
        return "a controller", "controller"
    if g.kind in _ACTUATOR_KINDS:
        return _article(g.kind.replace("_", " ")), "actuator"
    return _article(f"{g.kind.replace('_', ' ')} element"), "element"


def _owner_kind(o) -> tuple[str, str]:
    """(what constraint owner ``o`` is, the Result accessor that reads it)."""
    kind = getattr(o, "kind", None)
    if kind == "coupler":
        return "a coupler", "coupler"
    if type(o).__name__ == "Motion":
        return "a motion", "motion"
    return (f"a {kind} joint" if kind else "a joint"), "joint"


_UNITS = weakref.WeakKeyDictionary()  # topology → {group kind: {output: unit}}


def element_units(system: System, nz: int) -> dict:
    """{group kind: {output: unit}} of ``system``'s element outputs (``nz``: controller states)."""
    topo = system.topo
    if topo in _UNITS:
        return _UNITS[topo]
    out = {}

    def f(q, v, t, z):
        bk, mk = kinematics(system, q, v)
        ctx = StateView(topo, bk, mk, t, z, system.params)
        for g in topo.groups + topo.extensions:
            if len(g) and hasattr(g, "outputs"):
                out[g.kind] = {k: unit for k, (val, unit) in g.outputs(system.params, mk, t, ctx).items()}
        return 0.0

    q = jax.ShapeDtypeStruct((system.nq,), jnp.float64)
    jax.eval_shape(f, q, q, jax.ShapeDtypeStruct((), jnp.float64), jax.ShapeDtypeStruct((nz,), jnp.float64))
    _UNITS[topo] = out
    return out


def _joint_reactions_one(system: System, qk, tk, lk, Pq=None, kin=None):
    """Reactions on part I of every constraint owner (joints, then motions) at one time, note §5:
    (F, T, F_local, T_local, angle, translation), each (nowner, ...). ``Pq`` (Φ_q at (qk, tk))
    and ``kin`` (``kinematics(system, qk, ...)``): already evaluated, if the caller has them."""
    topo = system.topo
    ct = topo.ct
    nowner = len(ct.owners)
    if nowner == 0:
        z = jnp.zeros((0, 3))
        return z, z, z, z, jnp.zeros(0), jnp.zeros(0)
    mi, mj = (np.array(m, int) for m in _owner_markers(topo))
    masks = np.stack([(ct.row_owner == k).astype(float) for k in range(nowner)])
    bi = topo.marker_body[mi]
    bj = topo.marker_body[mj]
    nb = topo.nbody
    if Pq is None:
        _, vjp = jax.vjp(lambda qq: constraints(system, qq, tk), qk)
        Qc = -jax.vmap(lambda m: vjp(lk * m)[0])(jnp.asarray(masks))  # (nowner, nq)
    else:
        Qc = -(jnp.asarray(masks) * lk) @ Pq
    bk, mk = kinematics(system, qk) if kin is None else kin
    Qb = Qc[:, : 7 * nb].reshape(nowner, nb, 7)

    def side(b, m):
        bb = jnp.minimum(b, nb - 1)
        Fb = Qb[jnp.arange(nowner), bb, :3]
        Qp = Qb[jnp.arange(nowner), bb, 3:]
        L = L_of_p(bk.p[bb])
        n_body = 0.5 * jnp.einsum("nij,nj->ni", L, Qp)
        A = bk.A[bb]
        s = system.params["marker_s"][m]
        n_m = n_body - jnp.cross(s, jnp.einsum("nji,nj->ni", A, Fb))
        return Fb, jnp.einsum("nij,nj->ni", A, n_m)

    FI, TI = side(jnp.asarray(bi), jnp.asarray(mi))
    FJ, TJ = side(jnp.asarray(bj), jnp.asarray(mj))
    rI, rJ = mk.r[mi], mk.r[mj]
    FI_from_J = -FJ
    TI_from_J = -TJ - jnp.cross(rI - rJ, FI_from_J)
    ground_i = jnp.asarray(bi == nb)[:, None]
    F = jnp.where(ground_i, FI_from_J, FI)
    T = jnp.where(ground_i, TI_from_J, TI)
    RI, RJ = mk.R[mi], mk.R[mj]
    Fl = jnp.einsum("nji,nj->ni", RI, F)
    Tl = jnp.einsum("nji,nj->ni", RI, T)
    return F, T, Fl, Tl, joint_angle(RI, RJ), joint_translation(rI, rJ, RJ)


# force elements drawn as lines between their markers (report/animate.py LINE_KINDS)
_LINE_KINDS = ("spring_damper", "hydraulic_actuator", "translational_actuator", "bushing")


def viewer_topology(system: System) -> dict:
    """What the viewer needs besides the part poses to draw a result file without its model
    (``to_frame().attrs["proleg.viewer"]``, stored by :meth:`Result.to_parquet` with the table):
    each joint's two markers and each spring, actuator and bushing's two markers as
    ``[part, local position (3,) [m]]`` (part ``"ground"``: the position in ground), contact
    radii [m]. Marker positions are in the part frame (COM origin, part axes) at the modelled
    geometry; a flexible part's markers are drawn rigidly attached."""
    topo = system.topo
    S = system.params.get("marker_s")
    if S is None or isinstance(S, jax.core.Tracer):
        return {}
    S = np.asarray(S)
    index = {n: k for k, n in enumerate(topo.marker_names)}
    nb = topo.nbody

    def at(marker):
        k = index.get(getattr(marker, "name", None))
        if k is None:
            return None
        b = int(topo.marker_body[k])
        return ["ground" if b >= nb else topo.body_names[b], [float(x) for x in S[k]]]

    joints = []
    for j in topo.joints:
        ends = [at(getattr(j, "marker_i", None)), at(getattr(j, "marker_j", None))]
        if None not in ends:
            joints.append({"name": j.name, "kind": getattr(j, "kind", "joint"), "i": ends[0], "j": ends[1]})
    lines = []
    model = topo.model
    elements = list(getattr(model, "forces", [])) + list(getattr(model, "actuators", [])) if model is not None else []
    for e in elements:
        if getattr(e, "kind", None) in _LINE_KINDS:
            ends = [at(getattr(e, "i", None)), at(getattr(e, "j", None))]
            if None not in ends:
                lines.append({"name": e.name, "kind": e.kind, "i": ends[0], "j": ends[1]})
    radii = {c.name: float(c.radius) for c in getattr(model, "contacts", [])} if model is not None else {}
    return {"joints": joints, "lines": lines, "contact_radius": radii}


def _owner_markers(topo):
    mi, mj = [], []
    idx = {n: k for k, n in enumerate(topo.marker_names)}
    for o in topo.ct.owners:
        mi.append(idx[o.marker_i.name])
        mj.append(idx[o.marker_j.name])
    return mi, mj


# Module-level compiled post-processing: the System is an argument (its topology is static), so
# every Result of the same model reuses the same executables.
def _one_outputs(system, q, v, t, z, kin=None):
    bk, mk = kinematics(system, q, v) if kin is None else kin
    ctx = StateView(system.topo, bk, mk, t, z, system.params)
    return {
        g.kind: {k: val for k, (val, unit) in g.outputs(system.params, mk, t, ctx).items()}
        for g in system.topo.groups + system.topo.extensions
        if len(g) and hasattr(g, "outputs")
    }


def _post_one(system, q, v, t, z):
    """Everything a table needs at one output: accelerations and multipliers (KKT, note §5), joint
    reactions, element outputs, kinetic and potential energy."""
    Pq = constraint_jacobian(system, q, t)
    qdd, lam = kkt_accelerations(system, q, v, t, z, Pq=Pq)
    T, V = kinematic_energy_terms(system, q, v, t, z)
    kin = kinematics(system, q, v)
    return {"qdd": qdd, "lam": lam, "reactions": _joint_reactions_one(system, q, t, lam, Pq, kin),
            "outputs": _one_outputs(system, q, v, t, z, kin), "energy": (T, V)}


# One executable for all the post-processing of a run (one compile per model and output count):
# simulate() compiles it while the run compiles (prepare_outputs), so the first table costs no
# second compile.
post_batch = cached_jit(jax.vmap(_post_one, in_axes=(None, 0, 0, 0, 0)), xla="loop")
_marker_batch = jit(jax.vmap(lambda s, q, v: kinematics(s, q, v)[1], in_axes=(None, 0, 0)))
_residual_batch = jit(jax.vmap(lambda s, q, t: jnp.max(jnp.abs(constraints(s, q, t))), in_axes=(None, 0, 0)))
_outputs_batch = jit(jax.vmap(_one_outputs, in_axes=(None, 0, 0, 0, 0)))


def _atomic_parquet(df, path) -> None:
    """``df.to_parquet(path)`` through a temporary file in the same folder and ``os.replace``."""
    import os
    import uuid

    tmp = path.with_name(f".tmp-{uuid.uuid4().hex[:8]}-{path.name}")
    try:
        df.to_parquet(tmp, index=False)
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


class ChunkStore:
    """Streams a run's state to a Parquet dataset as it goes (``simulate(..., store=path)``).

    ``path`` becomes a folder holding ``part-00000.parquet``, ``part-00001.parquet``, ... — one
    file per finished chunk, each written atomically (temporary name, then ``os.replace``), so
    that ``pandas.read_parquet(path)`` reads every finished chunk even if the process was
    killed. The rows are the full state, lossless and cheap to write (no output is computed per
    chunk): ``time [s]``, per part ``<part>.x [m]`` ... ``<part>.e3`` and their rates
    ``<part>.vx [m/s]`` ... ``<part>.de3 [1/s]`` (modal coordinates ``eta[k]``, ``deta[k]``),
    ``energy.dissipated [J]``, ``energy.input [J]`` and controller states ``z[k]``.
    :func:`read_store` turns it back into a :class:`Result` (every output accessor). Part files
    of an earlier run in the same folder are removed when a run starts. Called as ``on_chunk``
    (it forwards to the user's own ``on_chunk``).
    """

    def __init__(self, path, on_chunk=None):
        from .checks import writable

        self.path = writable(path, "simulate(store=...)", folder=True).parent
        for old in list(self.path.glob("part-*.parquet")) + list(self.path.glob(".tmp-*")):
            old.unlink()
        self.on_chunk, self.written, self.files = on_chunk, 0, 0

    def write(self, result: Result) -> None:
        """Write the rows of ``result`` not yet written (one new part file)."""
        n = len(result.t)
        if n <= self.written:
            return
        _atomic_parquet(state_frame(result, self.written, n), self.path / f"part-{self.files:05d}.parquet")
        self.written, self.files = n, self.files + 1

    def __call__(self, result: Result) -> None:
        self.write(result)
        if self.on_chunk is not None:
            self.on_chunk(result)


def _state_columns(topo) -> tuple[list[str], list[str]]:
    qc, vc = [], []
    for b in topo.body_names:
        qc += [f"{b}.{a} [m]" for a in "xyz"] + [f"{b}.e{k}" for k in range(4)]
        vc += [f"{b}.v{a} [m/s]" for a in "xyz"] + [f"{b}.de{k} [1/s]" for k in range(4)]
    qc += [f"eta[{k}]" for k in range(topo.n_eta)]
    vc += [f"deta[{k}]" for k in range(topo.n_eta)]
    return qc, vc


def state_frame(result: Result, start: int = 0, stop: int | None = None):
    """The raw state of outputs ``start:stop`` as a DataFrame (the columns of :class:`ChunkStore`)."""
    import pandas as pd

    sl = slice(start, stop)
    qc, vc = _state_columns(result.system.topo)
    q, v = np.asarray(result.q[sl]), np.asarray(result.v[sl])
    w, z = np.asarray(result.w[sl]), np.asarray(result.z[sl])
    cols = {"time [s]": result.t[sl]}
    cols.update({c: q[:, k] for k, c in enumerate(qc)})
    cols.update({c: v[:, k] for k, c in enumerate(vc)})
    cols["energy.dissipated [J]"], cols["energy.input [J]"] = w[:, 0], w[:, 1]
    cols.update({f"z[{k}]": z[:, k] for k in range(z.shape[1])})
    return pd.DataFrame(cols)


def read_store(system: System, path) -> Result:
    """The :class:`Result` of the chunks a ``simulate(..., store=path)`` run wrote (all of them,
    or those finished before it was stopped). ``system`` is the one that was simulated."""
    import pandas as pd

    from ..errors import DataError

    import os
    from pathlib import Path

    try:
        where = Path(os.fspath(path))
    except TypeError:
        raise DataError(f"read_store: the store path must be a str or os.PathLike, got {path!r}.") from None
    if not where.exists():
        raise DataError(
            f"read_store: there is no store at '{where}' (no such file or folder). Give the folder that "
            "simulate(..., store=...) wrote, holding part-00000.parquet, ...; it is created when that run starts."
        )
    if where.is_dir() and not any(where.glob("*.parquet")):
        raise DataError(f"read_store: the folder '{where}' holds no Parquet part files (part-00000.parquet, ...): "
                        "no chunk of the run finished, or it is not a simulate(..., store=...) folder.")
    try:
        df = pd.read_parquet(where)
    except (OSError, ValueError) as exc:
        raise DataError(f"read_store: cannot read the store '{where}' as Parquet: {type(exc).__name__}: {exc}.") from None
    qc, vc = _state_columns(system.topo)
    missing = [c for c in ["time [s]", *qc, *vc] if c not in df.columns]
    if missing:
        raise DataError(f"read_store: '{path}' was not written for model '{system.topo.name}' (no column {missing[0]!r}).")
    zc = [c for c in df.columns if c.startswith("z[")]
    return Result(system, df["time [s]"].to_numpy(), jnp.asarray(df[qc].to_numpy()), jnp.asarray(df[vc].to_numpy()),
                  jnp.asarray(df[["energy.dissipated [J]", "energy.input [J]"]].to_numpy()),
                  jnp.asarray(df[zc].to_numpy().reshape(len(df), len(zc))), message=f"read from {path}")
