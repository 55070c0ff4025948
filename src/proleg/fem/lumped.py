"""Rigid lumped masses and linear 6-DOF springs added to a beam or solid FE model.

A :class:`LumpedModel` starts from the stiffness and mass of an FE model (or from nothing) and
appends rigid bodies (6 DOFs: translation of the centre of mass and small rotation,
ux, uy, uz, rx, ry, rz) and springs between two "points": a beam node (its 6 DOFs), a rigid
body (the spring end sits at a given point of the body) or ground. It is the model of heavy
components on elastic mounts and of a structure resting on a soft support.

Spring law: with d = [u_I(p) - u_J(p), theta_I - theta_J] the relative translation at the
spring point p and the relative rotation (I and J the two ends, ground = 0), the energy is
1/2 d^T K_s d with K_s = diag(k) (6,) [N/m x3, N m/rad x3] in ground axes. The force on I is
-K_s d, the reaction acts on J.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from ..errors import ModelError
from .craig_bampton import solve_modes


def _skew(r):
    x, y, z = r
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


class LumpedModel:
    """An FE model (K, M) extended with rigid bodies and 6-DOF springs.

    Parameters
    ----------
    K, M : (n, n) sparse or dense [SI], optional   the structure's stiffness and mass (None: empty)
    node_coordinates : (n_nodes, 3) [m], optional  positions of the structure's nodes
    node_dof_table : (n_nodes, 6) int, optional     DOF indices (ux..rz) of the nodes, -1 if absent
    """

    def __init__(self, K=None, M=None, node_coordinates=None, node_dof_table=None):
        n = 0 if K is None else K.shape[0]
        self._K = [sp.csr_matrix(K) if K is not None else sp.csr_matrix((0, 0))]
        self._M = [sp.csr_matrix(M) if M is not None else sp.csr_matrix((0, 0))]
        self.ndof = n
        self.node_coordinates = np.zeros((0, 3)) if node_coordinates is None else np.asarray(node_coordinates, float)
        self.node_dof_table = np.zeros((0, 6), int) if node_dof_table is None else np.asarray(node_dof_table, int)
        self.bodies: dict[str, dict] = {}
        self._extra: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []  # (dofs, k_block, m_block)

    # -- building -----------------------------------------------------------------------------
    def add_body(self, name: str, mass: float, center, inertia=None) -> np.ndarray:
        """Add a rigid body; returns its 6 DOF indices.

        mass [kg] > 0; center (3,) [m] centre of mass; inertia (3,) or (3, 3) [kg m^2] about the
        centre of mass in ground axes (default: that of a point, tiny but non-singular)."""
        if name in self.bodies:
            raise ModelError(f"LumpedModel body '{name}' already exists; give each body its own name.")
        if not (np.isfinite(mass) and mass > 0):
            raise ModelError(f"LumpedModel body '{name}' mass must be positive [kg]; got {mass!r}.")
        J = np.eye(3) * mass * 1e-6 if inertia is None else np.asarray(inertia, float)
        J = np.diag(J) if J.shape == (3,) else J
        if J.shape != (3, 3) or np.any(np.linalg.eigvalsh(0.5 * (J + J.T)) <= 0):
            raise ModelError(f"LumpedModel body '{name}' inertia must be (3,) or (3, 3) positive definite [kg m^2].")
        dofs = np.arange(self.ndof, self.ndof + 6)
        self.ndof += 6
        Mb = np.zeros((6, 6))
        Mb[:3, :3] = mass * np.eye(3)
        Mb[3:, 3:] = J
        self._extra.append((dofs, np.zeros((6, 6)), Mb))
        self.bodies[name] = dict(dofs=dofs, mass=float(mass), center=np.asarray(center, float), inertia=J)
        return dofs

    def _end(self, end, point):
        """(dofs (6,), map (6, 6)) so that [u(p); theta] = map @ q[dofs]; None for ground."""
        if end is None or end == "ground":
            return None
        if isinstance(end, str):
            if end not in self.bodies:
                raise ModelError(f"LumpedModel spring end '{end}' is not a body; bodies: {sorted(self.bodies)}, "
                                 "or give a node index, or 'ground'.")
            b = self.bodies[end]
            T = np.eye(6)
            T[:3, 3:] = -_skew(np.asarray(point, float) - b["center"])
            return b["dofs"], T
        node = int(end)
        if not 0 <= node < self.node_dof_table.shape[0]:
            raise ModelError(f"LumpedModel spring end node {end} does not exist (0..{self.node_dof_table.shape[0] - 1}).")
        dofs = self.node_dof_table[node]
        if np.any(dofs < 0):
            raise ModelError(f"LumpedModel spring end node {node} lacks rotation DOFs; springs attach to beam nodes "
                             "(6 DOFs) or bodies.")
        T = np.eye(6)
        T[:3, 3:] = -_skew(np.asarray(point, float) - self.node_coordinates[node])
        return dofs, T

    def add_spring(self, end_i, end_j, stiffness, point=None, name: str = "spring") -> None:
        """Add a 6-DOF spring between ``end_i`` and ``end_j`` (a body name, a node index, or
        None/"ground"), acting at ``point`` (3,) [m] (default: the node or the body centre of ``end_i``).

        stiffness : (6,) [N/m x3, N m/rad x3], >= 0, in ground axes."""
        k = np.broadcast_to(np.asarray(stiffness, float), (6,))
        if not np.all(np.isfinite(k)) or np.any(k < 0):
            raise ModelError(f"LumpedModel spring '{name}' stiffness must be six non-negative numbers; got {stiffness!r}.")
        if point is None:
            if isinstance(end_i, str) and end_i != "ground":
                point = self.bodies[end_i]["center"] if end_i in self.bodies else None
            elif end_i is not None and end_i != "ground":
                point = self.node_coordinates[int(end_i)]
            if point is None:
                raise ModelError(f"LumpedModel spring '{name}': give point= (3,) [m] where it acts.")
        ends = [self._end(e, point) for e in (end_i, end_j)]
        if ends[0] is None and ends[1] is None:
            raise ModelError(f"LumpedModel spring '{name}' joins ground to ground; one end must be a body or node.")
        dofs, cols = [], []
        for sign, e in zip((1.0, -1.0), ends, strict=True):
            if e is not None:
                dofs.append(e[0])
                cols.append(sign * e[1])
        G = np.hstack(cols)  # d = G q
        self._extra.append((np.concatenate(dofs), G.T @ np.diag(k) @ G, np.zeros((G.shape[1],) * 2)))

    # -- matrices -----------------------------------------------------------------------------
    @property
    def K(self) -> sp.csr_matrix:
        return self._assemble(1)

    @property
    def M(self) -> sp.csr_matrix:
        return self._assemble(2)

    def _assemble(self, which) -> sp.csr_matrix:
        base = (self._K[0] if which == 1 else self._M[0]).tocoo()
        r, c, v = [base.row], [base.col], [base.data]
        for dofs, kb, mb in self._extra:
            blk = kb if which == 1 else mb
            r.append(np.repeat(dofs, dofs.size))
            c.append(np.tile(dofs, dofs.size))
            v.append(blk.ravel())
        return sp.coo_matrix((np.concatenate(v), (np.concatenate(r), np.concatenate(c))),
                             shape=(self.ndof, self.ndof)).tocsr()

    def modes(self, n_modes: int, fixed_dofs=None):
        """Lowest natural frequencies (n_modes,) [rad/s] and mass-normalised shapes (ndof, n_modes)."""
        return solve_modes(self.K, self.M, n_modes, fixed_dofs)

    def rigid_body_vectors(self, center) -> np.ndarray:
        """(ndof, 6) displacement fields of unit rigid translations x, y, z and rotations about
        x, y, z through ``center`` [m] (for participation factors and effective masses)."""
        c = np.asarray(center, float)
        R = np.zeros((self.ndof, 6))
        tab = self.node_dof_table
        for k in range(6):
            q = np.zeros(6)
            q[k] = 1.0
            for i in range(tab.shape[0]):
                T = np.eye(6)
                T[:3, 3:] = -_skew(self.node_coordinates[i] - c)
                vals = T @ q
                ok = tab[i] >= 0
                R[tab[i][ok], k] = vals[ok]
            for b in self.bodies.values():
                T = np.eye(6)
                T[:3, 3:] = -_skew(b["center"] - c)
                R[b["dofs"], k] = T @ q
        return R
