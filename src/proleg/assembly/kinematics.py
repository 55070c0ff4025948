"""Body and marker kinematics from the absolute coordinates (formulation note §0-§1).

Arrays are struct-of-arrays over bodies; row ``nbody`` is ground (r = 0, A = I). Marker
quantities are gathered with constant indices (select.py).
"""

from __future__ import annotations

from typing import NamedTuple

import jax.numpy as jnp
import numpy as np

from ..errors import ModelError
from ..spatial.rotation import A_of_p, G_of_p, L_of_p, mm, mv
from .constraints import joint_angle, joint_translation


class BodyKin(NamedTuple):
    r: jnp.ndarray  # (nb+1, 3) COM position, ground row last
    p: jnp.ndarray  # (nb+1, 4)
    A: jnp.ndarray  # (nb+1, 3, 3)
    rd: jnp.ndarray  # (nb+1, 3) COM velocity
    w: jnp.ndarray  # (nb+1, 3) angular velocity, ground components


class MarkerKin(NamedTuple):
    r: jnp.ndarray  # (nm, 3) origin, ground
    R: jnp.ndarray  # (nm, 3, 3) axes (columns x, y, z), ground
    v: jnp.ndarray  # (nm, 3) origin velocity, ground
    w: jnp.ndarray  # (nm, 3) angular velocity, ground
    Ab: jnp.ndarray  # (nm, 3, 3) rotation of the marker's body
    s: jnp.ndarray  # (nm, 3) marker origin relative to body COM, ground components


# The ground row as NumPy constants: a constant operand of the concatenation, not a traced
# broadcast per call (body_kin is traced in every evaluation and its derivatives).
_GROUND_R = np.zeros((1, 3))
_GROUND_P = np.array([[1.0, 0.0, 0.0, 0.0]])


def body_kin(nbody: int, q, v=None) -> BodyKin:
    qb = q[: 7 * nbody].reshape(nbody, 7)
    r = jnp.concatenate([qb[:, :3], _GROUND_R.astype(q.dtype)], 0)
    p = jnp.concatenate([qb[:, 3:], _GROUND_P.astype(q.dtype)], 0)
    A = A_of_p(p)
    if v is None:
        rd = jnp.zeros_like(r)
        w = rd
    else:
        vb = v[: 7 * nbody].reshape(nbody, 7)
        rd = jnp.concatenate([vb[:, :3], _GROUND_R.astype(v.dtype)], 0)
        pd = jnp.concatenate([vb[:, 3:], np.zeros((1, 4), v.dtype)], 0)
        w = 2.0 * mv(G_of_p(p), pd)
    return BodyKin(r, p, A, rd, w)


def marker_kin(body_of, marker_s, marker_C, bk: BodyKin, flex=None) -> MarkerKin:
    """Marker frames; ``body_of`` is the constant (nm, nb+1) marker→body selection (select.Select).

    ``flex = (eta, etad, phi, psi)`` adds the deformation of markers on flexible bodies:
    s' = s'_0 + Φ η, C = (I + (Ψ η)~) C_0, with the deformation velocities in v and ω.
    """
    # one gather of the bodies' [A, ω, ṙ, r] rows instead of one per quantity (each a kernel)
    nm = marker_s.shape[0]
    rows = body_of @ jnp.concatenate([bk.A.reshape(-1, 9), bk.w, bk.rd, bk.r], 1)
    Ab, w, rd_m, r_m = rows[:, :9].reshape(nm, 3, 3), rows[:, 9:12], rows[:, 12:15], rows[:, 15:]
    if flex is None:
        s = mv(Ab, marker_s)
        R = mm(Ab, marker_C)
        v = rd_m + jnp.cross(w, s)
    else:
        eta, etad, phi, psi = flex
        from ..spatial.rotation import skew

        s_loc = marker_s + jnp.einsum("mij,j->mi", phi, eta)
        s = jnp.einsum("mij,mj->mi", Ab, s_loc)
        R = Ab @ ((jnp.eye(3) + skew(jnp.einsum("mij,j->mi", psi, eta))) @ marker_C)
        v = rd_m + jnp.cross(w, s)
        if etad is not None:
            v = v + jnp.einsum("mij,mj->mi", Ab, jnp.einsum("mij,j->mi", phi, etad))
            w = w + jnp.einsum("mij,mj->mi", Ab, jnp.einsum("mij,j->mi", psi, etad))
    return MarkerKin(r_m + s, R, v, w, Ab, s)


def body_L(p):
    return L_of_p(p)


# ---------------------------------------------------------------------------------------------
# What user functions see, and the kinematics of a System (duck-typed: .topo, .params)
# ---------------------------------------------------------------------------------------------
class StateView:
    """What user force/torque/motion functions see: ``state.position('upper')`` etc. (traceable)."""

    def __init__(self, topo, bk, mk, t, z=None, params=None):
        self._topo, self._bk, self._mk, self.t, self.z, self._P = topo, bk, mk, t, z, params

    def _b(self, part):
        name = getattr(part, "name", part)
        if name == "ground":
            return self._topo.nbody
        try:
            return self._topo.body_names.index(name)
        except ValueError:
            raise ModelError(f"State access: no part named '{name}'.") from None

    def _m(self, marker):
        name = getattr(marker, "name", marker)
        try:
            return self._topo.marker_names.index(name)
        except ValueError:
            raise ModelError(f"State access: no marker named '{name}'.") from None

    def position(self, part):
        return self._bk.r[self._b(part)]

    def velocity(self, part):
        return self._bk.rd[self._b(part)]

    def orientation(self, part):
        return self._bk.A[self._b(part)]

    def angular_velocity(self, part):
        return self._bk.w[self._b(part)]

    def marker_position(self, marker):
        return self._mk.r[self._m(marker)]

    def marker_velocity(self, marker):
        return self._mk.v[self._m(marker)]

    def marker_orientation(self, marker):
        return self._mk.R[self._m(marker)]

    def _joint_markers(self, joint):
        name = getattr(joint, "name", joint)
        for j in self._topo.joints:
            if j.name == name:
                return self._m(j.marker_i.name), self._m(j.marker_j.name)
        raise ModelError(f"State access: no joint named '{name}'.")

    def joint_angle(self, joint):
        """Rotation [rad] of the joint's marker I relative to J about z_J."""
        i, j = self._joint_markers(joint)
        return joint_angle(self._mk.R[i], self._mk.R[j])

    def joint_rate(self, joint):
        """d/dt of :meth:`joint_angle` [rad/s]."""
        i, j = self._joint_markers(joint)
        return jnp.dot(self._mk.R[j][:, 2], self._mk.w[i] - self._mk.w[j])

    def joint_translation(self, joint):
        i, j = self._joint_markers(joint)
        return joint_translation(self._mk.r[i], self._mk.r[j], self._mk.R[j])

    def variable(self, name):
        """Value of the design variable ``name`` (``model.add_variable``), a traced parameter."""
        key = f"variable_{name}"
        if self._P is None or key not in self._P:
            have = sorted(k[9:] for k in (self._P or {}) if k.startswith("variable_"))
            raise ModelError(f"State access: no design variable named '{name}'. Known: {have}. Add it with model.add_variable.")
        return self._P[key]

    def contact_force(self, contact):
        """Normal force [N] of a contact (for touchdown / lift-off guards)."""
        name = getattr(contact, "name", contact)
        for g in self._topo.extensions:
            if g.kind == "contact" and name in g.names:
                out = g.outputs(self._P, self._mk, self.t, self)
                return out["normal_force"][0][g.names.index(name)]
        raise ModelError(f"State access: no contact named '{name}'.")


def kinematics(system, q, v=None):
    """(body, marker) kinematics of a System at (q, v): positions, frames, velocities."""
    topo, P = system.topo, system.params
    bk = body_kin(topo.nbody, q, v)
    flex = None
    if topo.n_eta:
        n0 = 7 * topo.nbody
        flex = (q[n0:], None if v is None else v[n0:], P["marker_phi"], P["marker_psi"])
    mk = marker_kin(topo.marker_oh, P["marker_s"], P["marker_C"], bk, flex)
    return bk, mk
