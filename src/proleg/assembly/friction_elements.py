"""The :class:`proleg.model.friction.SlideFriction` group: prismatic-joint friction under side load.

The normal load needs the loads of the other elements on the sliding part (the quasi-static
joint reaction, see the element's docstring), so this group evaluates the groups that act on
those parts once more inside its own ``loads``. Its Jacobian pattern couples the joint's two
parts with every part those elements touch (per element, from the topology).
"""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np

from ..fn import step
from .constraints import joint_coordinate
from .elements import TwoMarkerGroup, pair_loads
from .select import Select


def friction_coefficient(v, mu_s, mu_d, v_s, v_d):
    """Signed stick–slip coefficient μ(v) [-] (Adams FRICTION, cubic STEPs; see SlideFriction)."""
    a = jnp.abs(v)
    inner = step(v, -v_s, -mu_s, v_s, mu_s)
    outer = jnp.sign(v) * step(a, v_s, mu_s, v_d, mu_d)
    return jnp.where(a <= v_s, inner, outer)


def _smooth_norm(x, eps=1e-9):
    """|x| along the last axis, differentiable at 0 (bias below eps)."""
    return jnp.sqrt(jnp.sum(x * x, -1) + eps * eps) - eps


def _element_markers(e):
    """Markers an element's load acts through (two-marker elements, contacts, joint actuators)."""
    from ..model.joints import AbstractJoint
    from ..model.parts import Marker

    out = []
    for a in ("i", "j", "marker", "plane", "marker_i", "marker_j"):
        m = getattr(e, a, None)
        if isinstance(m, Marker):
            out.append(m)
    j = getattr(e, "joint", None)
    if isinstance(j, AbstractJoint):
        out += [j.marker_i, j.marker_j]
    return out


class SlideFrictionGroup(TwoMarkerGroup):
    """SlideFriction elements, vectorised; ``dependencies(model, ...)`` sets the coupling."""

    kind = "slide_friction"
    fields = ("mu_static", "mu_dynamic", "v_stiction", "v_friction", "damping", "preload", "overlap", "bearing_offset")

    def __init__(self, elements, marker_index, nm, model, marker_body):
        super().__init__(elements, marker_index, nm)
        self.rot = np.zeros(len(self.elements), bool)
        self.marker_body = np.asarray(marker_body)
        self.nbody = len(model.parts)
        self.slider = np.array([self.marker_body[marker_index[id(e.i)]] for e in self.elements], int)
        self.use_moment = np.array([e.use_moment for e in self.elements], bool)
        # markers on each slider part (the loads summed into its reaction)
        # a bool mask (structure: which markers sit on the slider), so that the structural hash
        # and the numbers check keep it exact instead of treating its 0/1 as model numbers
        self.on_slider = np.array([self.marker_body == b for b in self.slider], bool)  # (ne, nm)
        # Jacobian coupling: every marker of every element with a marker on the slider part,
        # padded per element to equal length (one Select per column: per-element body sets).
        others = [f for f in list(model.forces) + list(model.contacts) + list(model.actuators) if getattr(f, "kind", "") != self.kind]
        deps = []
        for e, b in zip(self.elements, self.slider):
            ms = [marker_index[id(e.i)], marker_index[id(e.j)]]
            for f in others:
                fm = [marker_index[id(m)] for m in _element_markers(f) if id(m) in marker_index]
                if any(self.marker_body[k] == b for k in fm):
                    ms += fm
            deps.append(sorted(set(ms)))
        width = max(len(d) for d in deps)
        for c in range(width):
            setattr(self, f"dep_{c}", Select([d[c] if c < len(d) else d[0] for d in deps], nm))

    def _reaction(self, P, mk, ctx, zJ, centre):
        """Quasi-static reaction force on each slider and its moment about the bearing centre."""
        topo = ctx._topo
        nm = len(topo.marker_names)
        Fm, Tm = jnp.zeros((nm, 3)), jnp.zeros((nm, 3))
        sl = set(int(b) for b in self.slider)
        for g in list(topo.groups) + list(topo.extensions):
            if g is self or not len(g) or not hasattr(g, "loads") or g.kind == self.kind:
                continue
            sels = [v for v in vars(g).values() if isinstance(v, Select)]
            if not any(int(self.marker_body[k]) in sl for s in sels for k in s.idx):
                continue
            F, T = g.loads(P, mk, ctx.t, ctx)
            Fm, Tm = Fm + F, Tm + T
        W = jnp.asarray(self.on_slider, jnp.float64)
        F_res = W @ Fm + P["body_mass"][self.slider][:, None] * P["gravity"][None, :]
        r_com = ctx._bk.r[self.slider]
        arm = mk.r[None, :, :] - centre[:, None, :]  # (ne, nm, 3)
        M_res = jnp.einsum("em,emk->ek", W, jnp.cross(arm, Fm[None, :, :]) + Tm[None, :, :])
        M_res = M_res + jnp.cross(r_com - centre, P["body_mass"][self.slider][:, None] * P["gravity"][None, :])
        R, M = -F_res, -M_res  # what the joint must supply for the slider's quasi-static balance
        R_perp = R - jnp.sum(R * zJ, -1, keepdims=True) * zJ
        M_perp = M - jnp.sum(M * zJ, -1, keepdims=True) * zJ
        return R_perp, M_perp

    def _law(self, P, mk, ctx):
        x, xd, zJ, delta = joint_coordinate(self.oh_i, self.oh_j, self.rot, mk)
        centre = self.oh_j @ mk.r + P["slide_friction_bearing_offset"][:, None] * zJ
        R_perp, M_perp = self._reaction(P, mk, ctx, zJ, centre)
        side = _smooth_norm(R_perp)
        bend = jnp.where(self.use_moment, _smooth_norm(M_perp) / P["slide_friction_overlap"], 0.0)
        N = P["slide_friction_preload"] + side + bend
        mu = friction_coefficient(xd, P["slide_friction_mu_static"], P["slide_friction_mu_dynamic"], P["slide_friction_v_stiction"], P["slide_friction_v_friction"])
        f = -(mu * N + P["slide_friction_damping"] * xd)
        return xd, zJ, delta, f, N, side, bend * P["slide_friction_overlap"], mu

    def loads(self, P, mk, t, ctx):
        xd, zJ, delta, f, *_ = self._law(P, mk, ctx)
        return pair_loads(self.oh_i, self.oh_j, f[:, None] * zJ, None, delta)

    def dissipation(self, P, mk, t, ctx):
        xd, zJ, delta, f, *_ = self._law(P, mk, ctx)
        return -jnp.sum(f * xd)

    def outputs(self, P, mk, t, ctx):
        xd, zJ, delta, f, N, side, bend, mu = self._law(P, mk, ctx)
        return {
            "force": (f, "N"), "normal_load": (N, "N"), "side_force": (side, "N"), "bending_moment": (bend, "N m"),
            "mu": (mu, "-"), "rate": (xd, "m/s"), "power": (f * xd, "W"),
        }


__all__ = ["SlideFrictionGroup", "friction_coefficient"]
