"""Flexible bodies in the floating frame of reference (see :class:`proleg.model.flexible.FlexibleBody`).

Coordinates: each flexible body has a frame (7 coordinates, like a rigid part) and n_eta
deformation coordinates η appended after all frames in q. Inertia comes from the Lagrangian:
M q̈ = ∂²T/∂v² q̈ and the velocity terms ∂T/∂q − (∂²T/∂v∂q) v, both by autodiff of T.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from ..spatial.rotation import A_of_p, L_of_p


class FlexGroup:
    kind = "flexible_body"

    def __init__(self, bodies, body_index, eta_offset0):
        self.bodies = list(bodies)
        self.names = [b.name for b in self.bodies]
        self.elements = self.bodies
        self.b = [body_index[id(b)] for b in self.bodies]
        self.off = []
        off = eta_offset0
        for b in self.bodies:
            self.off.append(off)
            off += b.n_eta
        self.n_eta = off - eta_offset0
        self.eta0 = eta_offset0

    def __len__(self):
        return len(self.bodies)

    def params(self):
        P = {}
        for b in self.bodies:
            n = b.name
            P[f"flex_{n}_M"] = b.reduced.M
            P[f"flex_{n}_K"] = b.K_eta
            P[f"flex_{n}_D"] = b.D_eta
            P[f"flex_{n}_S0"] = b.S0
            P[f"flex_{n}_S1"] = b.S1
        return P

    def _split(self, k, q, v):
        b, body = self.b[k], self.bodies[k]
        o = self.off[k]
        r, p = q[7 * b : 7 * b + 3], q[7 * b + 3 : 7 * b + 7]
        eta = q[o : o + body.n_eta]
        if v is None:
            return r, p, eta, None, None, None
        return r, p, eta, v[7 * b : 7 * b + 3], v[7 * b + 3 : 7 * b + 7], v[o : o + body.n_eta]

    def kinetic(self, P, q, v):
        T = 0.0
        for k, body in enumerate(self.bodies):
            r, p, eta, rd, pd, etad = self._split(k, q, v)
            A = A_of_p(p)
            wl = 2.0 * L_of_p(p) @ pd
            vl = A.T @ rd
            red = body.reduced
            bn = np.maximum(body.bnode, 0)
            # boundary-node deformed positions (body frame)
            U = jnp.einsum("cij,j->ci", jnp.asarray(red.modes[bn][:, :3][:, :, body.eta_cols]), eta)
            x = jnp.asarray(body.X[bn]) + U
            lin = vl[None, :] + jnp.cross(wl[None, :], x)  # (nq_r, 3)
            t = body.btype
            val = jnp.where(t < 3, jnp.take_along_axis(lin, np.clip(t, 0, 2)[:, None], 1)[:, 0], wl[np.clip(t - 3, 0, 2)])
            xi = jnp.where(body.bnode >= 0, val, 0.0)
            xi = xi.at[body.eta_cols].add(etad)
            T = T + 0.5 * xi @ P[f"flex_{body.name}_M"] @ xi
        return T

    def potential(self, P, q, gravity):
        V = 0.0
        for k, body in enumerate(self.bodies):
            r, p, eta, *_ = self._split(k, q, None)
            n = body.name
            S = P[f"flex_{n}_S0"] + P[f"flex_{n}_S1"] @ eta
            V = V - gravity @ (body.mass * r + A_of_p(p) @ S) + 0.5 * eta @ P[f"flex_{n}_K"] @ eta
        return V

    def dissipative(self, P, q, v):
        """Generalized modal damping forces (nq,) and their dissipated power."""
        Q = jnp.zeros_like(q)
        pw = 0.0
        for k, body in enumerate(self.bodies):
            *_, etad = self._split(k, q, v)
            f = -P[f"flex_{body.name}_D"] @ etad
            Q = Q.at[self.off[k] : self.off[k] + body.n_eta].add(f)
            pw = pw - f @ etad
        return Q, pw

    def mass_action(self, P, q, qdd):
        g = jax.grad(self.kinetic, argnums=2)
        return jax.jvp(lambda vv: g(P, q, vv), (jnp.zeros_like(q),), (qdd,))[1]

    def forces(self, P, q, v, gravity):
        """∂T/∂q − (∂²T/∂v∂q) v − ∂V/∂q − D η̇ (no M q̈)."""
        dTdq = jax.grad(self.kinetic, argnums=1)(P, q, v)
        gv = jax.grad(self.kinetic, argnums=2)
        mixed = jax.jvp(lambda qq: gv(P, qq, v), (q,), (v,))[1]
        dVdq = jax.grad(self.potential, argnums=1)(P, q, gravity)
        Qd, _ = self.dissipative(P, q, v)
        return dTdq - mixed - dVdq + Qd

    def marker_fields(self, markers, nm, n_eta_total):
        """(nm, 3, n_eta) translation and rotation fields of the markers on flexible bodies."""
        phi = np.zeros((nm, 3, n_eta_total))
        psi = np.zeros((nm, 3, n_eta_total))
        for mi, m in enumerate(markers):
            if getattr(m.part, "is_flexible", False):
                k = self.names.index(m.part.name)
                body = m.part
                node = getattr(m, "node", None)
                if node is None:
                    node = body.nearest_node(m.position)
                o = self.off[k] - self.eta0
                phi[mi, :, o : o + body.n_eta] = body.reduced.modes[node, :3][:, body.eta_cols]
                psi[mi, :, o : o + body.n_eta] = body.reduced.modes[node, 3:][:, body.eta_cols]
        return phi, psi
