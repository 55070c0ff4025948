"""Body and marker kinematics from the absolute coordinates (formulation note §0-§1).

Arrays are struct-of-arrays over bodies; row ``nbody`` is ground (r = 0, A = I). Marker
quantities are gathered with constant indices (select.py).
"""

from __future__ import annotations

from typing import NamedTuple

import jax.numpy as jnp

from ..spatial.rotation import A_of_p, G_of_p, L_of_p, mm, mv


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


_GROUND_P = jnp.array([1.0, 0.0, 0.0, 0.0])


def body_kin(nbody: int, q, v=None) -> BodyKin:
    qb = q[: 7 * nbody].reshape(nbody, 7)
    r = jnp.concatenate([qb[:, :3], jnp.zeros((1, 3), q.dtype)], 0)
    p = jnp.concatenate([qb[:, 3:], _GROUND_P[None, :].astype(q.dtype)], 0)
    A = A_of_p(p)
    if v is None:
        rd = jnp.zeros_like(r)
        w = jnp.zeros_like(r)
    else:
        vb = v[: 7 * nbody].reshape(nbody, 7)
        rd = jnp.concatenate([vb[:, :3], jnp.zeros((1, 3), v.dtype)], 0)
        pd = jnp.concatenate([vb[:, 3:], jnp.zeros((1, 4), v.dtype)], 0)
        w = 2.0 * mv(G_of_p(p), pd)
    return BodyKin(r, p, A, rd, w)


def marker_kin(body_of, marker_s, marker_C, bk: BodyKin, flex=None) -> MarkerKin:
    """Marker frames; ``body_of`` is the constant (nm, nb+1) marker→body selection (select.Select).

    ``flex = (eta, etad, phi, psi)`` adds the deformation of markers on flexible bodies:
    s' = s'_0 + Φ η, C = (I + (Ψ η)~) C_0, with the deformation velocities in v and ω.
    """
    Ab = body_of @ bk.A
    w = body_of @ bk.w
    if flex is None:
        s = mv(Ab, marker_s)
        R = mm(Ab, marker_C)
        v = body_of @ bk.rd + jnp.cross(w, s)
    else:
        eta, etad, phi, psi = flex
        from ..spatial.rotation import skew

        s_loc = marker_s + jnp.einsum("mij,j->mi", phi, eta)
        s = jnp.einsum("mij,mj->mi", Ab, s_loc)
        R = Ab @ ((jnp.eye(3) + skew(jnp.einsum("mij,j->mi", psi, eta))) @ marker_C)
        v = body_of @ bk.rd + jnp.cross(w, s)
        if etad is not None:
            v = v + jnp.einsum("mij,mj->mi", Ab, jnp.einsum("mij,j->mi", phi, etad))
            w = w + jnp.einsum("mij,mj->mi", Ab, jnp.einsum("mij,j->mi", psi, etad))
    r = body_of @ bk.r + s
    return MarkerKin(r, R, v, w, Ab, s)


def body_L(p):
    return L_of_p(p)
