"""Element groups on joint coordinates: joint stops (unilateral, IMPACT law) and shared batteries.

The Coupler constraint rows are in constraints.py (row kind ``cpl``).
"""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np

from ..contact_law import normal_force
from ..fn import _safe_pow
from .elements import AbstractGroup, TwoMarkerGroup, pair_loads
from .constraints import joint_coordinate

_BIG = 1e30  # an absent limit (finite, so no inf · 0 in derivatives)


class JointStopGroup(TwoMarkerGroup):
    """:class:`proleg.model.couplers.JointStop` elements, vectorised."""

    kind = "joint_stop"

    def __init__(self, elements, marker_index, nm):
        super().__init__(elements, marker_index, nm)
        self.rot = np.array([e.dof == "rotation" for e in self.elements], bool)

    def params(self):
        e = self.elements
        lim = lambda v: np.clip(np.array(v, float), -_BIG, _BIG)
        return {
            "joint_stop_lower": lim([x.lower for x in e]),
            "joint_stop_upper": lim([x.upper for x in e]),
            "joint_stop_stiffness": np.array([x.stiffness for x in e]),
            "joint_stop_exponent": np.array([x.exponent for x in e]),
            "joint_stop_damping": np.array([x.damping for x in e]),
            "joint_stop_penetration": np.array([x.penetration for x in e]),
        }

    def _law(self, P, mk):
        x, xd, zJ, delta = joint_coordinate(self.oh_i, self.oh_j, self.rot, mk)
        p_up = x - P["joint_stop_upper"]
        p_lo = P["joint_stop_lower"] - x
        up = p_up > p_lo  # the nearer limit (the coordinate can be past at most one)
        p = jnp.where(up, p_up, p_lo)
        pd = jnp.where(up, xd, -xd)
        k, e = P["joint_stop_stiffness"], P["joint_stop_exponent"]
        F = normal_force(p, pd, k, e, P["joint_stop_damping"], P["joint_stop_penetration"])
        sign = jnp.where(up, -1.0, 1.0)  # push back towards the free range
        return x, xd, zJ, delta, p, pd, F, sign

    def loads(self, P, mk, t, ctx):
        x, xd, zJ, delta, p, pd, F, sign = self._law(P, mk)
        V = (sign * F)[:, None] * zJ
        rot = self.rot[:, None]
        return pair_loads(self.oh_i, self.oh_j, jnp.where(rot, 0.0, V), jnp.where(rot, V, 0.0), delta)

    def potential(self, P, mk, t, ctx):
        x, xd, zJ, delta, p, *_ = self._law(P, mk)
        e = P["joint_stop_exponent"]
        return jnp.sum(jnp.where(p > 0, P["joint_stop_stiffness"] * _safe_pow(p, e + 1.0) / (e + 1.0), 0.0))

    def dissipation(self, P, mk, t, ctx):
        x, xd, zJ, delta, p, pd, F, sign = self._law(P, mk)
        k_el = jnp.where(p > 0, P["joint_stop_stiffness"] * _safe_pow(p, P["joint_stop_exponent"]), 0.0)
        return jnp.sum((F - k_el) * pd)

    def outputs(self, P, mk, t, ctx):
        x, xd, zJ, delta, p, pd, F, sign = self._law(P, mk)
        return {
            "force": (sign * F, "N|N m"),
            "penetration": (p, "m|rad"),
            "penetration_rate": (pd, "m/s|rad/s"),
            "in_contact": ((p > 0).astype(jnp.float64), "-"),
            "coordinate": (x, "m|rad"),
        }


class JointFrictionGroup(TwoMarkerGroup):
    """:class:`proleg.model.couplers.JointFriction` elements, vectorised."""

    kind = "joint_friction"
    fields = ("friction", "damping", "slip_rate")

    def __init__(self, elements, marker_index, nm):
        super().__init__(elements, marker_index, nm)
        self.rot = np.array([e.dof == "rotation" for e in self.elements], bool)

    def _law(self, P, mk):
        x, xd, zJ, delta = joint_coordinate(self.oh_i, self.oh_j, self.rot, mk)
        tq = -P["joint_friction_friction"] * jnp.tanh(xd / P["joint_friction_slip_rate"]) - P["joint_friction_damping"] * xd
        return xd, zJ, delta, tq

    def loads(self, P, mk, t, ctx):
        xd, zJ, delta, tq = self._law(P, mk)
        V = tq[:, None] * zJ
        rot = self.rot[:, None]
        return pair_loads(self.oh_i, self.oh_j, jnp.where(rot, 0.0, V), jnp.where(rot, V, 0.0), delta)

    def dissipation(self, P, mk, t, ctx):
        xd, zJ, delta, tq = self._law(P, mk)
        return -jnp.sum(tq * xd)

    def outputs(self, P, mk, t, ctx):
        xd, zJ, delta, tq = self._law(P, mk)
        return {"torque": (tq, "N m|N"), "rate": (xd, "rad/s|m/s"), "power": (tq * xd, "W")}


class BatteryGroup(AbstractGroup):
    """Batteries shared by DC motor drives: parameters and outputs (the law is in the actuators)."""

    kind = "battery"

    def __init__(self, elements, actuators):
        self.elements = list(elements)
        self.names = [e.name for e in self.elements]
        self.actuators = actuators  # the JointActuatorGroup that evaluates the shared supply

    def params(self):
        return {
            "battery_V_nom": np.array([e.V_nom for e in self.elements], float),
            "battery_R_s": np.array([e.R_s for e in self.elements], float),
        }

    def outputs(self, P, mk, t, ctx):
        out = self.actuators.outputs(P, mk, t, ctx)
        i_s = out["supply_current"][0]
        vs = out["supply_voltage"][0]
        n = len(self.elements)
        cur, volt = [], []
        for b in range(n):
            ks = self.actuators.battery_members.get(b, [])
            cur.append(sum((i_s[k] for k in ks), jnp.zeros(())))
            volt.append(vs[ks[0]] if ks else P["battery_V_nom"][b])
        cur, volt = jnp.stack(cur), jnp.stack(volt)
        return {
            "voltage": (volt, "V"),
            "current": (cur, "A"),
            "power": (volt * cur, "W"),
            "internal_loss": (P["battery_R_s"] * cur**2, "W"),
        }
