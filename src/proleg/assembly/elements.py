"""Force-element groups: each kind of element is evaluated vectorised over its instances.

A group turns model elements into parameter arrays (``params``) and static marker
selections, and provides pure functions of the marker kinematics:

- ``loads`` → per-marker force and torque accumulations (ground components),
- ``potential`` (stored energy), ``dissipation`` (power ≥ 0 lost in dampers, friction),
  ``input_power`` (power of external loads), ``outputs`` (named per-element arrays).

Two-marker elements follow the Adams convention: force F and torque T act on I; −F and
−T − δ × F act on J, with δ = r_I − r_J, so the pair carries no net force or moment.
"""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np

from ..spatial.rotation import mv
from .constraints import _oh, joint_angle


class AbstractGroup:
    kind = ""

    def __init__(self, elements, marker_index: dict, nm: int):
        self.elements = list(elements)
        self.names = [e.name for e in self.elements]
        self.nm = nm

    def __len__(self):
        return len(self.elements)

    fields: tuple = ()  # element attributes that become parameter arrays "<kind>_<field>"

    def params(self) -> dict:
        return {f"{self.kind}_{f}": np.array([getattr(e, f) for e in self.elements], float) for f in self.fields}

    def index(self, name: str) -> int:
        return self.names.index(name)

    def element_params(self) -> dict:
        """{"element.field": (parameter array name, index)}: where one element's own number sits
        in :meth:`params`, for ``System.with_params``/``get``/``param_names``. By default each
        array has one row per element, in ``names`` order; a group whose arrays are laid out
        otherwise (some elements without the field, several numbers per element) overrides it."""
        per = {k: k[len(self.kind) + 1 :] for k, a in self.params().items() if np.ndim(a) and np.shape(a)[0] == len(self.names)}
        return {f"{n}.{fld}": (k, i) for i, n in enumerate(self.names) for k, fld in per.items()}

    # Defaults: no contribution.
    def potential(self, P, mk, t, ctx):
        return 0.0

    def dissipation(self, P, mk, t, ctx):
        return 0.0

    def input_power(self, P, mk, t, ctx):
        return 0.0


class MarkerLoads:
    """Loads at marker rows, not yet summed per marker: blocks (selection, force rows, torque
    rows), each row adding (F, T) [N, N·m, ground] to the marker its selection picks.

    A group's ``loads`` returns one; unpacked (``Fm, Tm = loads``) it sums itself into (nm, 3)
    force and torque arrays, and :func:`~proleg.assembly.system.element_loads` instead joins
    every group's blocks and sums them all with one gather (:func:`sum_marker_loads`): each sum
    is a kernel launch of its own on XLA-CPU, and a robot's servos, dampers and contacts had
    four each per evaluation."""

    __slots__ = ("nm", "blocks")

    def __init__(self, nm: int, blocks):
        self.nm, self.blocks = int(nm), list(blocks)

    def __iter__(self):
        return iter(sum_marker_loads(self.nm, self.blocks))


def sum_marker_loads(nm: int, blocks):
    """(Fm, Tm) (nm, 3) each: the rows of ``blocks`` [(Select, F (k, 3), T (k, 3))] summed per
    marker by one gather-and-sum (Select.T)."""
    from .select import Select

    blocks = [b for b in blocks if len(b[0])]
    if not blocks:
        return jnp.zeros((nm, 3)), jnp.zeros((nm, 3))
    idx = np.concatenate([b[0].idx for b in blocks])
    rows = jnp.concatenate([jnp.concatenate([F, T], 1) for _, F, T in blocks], 0)
    out = Select(idx, nm).T @ rows
    return out[:, :3], out[:, 3:]


def pair_loads(oh_i, oh_j, F, T, delta):
    """Loads of action F, T on I and reaction on J (with moment arm), as :class:`MarkerLoads`.
    ``F`` or ``T`` None: no force (a pure torque element) or no torque (a pure force element)."""
    if F is None:
        return MarkerLoads(oh_i.n, [(oh_i, jnp.zeros_like(T), T), (oh_j, jnp.zeros_like(T), -T)])
    TJ = -jnp.cross(delta, F) if T is None else -T - jnp.cross(delta, F)
    return MarkerLoads(oh_i.n, [(oh_i, F, jnp.zeros_like(F) if T is None else T), (oh_j, -F, TJ)])


class TwoMarkerGroup(AbstractGroup):
    def __init__(self, elements, marker_index, nm):
        super().__init__(elements, marker_index, nm)
        self.oh_i = _oh([marker_index[id(e.i)] for e in self.elements], nm)
        self.oh_j = _oh([marker_index[id(e.j)] for e in self.elements], nm)

    def _ends(self, mk):
        rI, rJ = self.oh_i @ mk.r, self.oh_j @ mk.r
        vI, vJ = self.oh_i @ mk.v, self.oh_j @ mk.v
        return rI, rJ, vI, vJ


class SpringDamperGroup(TwoMarkerGroup):
    kind = "spring_damper"
    fields = ("stiffness", "damping", "free_length", "preload")

    def _law(self, P, mk):
        rI, rJ, vI, vJ = self._ends(mk)
        delta = rI - rJ
        length = jnp.sqrt(jnp.sum(delta * delta, -1))
        u = delta / length[:, None]
        rate = jnp.sum(u * (vI - vJ), -1)
        ext = length - P["spring_damper_free_length"]
        f = -P["spring_damper_stiffness"] * ext - P["spring_damper_damping"] * rate + P["spring_damper_preload"]
        return delta, length, rate, ext, u, f

    def loads(self, P, mk, t, ctx):
        delta, _, _, _, u, f = self._law(P, mk)
        return pair_loads(self.oh_i, self.oh_j, f[:, None] * u, None, delta)

    def potential(self, P, mk, t, ctx):
        _, _, _, ext, _, _ = self._law(P, mk)
        return jnp.sum(0.5 * P["spring_damper_stiffness"] * ext**2 - P["spring_damper_preload"] * ext)

    def dissipation(self, P, mk, t, ctx):
        _, _, rate, _, _, _ = self._law(P, mk)
        return jnp.sum(P["spring_damper_damping"] * rate**2)

    def outputs(self, P, mk, t, ctx):
        delta, length, rate, ext, u, f = self._law(P, mk)
        return {
            "force": (f[:, None] * u, "N"),
            "tension": (-f, "N"),
            "length": (length, "m"),
            "deformation": (ext, "m"),
            "velocity": (rate, "m/s"),
            "power": (-P["spring_damper_damping"] * rate**2, "W"),
        }


class RotationalSpringDamperGroup(TwoMarkerGroup):
    kind = "rotational_spring_damper"
    fields = ("stiffness", "damping", "free_angle", "preload")

    def _relative_rotation(self, mk):
        """z_J, the angle of I relative to J about it, and its rate."""
        R9 = mk.R.reshape(-1, 9)
        RI = (self.oh_i @ R9).reshape(-1, 3, 3)
        RJ = (self.oh_j @ R9).reshape(-1, 3, 3)
        z = RJ[:, :, 2]
        return z, joint_angle(RI, RJ), jnp.sum(z * (self.oh_i @ mk.w - self.oh_j @ mk.w), -1)

    def _law(self, P, mk):
        z, th, rate = self._relative_rotation(mk)
        ext = th - P["rotational_spring_damper_free_angle"]
        tq = (
            -P["rotational_spring_damper_stiffness"] * ext
            - P["rotational_spring_damper_damping"] * rate
            + P["rotational_spring_damper_preload"]
        )
        return z, th, rate, ext, tq

    def loads(self, P, mk, t, ctx):
        z, _, _, _, tq = self._law(P, mk)
        return pair_loads(self.oh_i, self.oh_j, None, tq[:, None] * z, None)

    def potential(self, P, mk, t, ctx):
        _, _, _, ext, _ = self._law(P, mk)
        return jnp.sum(0.5 * P["rotational_spring_damper_stiffness"] * ext**2 - P["rotational_spring_damper_preload"] * ext)

    def dissipation(self, P, mk, t, ctx):
        _, _, rate, _, _ = self._law(P, mk)
        return jnp.sum(P["rotational_spring_damper_damping"] * rate**2)

    def outputs(self, P, mk, t, ctx):
        z, th, rate, ext, tq = self._law(P, mk)
        return {
            "torque": (tq, "N m"),
            "angle": (th, "rad"),
            "deformation": (ext, "rad"),
            "velocity": (rate, "rad/s"),
            "power": (-P["rotational_spring_damper_damping"] * rate**2, "W"),
        }


def bushing_kinematics(RI, RJ, rI, rJ, vI, vJ, wI, wJ):
    """Displacement [d; (a, b, c)] and velocity [ḋ; ω_rel] of I relative to J in J axes (note §3)."""
    delta = rI - rJ
    RJt = jnp.swapaxes(RJ, -1, -2)
    d = mv(RJt, delta)
    dd = mv(RJt, vI - vJ - jnp.cross(wJ, delta))
    wrel = mv(RJt, wI - wJ)
    xI, zI = RI[:, :, 0], RI[:, :, 2]
    xJ, yJ, zJ = RJ[:, :, 0], RJ[:, :, 1], RJ[:, :, 2]
    zz = jnp.sum(zI * zJ, -1)
    a = jnp.arctan2(-jnp.sum(zI * yJ, -1), zz)
    b = jnp.arctan2(jnp.sum(zI * xJ, -1), zz)
    c = jnp.arctan2(jnp.sum(xI * yJ, -1), jnp.sum(xI * xJ, -1))
    x = jnp.concatenate([d, jnp.stack([a, b, c], -1)], -1)
    xd = jnp.concatenate([dd, wrel], -1)
    return delta, x, xd


class BushingGroup(TwoMarkerGroup):
    kind = "bushing"

    def params(self):
        e = self.elements
        return {
            "bushing_stiffness": np.array([x.stiffness for x in e]).reshape(-1, 6, 6),
            "bushing_damping": np.array([x.damping for x in e]).reshape(-1, 6, 6),
            "bushing_preload": np.array([x.preload for x in e]).reshape(-1, 6),
            "bushing_free": np.array([x.free for x in e]).reshape(-1, 6),
        }

    def _law(self, P, mk):
        R9 = mk.R.reshape(-1, 9)
        RI = (self.oh_i @ R9).reshape(-1, 3, 3)
        RJ = (self.oh_j @ R9).reshape(-1, 3, 3)
        rI, rJ, vI, vJ = self._ends(mk)
        delta, x, xd = bushing_kinematics(RI, RJ, rI, rJ, vI, vJ, self.oh_i @ mk.w, self.oh_j @ mk.w)
        xe = x - P["bushing_free"]
        fe = -mv(P["bushing_stiffness"], xe)
        fd = -mv(P["bushing_damping"], xd)
        f = fe + fd + P["bushing_preload"]
        return RJ, delta, x, xd, xe, f, fd

    def loads(self, P, mk, t, ctx):
        RJ, delta, _, _, _, f, _ = self._law(P, mk)
        F = mv(RJ, f[:, :3])
        T = mv(RJ, f[:, 3:])
        return pair_loads(self.oh_i, self.oh_j, F, T, delta)

    def potential(self, P, mk, t, ctx):
        _, _, _, _, xe, _, _ = self._law(P, mk)
        return jnp.sum(0.5 * jnp.einsum("ni,nij,nj->n", xe, P["bushing_stiffness"], xe) - jnp.sum(P["bushing_preload"] * xe, -1))

    def dissipation(self, P, mk, t, ctx):
        _, _, _, xd, _, _, fd = self._law(P, mk)
        return -jnp.sum(fd * xd)

    def outputs(self, P, mk, t, ctx):
        RJ, _, x, xd, _, f, fd = self._law(P, mk)
        return {
            "force": (mv(RJ, f[:, :3]), "N"),
            "torque": (mv(RJ, f[:, 3:]), "N m"),
            "force_local": (f[:, :3], "N"),
            "torque_local": (f[:, 3:], "N m"),
            "deformation": (x[:, :3], "m"),
            "rotation": (x[:, 3:], "rad"),
            "power": (jnp.sum(fd * xd, -1), "W"),
        }


class PartLoadGroup(AbstractGroup):
    """User forces (kind 'force') or torques ('torque') on parts: constants or f(t) / f(t, state)."""

    def __init__(self, elements, marker_index, nm, kind):
        super().__init__(elements, marker_index, nm)
        self.kind = kind
        self.oh = _oh([marker_index[id(e.marker)] for e in self.elements], nm)
        self.const = np.array([e.fn is None for e in self.elements], bool)
        # A function of the state may read any part: the Jacobian pattern is then taken dense.
        self.state_dependent = any(e.fn is not None and e.arity >= 2 for e in self.elements)

    def params(self):
        vals = np.array([e.value if e.fn is None else np.zeros(3) for e in self.elements]).reshape(-1, 3)
        return {f"{self.kind}_value": vals}

    def _values(self, P, t, ctx):
        rows = []
        for k, e in enumerate(self.elements):
            if e.fn is None:
                rows.append(P[f"{self.kind}_value"][k])
            else:
                out = e.fn(t) if e.arity <= 1 else e.fn(t, ctx)
                rows.append(jnp.broadcast_to(jnp.asarray(out, dtype=jnp.float64), (3,)))
        return jnp.stack(rows)

    def loads(self, P, mk, t, ctx):
        val = self._values(P, t, ctx)
        if self.kind == "force":
            return self.oh.T @ val, jnp.zeros((self.nm, 3))
        return jnp.zeros((self.nm, 3)), self.oh.T @ val

    def input_power(self, P, mk, t, ctx):
        val = self._values(P, t, ctx)
        vel = self.oh @ (mk.v if self.kind == "force" else mk.w)
        return jnp.sum(val * vel)

    def outputs(self, P, mk, t, ctx):
        val = self._values(P, t, ctx)
        vel = self.oh @ (mk.v if self.kind == "force" else mk.w)
        return {self.kind: (val, "N" if self.kind == "force" else "N m"), "power": (jnp.sum(val * vel, -1), "W")}


class RotationalBacklashGroup(RotationalSpringDamperGroup):
    """Dead band + spring-damper about z_J (seed 003 Model II); smooth C1 contact gate."""

    kind = "rotational_backlash"
    fields = ("stiffness", "damping", "free_angle", "half_gap", "width")

    def _bl(self, P, mk):
        from ..drives.backlash import deadband_smooth

        z, th, rate = self._relative_rotation(mk)
        th = th - P["rotational_backlash_free_angle"]
        w = jnp.maximum(P["rotational_backlash_width"], 1e-12)
        delta, gate = deadband_smooth(th, P["rotational_backlash_half_gap"], w)
        tq = -P["rotational_backlash_stiffness"] * delta - gate * P["rotational_backlash_damping"] * rate
        return z, th, rate, delta, gate, tq

    def loads(self, P, mk, t, ctx):
        z, _, _, _, _, tq = self._bl(P, mk)
        return pair_loads(self.oh_i, self.oh_j, None, tq[:, None] * z, None)

    def potential(self, P, mk, t, ctx):
        _, _, _, delta, _, _ = self._bl(P, mk)
        return jnp.sum(0.5 * P["rotational_backlash_stiffness"] * delta**2)

    def dissipation(self, P, mk, t, ctx):
        # Exact accounting: −τ θ̇ − dV/dt (dV/dθ = k δ s differs from k δ inside the smoothing band).
        _, _, rate, delta, gate, tq = self._bl(P, mk)
        return jnp.sum(-tq * rate - P["rotational_backlash_stiffness"] * delta * gate * rate)

    def outputs(self, P, mk, t, ctx):
        z, th, rate, delta, gate, tq = self._bl(P, mk)
        return {"torque": (tq, "N m"), "angle": (th, "rad"), "deflection": (delta, "rad"), "engaged": (gate, "-"), "velocity": (rate, "rad/s")}
