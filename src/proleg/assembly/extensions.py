"""Contacts, actuators and sampled controllers as element groups (issue: contacts, motions,
actuators, drives and discrete controllers).

Controllers own a slice of the discrete state ``z`` (carried by the solver, updated at their
sample times, held in between: zero-order hold). Actuators read their command from ``z``.
"""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np

from ..contact_law import friction_vector, normal_force
from ..errors import ModelError
from ..fn import _safe_pow
from ..model.forces import _callable_arity
from .constraints import _frames, _oh, joint_coordinate
from .kinematics import StateView, kinematics
from .elements import AbstractGroup, TwoMarkerGroup, pair_loads


# ---------------------------------------------------------------------------------------------
class ContactGroup(AbstractGroup):
    kind = "contact"

    def __init__(self, elements, marker_index, nm):
        super().__init__(elements, marker_index, nm)
        self.oh_i = _oh([marker_index[id(e.marker)] for e in self.elements], nm)
        self.oh_j = _oh([marker_index[id(e.plane)] for e in self.elements], nm)
        self.cyl = np.array([e.kind == "cylinder" for e in self.elements], bool)
        self.body = [e.marker.part.name for e in self.elements]

    def params(self):
        e = self.elements
        f = lambda a: np.array([getattr(x, a) for x in e], float)
        return {f"contact_{a}": f(a) for a in ("radius", "stiffness", "exponent", "damping", "penetration", "mu_static", "mu_dynamic", "v_stiction", "v_friction")}

    def elements_on_body(self, body_name):
        """Names of the contacts whose contacting marker is on part ``body_name`` (for failure messages)."""
        return [e.name for e in self.elements if body_name in (e.marker.part.name, e.plane.part.name)]

    def _law(self, P, mk):
        c = self.oh_i @ mk.r
        RI = _frames(self.oh_i, mk)
        RP = _frames(self.oh_j, mk)
        n = RP[:, :, 2]
        o = self.oh_j @ mk.r
        R = P["contact_radius"]
        a = RI[:, :, 2]
        u = n - jnp.sum(n * a, -1, keepdims=True) * a
        u = u / jnp.sqrt(jnp.sum(u * u, -1, keepdims=True) + 1e-300)
        dirn = jnp.where(self.cyl[:, None], u, n)
        p = c - R[:, None] * dirn
        g = -jnp.sum(n * (p - o), -1)
        wI, wJ = self.oh_i @ mk.w, self.oh_j @ mk.w
        vp = self.oh_i @ mk.v + jnp.cross(wI, p - c)
        vq = self.oh_j @ mk.v + jnp.cross(wJ, p - o)
        vrel = vp - vq
        vn = jnp.sum(n * vrel, -1)
        vt = vrel - vn[:, None] * n
        gd = -vn
        Fn = normal_force(g, gd, P["contact_stiffness"], P["contact_exponent"], P["contact_damping"], P["contact_penetration"])
        mu_vec = friction_vector(vt, P["contact_mu_static"][:, None], P["contact_mu_dynamic"][:, None], P["contact_v_stiction"][:, None], P["contact_v_friction"][:, None])
        Ft = -Fn[:, None] * mu_vec
        F = Fn[:, None] * n + Ft
        return c, p, n, g, gd, vt, vrel, Fn, Ft, F

    def loads(self, P, mk, t, ctx):
        c, p, n, g, gd, vt, vrel, Fn, Ft, F = self._law(P, mk)
        T = jnp.cross(p - c, F)
        return pair_loads(self.oh_i, self.oh_j, F, T, self.oh_i @ mk.r - self.oh_j @ mk.r)

    def _elastic(self, P, g):
        e = P["contact_exponent"]
        return jnp.where(g > 0, P["contact_stiffness"] * _safe_pow(g, e + 1.0) / (e + 1.0), 0.0)

    def potential(self, P, mk, t, ctx):
        c, p, n, g, *_ = self._law(P, mk)
        return jnp.sum(self._elastic(P, g))

    def dissipation(self, P, mk, t, ctx):
        c, p, n, g, gd, vt, vrel, Fn, Ft, F = self._law(P, mk)
        k_el = jnp.where(g > 0, P["contact_stiffness"] * _safe_pow(g, P["contact_exponent"]), 0.0)
        return jnp.sum((Fn - k_el) * gd - jnp.sum(Ft * vt, -1))

    def outputs(self, P, mk, t, ctx):
        c, p, n, g, gd, vt, vrel, Fn, Ft, F = self._law(P, mk)
        return {
            "normal_force": (Fn, "N"),
            "friction_force": (Ft, "N"),
            "force": (F, "N"),
            "penetration": (g, "m"),
            "penetration_rate": (gd, "m/s"),
            "slip_velocity": (jnp.sqrt(jnp.sum(vt * vt, -1)), "m/s"),
            "in_contact": ((g > 0).astype(jnp.float64), "-"),
            "point": (p, "m"),
        }


# ---------------------------------------------------------------------------------------------
class ControllerGroup(AbstractGroup):
    """PIDs and general discrete controllers; ``z`` slices assigned at assembly."""

    kind = "controller"
    _structure_fields = ("period",)  # the controllers' clock (model/control.py PID)

    def __init__(self, elements, marker_index, nm, offset=0):
        super().__init__(elements, marker_index, nm)
        self.slices = []
        self.out_index = {}  # actuator name -> z index of its command
        off = offset
        for e in self.elements:
            if e.kind == "pid":
                size = 3  # [u, integral of error, actuator command]
                self.out_index[e.actuator_ref] = off + 2
            else:
                size = e.z0.size + len(e.outputs)
                for k, a in enumerate(e.outputs):
                    self.out_index[a] = off + e.z0.size + k
            self.slices.append((off, size))
            off += size
        self.size = off - offset
        pids = [e for e in self.elements if e.kind == "pid"]
        self.pid_oh_i = _oh([marker_index[id(e.joint.marker_i)] for e in pids], nm)
        self.pid_oh_j = _oh([marker_index[id(e.joint.marker_j)] for e in pids], nm)
        self.pid_rot = np.array([e.dof == "rotation" for e in pids], bool)
        self.period = min((e.period for e in self.elements), default=None)
        self.actuators = {}  # name -> actuator element (filled by the hook)

    def params(self):
        pids = [e for e in self.elements if e.kind == "pid"]
        out = {}
        dz = [e.z0 for e in self.elements if e.kind != "pid"]
        if dz:  # the discrete controllers' initial states: numbers, so a design may change them
            out["controller_state0"] = np.concatenate(dz)
        if not pids:
            return out
        # Every number the sample reads is a parameter, so that a new gain, set point, limit,
        # lever or valve lag is a new argument, not a new compile (issue 42). Which of them a PID
        # has (a set point or none, a limit or none, a constant or a callable lever, a valve
        # lag or none) is structure: the unused entries hold a neutral value and are never read.
        def num(x, neutral):
            return neutral if x is None or callable(x) else float(x)

        taus = [getattr(self.actuators.get(e.actuator_ref), "valve_time_constant", None) for e in pids]
        return out | {
            "controller_kp": np.array([e.kp for e in pids]),
            "controller_kd": np.array([e.kd for e in pids]),
            "controller_ki": np.array([e.ki for e in pids]),
            "controller_setpoint": np.array([num(e.setpoint, 0.0) for e in pids]),
            "controller_output_limit": np.array([num(e.output_limit, np.inf) for e in pids]),
            "controller_lever_arm": np.array([num(e.lever_arm, 1.0) for e in pids]),
            "controller_valve_time_constant": np.array([num(t, 1.0) for t in taus]),
        }

    def element_params(self):
        """The PIDs' numbers index the PIDs only (``controller_kp[k]``: the k-th PID), and a
        discrete controller's ``state0`` is its slice of ``controller_state0`` (its own initial
        state, any length); a discrete controller has no gains, a PID no ``state0``."""
        keys = [k for k in self.params() if k != "controller_state0"]
        out, k, pid = {}, 0, 0
        for e in self.elements:
            if e.kind == "pid":
                out.update({f"{e.name}.{key[len(self.kind) + 1:]}": (key, pid) for key in keys})
                pid += 1
            else:
                out[f"{e.name}.state0"] = ("controller_state0", slice(k, k + e.z0.size))
                k += e.z0.size
        return out

    def z0(self, P):
        """The controllers' initial z: a PID's [u, ∫e, command] zero, a discrete controller's
        own initial state from ``P["controller_state0"]`` (so that a trace reads no model
        number: issue 42) and its outputs zero."""
        # NumPy where the parameters are (no eager JAX op, each a small compile), else traced
        xp = np if isinstance(P.get("controller_state0", np.zeros(0)), np.ndarray) else jnp
        parts, k = [], 0
        for e in self.elements:
            if e.kind == "pid":
                parts.append(xp.zeros(3))
            else:
                parts.append(xp.concatenate([P["controller_state0"][k : k + e.z0.size], xp.zeros(len(e.outputs))]))
                k += e.z0.size
        return xp.concatenate(parts) if parts else xp.zeros(0)

    def sample(self, P, t, q, v, z, system, first=False, kin=None):
        """z after a sample at t: every controller whose clock ticks at t (or all, ``first``)
        updates its slice. ``kin``: the (body, marker) kinematics at the state, where the
        caller has them (joint coordinates: no round trip through absolute coordinates).

        The PIDs are one vectorised law over all of them (set points, limits, levers and valve
        lags from ``params``; a callable set point or lever is evaluated per PID), written into
        z by one gather, so that a robot with a servo per joint costs a few kernels a sample, not
        a few per servo; general discrete controllers run their own update each."""
        bk, mk = kin if kin is not None else kinematics(system, q, v)
        view = StateView(system.topo, bk, mk, t, z, system.params)
        pids = [e for e in self.elements if e.kind == "pid"]
        z_new = z
        if pids:
            z_new = self._sample_pids(P, t, z, system, first, view, mk, pids)
        for e, (off, size) in zip(self.elements, self.slices):
            if e.kind == "pid":
                continue
            tick = jnp.abs(t / e.period - jnp.round(t / e.period)) < 1e-7
            zi, outs = e.update(t, view, z[off : off + e.z0.size])
            zi = jnp.atleast_1d(jnp.asarray(zi, jnp.float64))
            if zi.shape != (e.z0.size,):
                raise ModelError(f"DiscreteController '{e.name}': update returned state of shape {zi.shape}; expected ({e.z0.size},).")
            missing = set(e.outputs) - set(outs)
            if missing:
                raise ModelError(f"DiscreteController '{e.name}': update did not return outputs {sorted(missing)}.")
            new = jnp.concatenate([zi, jnp.stack([jnp.asarray(outs[a], jnp.float64) for a in e.outputs])])
            z_new = z_new.at[off : off + size].set(jnp.where(tick | first, new, z[off : off + size]))
        return z_new

    def _sample_pids(self, P, t, z, system, first, view, mk, pids):
        """The PIDs' sample (:meth:`sample`): z with each ticking PID's [u, ∫e, command] new."""
        th, th_d, _, _ = joint_coordinate(self.pid_oh_i, self.pid_oh_j, self.pid_rot, mk)
        offs = np.array([off for e, (off, _) in zip(self.elements, self.slices) if e.kind == "pid"])
        period = np.array([e.period for e in pids], float)
        if any(callable(e.setpoint) for e in pids):
            sp = jnp.stack([
                jnp.asarray(e.setpoint(t) if _callable_arity(e.setpoint) <= 1 else e.setpoint(t, view), jnp.float64).reshape(())
                if callable(e.setpoint) else (system.params["controller_setpoint0"][k] if e.setpoint is None else P["controller_setpoint"][k])
                for k, e in enumerate(pids)
            ])
        elif all(e.setpoint is not None for e in pids):
            sp = P["controller_setpoint"]
        else:
            none = np.array([e.setpoint is None for e in pids])
            sp = jnp.where(none, system.params["controller_setpoint0"], P["controller_setpoint"])
        err = sp - th
        integ = z[offs + 1] + jnp.where(first, 0.0, err * period)
        u = P["controller_kp"] * err + P["controller_ki"] * integ - P["controller_kd"] * th_d
        if any(e.output_limit is not None for e in pids):  # (the others' limit is +inf)
            lim = P["controller_output_limit"]
            u = jnp.clip(u, -lim, lim)
        cmd = u
        if any(e.lever_arm is not None for e in pids):  # (the others' constant lever is 1)
            if any(callable(e.lever_arm) for e in pids):
                la = jnp.stack([e.lever_arm(th[k]) if callable(e.lever_arm) else P["controller_lever_arm"][k] for k, e in enumerate(pids)])
            else:
                la = P["controller_lever_arm"]
            cmd = u / la
        valve = np.array([getattr(self.actuators.get(e.actuator_ref), "valve_time_constant", None) is not None for e in pids])
        if valve.any():
            a = jnp.exp(-period / P["controller_valve_time_constant"])
            cmd = jnp.where(first | ~valve, cmd, a * z[offs + 2] + (1 - a) * cmd)
        tick = (jnp.abs(t / period - jnp.round(t / period)) < 1e-7) | first
        new = jnp.where(tick[:, None], jnp.stack([u, integ, cmd], 1), z[offs[:, None] + np.arange(3)])
        # z with the PIDs' slices replaced: one gather from [z, new] (no scatter)
        src = np.arange(z.shape[0])
        src[(offs[:, None] + np.arange(3)).reshape(-1)] = z.shape[0] + np.arange(3 * len(pids))
        return jnp.concatenate([z, new.reshape(-1)])[src]

    def outputs(self, P, mk, t, ctx):
        return {}


# ---------------------------------------------------------------------------------------------
class _CommandMixin:
    @property
    def state_dependent(self) -> bool:
        """A command given as f(t, state) may read any part (Jacobian pattern taken dense)."""
        from ..model.forces import _callable_arity

        fns = [getattr(e, "effort", None) for e in self.elements] + [getattr(e, "force", None) for e in self.elements]
        return any(callable(f) and _callable_arity(f) >= 2 for f in fns)

    def _command(self, P, t, ctx, const_key, fns):
        """Each element's command: a controller's output from z, a callable's value, else the
        constant ``P[const_key]``. Without callables, one gather and one select for all (a
        robot's dozen servos would otherwise be a dozen gathers and a stack each evaluation)."""
        n = len(self.elements)
        if n == 0:
            return jnp.zeros(0)
        idx = np.asarray(self.cmd_index[:n], int)
        held = idx >= 0
        calls = [k for k in range(n) if not held[k] and fns[k] is not None]
        if not calls:
            if not held.any():
                return P[const_key]
            zc = ctx.z[np.where(held, idx, 0)]
            return zc if held.all() else jnp.where(held, zc, P[const_key])
        vals = []
        for k, e in enumerate(self.elements):
            if held[k]:
                vals.append(ctx.z[idx[k]])
            elif fns[k] is not None:
                f = fns[k]
                out = f(t) if _callable_arity(f) <= 1 else f(t, ctx)
                vals.append(jnp.asarray(out, jnp.float64))
            else:
                vals.append(P[const_key][k])
        return jnp.stack(vals)


class JointActuatorGroup(TwoMarkerGroup, _CommandMixin):
    kind = "joint_actuator"

    def __init__(self, elements, marker_index, nm, cmd_index, batteries=()):
        super().__init__(elements, marker_index, nm)
        self.rot = np.array([e.dof == "rotation" for e in self.elements], bool)
        self.cmd_index = cmd_index
        self.has_drive = any(e.drive is not None for e in self.elements)
        # battery index -> member actuator indices (drives sharing one battery, seed 003 Eq. 9)
        bnames = [b.name for b in batteries]
        self.battery_members = {}
        for k, e in enumerate(self.elements):
            if e.battery is not None:
                self.battery_members.setdefault(bnames.index(e.battery.name), []).append(k)
        # A shared battery couples every actuator on it: one clique in the Jacobian pattern.
        self.clique = bool(self.battery_members)

    def params(self):
        """The constant efforts, the drives' numbers (:meth:`_drive_params`), and where some
        actuator has them, the effort limits (``joint_actuator_limit``) and the gear trains'
        ratio, efficiencies and blend speed (``joint_actuator_gear_*``): a design with another
        limit or gear is a new argument, not a new compile (issue 42). Which actuators have a
        limit or a gear is structure; the others' entries hold neutral values, never read."""
        els = self.elements
        out = {"joint_actuator_effort": np.array([e.effort_value for e in els], float)}
        if self.has_drive:
            out.update(self._drive_params())
        if any(e.limit is not None for e in els):
            out["joint_actuator_limit"] = np.array([np.inf if e.limit is None else float(e.limit) for e in els])
        if any(e.gear is not None for e in els):
            gears = [(float(g.ratio), float(g.efficiency), float(g.eta_back), float(e.gear_speed_eps)) if (g := e.gear) is not None
                     else (1.0, 1.0, 1.0, 0.0) for e in els]
            for i, f in enumerate(("gear_ratio", "gear_efficiency", "gear_back_efficiency", "gear_speed_eps")):
                out[f"joint_actuator_{f}"] = np.array([g[i] for g in gears])
        return out

    def _drive_params(self):
        """Every number of the actuators' DC motor drives and belt stages, one entry per actuator:
        ``joint_actuator_drive_<field>`` (:data:`~proleg.drives.dcmotor.DRIVE_NUMBERS`: gear and
        belt ratios and efficiencies, motor constants, amplifier and battery numbers, drag) and,
        where a drive models its belt stage, ``joint_actuator_belt_<field>``. The law reads them
        from ``params`` only (:meth:`_drives`), so a design with another gear ratio or motor
        shares the compiled model (issue 42). Which actuators have a drive, and which drives a
        belt stage, is structure; the entries of the others hold the default drive's (belt's)
        numbers and are never read."""
        from ..drives.belt import BELT_NUMBERS, BeltLoss
        from ..drives.dcmotor import DRIVE_NUMBERS, DCMotorDrive

        drives = [e.drive if e.drive is not None else DCMotorDrive() for e in self.elements]
        out = {f"joint_actuator_drive_{f}": np.array([float(getattr(d, f)) for d in drives]) for f in DRIVE_NUMBERS}
        if any(d.belt is not None for d in drives):
            belts = [d.belt if d.belt is not None else BeltLoss() for d in drives]
            out.update({f"joint_actuator_belt_{f}": np.array([float(getattr(b, f)) for b in belts]) for f in BELT_NUMBERS})
        return out

    def _drives(self, P):
        """The actuators' drives (None where there is none) with their numbers from ``P``."""
        import dataclasses

        from ..drives.belt import BELT_NUMBERS
        from ..drives.dcmotor import DRIVE_NUMBERS

        out = []
        for k, e in enumerate(self.elements):
            if e.drive is None:
                out.append(None)
                continue
            belt = e.drive.belt
            if belt is not None:
                belt = dataclasses.replace(belt, **{f: P[f"joint_actuator_belt_{f}"][k] for f in BELT_NUMBERS})
            out.append(dataclasses.replace(e.drive, belt=belt, **{f: P[f"joint_actuator_drive_{f}"][k] for f in DRIVE_NUMBERS}))
        return out

    def _leg_speed(self, k, xd, drives):
        return xd[k] / drives[k].beta if self.elements[k].motor_side else xd[k]

    def _law(self, P, mk, t, ctx, full=False):
        x, xd, zJ, delta = joint_coordinate(self.oh_i, self.oh_j, self.rot, mk)
        u = self._command(P, t, ctx, "joint_actuator_effort", [e.effort if callable(e.effort) else None for e in self.elements])
        drives = self._drives(P) if self.has_drive else [None] * len(self.elements)
        V_of = {}
        if self.battery_members:
            from ..drives.battery import shared_supply

            for b, ks in self.battery_members.items():
                V_of[b] = shared_supply(
                    [drives[k] for k in ks], jnp.stack([u[k] for k in ks]), jnp.stack([self._leg_speed(k, xd, drives) for k in ks]),
                    P["battery_V_nom"][b], P["battery_R_s"][b],
                )
        member_of = {k: b for b, ks in self.battery_members.items() for k in ks}
        outs, elec = [], []
        zero = jnp.zeros(())
        for k, e in enumerate(self.elements):
            uk = u[k]
            if e.drive is not None:
                from ..drives.dcmotor import delivered_torque

                drive = drives[k]
                V = V_of.get(member_of.get(k))
                d = delivered_torque(drive, uk, self._leg_speed(k, xd, drives), battery=True, V=V)
                uk = d.torque / drive.beta if e.motor_side else d.torque
                elec.append((d.current, d.supply_voltage, d.supply_current, d.electrical_power, d.saturated.astype(jnp.float64), d.torque))
            else:
                elec.append((zero, zero, zero, zero, zero, uk))
            if e.gear is not None:
                from ..drives.gears import GearTrain, output_torque

                gear = GearTrain(P["joint_actuator_gear_ratio"][k], P["joint_actuator_gear_efficiency"][k],
                                 P["joint_actuator_gear_back_efficiency"][k])
                uk = output_torque(gear, uk, xd[k], P["joint_actuator_gear_speed_eps"][k])
            if e.limit is not None:
                uk = jnp.clip(uk, -P["joint_actuator_limit"][k], P["joint_actuator_limit"][k])
            outs.append(uk)
        u_out = jnp.stack(outs)
        if full:
            return x, xd, zJ, delta, u_out, u, [jnp.stack(c) for c in zip(*elec)]
        return x, xd, zJ, delta, u_out

    def loads(self, P, mk, t, ctx):
        x, xd, zJ, delta, u = self._law(P, mk, t, ctx)
        V = u[:, None] * zJ
        rot = self.rot[:, None]
        return pair_loads(self.oh_i, self.oh_j, jnp.where(rot, 0.0, V), jnp.where(rot, V, 0.0), delta)

    def input_power(self, P, mk, t, ctx):
        x, xd, zJ, delta, u = self._law(P, mk, t, ctx)
        return jnp.sum(u * xd)

    def outputs(self, P, mk, t, ctx):
        x, xd, zJ, delta, u, cmd, elec = self._law(P, mk, t, ctx, full=True)
        out = {"effort": (u, "N m|N"), "coordinate": (x, "rad|m"), "rate": (xd, "rad/s|m/s"), "power": (u * xd, "W"), "command": (cmd, "N m|N")}
        if self.has_drive:
            cur, vs, i_s, p_el, sat, tau_leg = elec
            out.update(
                current=(cur, "A"), supply_voltage=(vs, "V"), supply_current=(i_s, "A"),
                electrical_power=(p_el, "W"), saturated=(sat, "-"), leg_torque=(tau_leg, "N m"),
            )
        return out


class LineActuatorGroup(TwoMarkerGroup, _CommandMixin):
    """TranslationalActuator and HydraulicActuator (spring-damper + commanded force along I–J)."""

    def __init__(self, elements, marker_index, nm, cmd_index, kind):
        super().__init__(elements, marker_index, nm)
        self.kind = kind
        self.cmd_index = cmd_index
        self.hyd = kind == "hydraulic_actuator"

    def params(self):
        e = self.elements
        if self.hyd:
            return {
                "hydraulic_actuator_stiffness": np.array([x.stiffness for x in e]),
                "hydraulic_actuator_damping": np.array([x.damping for x in e]),
                "hydraulic_actuator_free_length": np.array([x.free_length for x in e]),
                "hydraulic_actuator_force": np.zeros(len(e)),
            }
        return {"translational_actuator_force": np.array([x.force_value for x in e])}

    def _law(self, P, mk, t, ctx):
        rI, rJ, vI, vJ = self._ends(mk)
        delta = rI - rJ
        ell = jnp.sqrt(jnp.sum(delta * delta, -1))
        u = delta / ell[:, None]
        rate = jnp.sum(u * (vI - vJ), -1)
        key = f"{self.kind}_force"
        fns = [getattr(e, "force", None) if callable(getattr(e, "force", None)) else None for e in self.elements]
        cmd = self._command(P, t, ctx, key, fns)
        for k, e in enumerate(self.elements):
            if getattr(e, "force_limit", None) is not None:
                cmd = cmd.at[k].set(jnp.clip(cmd[k], -e.force_limit, e.force_limit))
        if self.hyd:
            ext = ell - P["hydraulic_actuator_free_length"]
            f_el = -P["hydraulic_actuator_stiffness"] * ext
            f_d = -P["hydraulic_actuator_damping"] * rate
        else:
            ext = jnp.zeros_like(ell)
            f_el = f_d = jnp.zeros_like(ell)
        return delta, ell, u, rate, ext, f_el, f_d, cmd

    def loads(self, P, mk, t, ctx):
        delta, ell, u, rate, ext, f_el, f_d, cmd = self._law(P, mk, t, ctx)
        F = (f_el + f_d + cmd)[:, None] * u
        return pair_loads(self.oh_i, self.oh_j, F, None, delta)  # a pure force element

    def potential(self, P, mk, t, ctx):
        if not self.hyd:
            return 0.0
        delta, ell, u, rate, ext, *_ = self._law(P, mk, t, ctx)
        return jnp.sum(0.5 * P["hydraulic_actuator_stiffness"] * ext**2)

    def dissipation(self, P, mk, t, ctx):
        if not self.hyd:
            return 0.0
        delta, ell, u, rate, *_ = self._law(P, mk, t, ctx)
        return jnp.sum(P["hydraulic_actuator_damping"] * rate**2)

    def input_power(self, P, mk, t, ctx):
        delta, ell, u, rate, ext, f_el, f_d, cmd = self._law(P, mk, t, ctx)
        return jnp.sum(cmd * rate)

    def outputs(self, P, mk, t, ctx):
        delta, ell, u, rate, ext, f_el, f_d, cmd = self._law(P, mk, t, ctx)
        f = f_el + f_d + cmd
        return {
            "force": (f[:, None] * u, "N"),
            "tension": (-f, "N"),
            "axial_force": (f, "N"),
            "command": (cmd, "N"),
            "length": (ell, "m"),
            "velocity": (rate, "m/s"),
            "power": (f * rate, "W"),
        }


def build_extensions(model, topo, marker_index, params):
    """EXTENSION_HOOK: contacts, controllers and actuators of ``model`` as groups."""
    nm = len(marker_index)
    groups = []
    if model.contacts:
        groups.append(ContactGroup(model.contacts, marker_index, nm))
    ctrl = ControllerGroup(model.controllers, marker_index, nm) if model.controllers else None
    acts = {a.name: a for a in model.actuators}
    if ctrl is not None:
        for e in model.controllers:
            refs = [e.actuator_ref] if e.kind == "pid" else e.outputs
            for r in refs:
                if r not in acts:
                    raise ModelError(f"Controller '{e.name}' drives actuator '{r}', which is not in the model. Known: {sorted(acts)}")
        ctrl.actuators = acts
        groups.append(ctrl)
        pids = [e for e in model.controllers if e.kind == "pid"]
        if pids:
            params["controller_setpoint0"] = np.zeros(len(pids))  # filled after assembly (modelled pose)
    for kind in ("joint_actuator", "translational_actuator", "hydraulic_actuator"):
        elems = [a for a in model.actuators if a.kind == kind]
        if not elems:
            continue
        cmd = np.array([ctrl.out_index.get(a.name, -1) if ctrl is not None else -1 for a in elems], int)
        if kind == "joint_actuator":
            groups.append(JointActuatorGroup(elems, marker_index, nm, cmd, getattr(model, "batteries", ())))
            if getattr(model, "batteries", None):
                from .joint_elements import BatteryGroup

                groups.append(BatteryGroup(model.batteries, groups[-1]))
        else:
            groups.append(LineActuatorGroup(elems, marker_index, nm, cmd, kind))
    from .joint_elements import JointFrictionGroup, JointStopGroup

    for kind, gcls in (("joint_stop", JointStopGroup), ("joint_friction", JointFrictionGroup)):
        elems = [f for f in model.forces if getattr(f, "kind", "") == kind]
        if elems:
            groups.append(gcls(elems, marker_index, nm))
    slides = [f for f in model.forces if getattr(f, "kind", "") == "slide_friction"]
    if slides:  # last: its normal load re-evaluates the groups above on the sliding parts
        from .friction_elements import SlideFrictionGroup

        groups.append(SlideFrictionGroup(slides, marker_index, nm, model, topo.marker_body))
    for g in groups:
        if len(g):
            params.update(g.params())
    return groups
