"""Flexible bodies: a Craig-Bampton reduced FE model in a floating frame of reference
(seed 002 Eqs. 12-15; Adams' MNF flexible body)."""

from __future__ import annotations

import numpy as np

from ..errors import ModelError
from ._validate import finite_array, rotation
from .parts import Marker, Part


class FlexibleBody(Part):
    """A linear flexible body: rigid floating frame + Craig-Bampton coordinates.

    The body frame is attached to ``frame_node`` (its six DOFs are the reference conditions:
    the frame follows that node, the remaining coordinates η describe deformation relative to
    it). Its origin is at that node, its axes are the FE model's axes rotated by
    ``orientation``. Kinetic energy T = ½ ξ̇ᵀ M_r ξ̇ with ξ̇ the reduced coordinates of the
    rigid velocity field (from the boundary nodes' deformed positions) plus η̇, so the equations
    come from the Lagrangian by autodiff and conserve energy; elastic energy ½ ηᵀK_ηη η; modal
    damping with ratio ``damping_ratio`` per free-free mode of the deformation block.

    Parameters
    ----------
    reduced : :class:`proleg.fem.ReducedBody` (or a path to its ``.npz`` file); not orthonormalised
    frame_node : int, a node whose 6 DOFs are boundary DOFs of the reduction
    position : (3,) [m] ground position of the frame node at the modelled pose
    orientation : (3, 3) FE axes → ground
    damping_ratio : float or (n_eta,) [-]
    stress : optional ``(points, fn)``: ``fn(u)`` maps a full-model displacement vector (ndof,) to
        the stress tensors (k, 3, 3) [Pa] at ``points`` (e.g. ``lambda u: solid.stress_at(u, pts).stress``);
        stress is linear in η, so it is precomputed per deformation coordinate and
        ``result.stress(name)`` gives the von Mises stress history (n, k) (stress recovery, e.g.
        at the clamped end of FLEGX's link).
    """

    is_flexible = True

    def __init__(self, name, reduced, frame_node, position, orientation=None, damping_ratio=0.0, velocity=None, angular_velocity=None, stress=None):
        from ..fem.craig_bampton import ReducedBody

        if isinstance(reduced, str) or hasattr(reduced, "__fspath__"):
            reduced = ReducedBody.load(reduced)
        if not isinstance(reduced, ReducedBody):
            raise ModelError(f"FlexibleBody '{name}': reduced must be a proleg.fem.ReducedBody or its .npz path, got {type(reduced).__name__}.")
        if reduced.orthonormalized:
            raise ModelError(f"FlexibleBody '{name}': give a reduction with physical boundary DOFs (craig_bampton(..., orthonormalize=False)).")
        n_nodes = reduced.node_coordinates.shape[0]
        if not (0 <= int(frame_node) < n_nodes):
            raise ModelError(f"FlexibleBody '{name}': frame_node {frame_node} is not a node of the mesh (0..{n_nodes - 1}).")
        self.reduced = reduced
        self.frame_node = int(frame_node)
        dofs = reduced.node_dofs[self.frame_node]
        col_of = {int(d): k for k, d in enumerate(reduced.boundary_dofs)}
        frame_cols = [col_of.get(int(d)) for d in dofs if d >= 0]
        if any(c is None for c in frame_cols) or len(frame_cols) != 6:
            raise ModelError(
                f"FlexibleBody '{name}': frame_node {frame_node} must carry 6 boundary DOFs of the reduction "
                "(make it an interface node with translations and rotations)."
            )
        self.frame_cols = np.array(frame_cols, int)  # columns for (ux, uy, uz, rx, ry, rz) at the frame node
        self.eta_cols = np.setdiff1d(np.arange(reduced.nq), self.frame_cols)
        R = np.eye(3) if orientation is None else rotation(f"FlexibleBody '{name}' orientation", orientation)
        pos = finite_array(f"FlexibleBody '{name}' position", position, (3,))
        self.X = reduced.node_coordinates - reduced.node_coordinates[self.frame_node]  # body frame, undeformed
        # Rigid fields in reduced coordinates: boundary DOF c at node k, type d (0-2 transl., 3-5 rot.).
        self.bnode = np.zeros(reduced.nq, int) - 1
        self.btype = np.zeros(reduced.nq, int) - 1
        for c, d in enumerate(reduced.boundary_dofs):
            k, t = np.argwhere(reduced.node_dofs == d)[0]
            self.bnode[c], self.btype[c] = k, t
        M = reduced.M
        e = [np.where((self.btype == d) & (self.bnode >= 0), 1.0, 0.0) for d in range(3)]  # unit translations
        mass = float(e[0] @ M @ e[0])
        if not mass > 0:
            raise ModelError(f"FlexibleBody '{name}': the reduced mass matrix gives a non-positive mass {mass}.")
        # First moment about the frame node from the position field of the boundary nodes is not in
        # the basis; use the FE invariants (mass, COM) when present, else the node average.
        inv = reduced.invariants or {}
        if "I1" in inv and "I2" in inv and float(inv["I1"]) > 0:
            com = np.asarray(inv["I2"], float) / float(inv["I1"])  # about the FE origin
        else:  # no invariants stored: node average (exact for uniform meshes)
            com = reduced.node_coordinates.mean(0)
        self.S0 = mass * (com - reduced.node_coordinates[self.frame_node])
        self.S1 = np.stack([ei @ M[:, self.eta_cols] for ei in e])  # (3, n_eta): first moment of deformation
        self.K_eta = reduced.K[np.ix_(self.eta_cols, self.eta_cols)]
        Mee = M[np.ix_(self.eta_cols, self.eta_cols)]
        # modal damping: D = Mee Φ diag(2 ζ ω) Φᵀ Mee with Φ mass-normalised eigenvectors of (K, M)
        import scipy.linalg

        w2, Phi = scipy.linalg.eigh(self.K_eta, Mee)
        zeta = np.broadcast_to(np.asarray(damping_ratio, float), w2.shape)
        if np.any(zeta < 0):
            raise ModelError(f"FlexibleBody '{name}': damping_ratio must be ≥ 0.")
        self.D_eta = Mee @ Phi @ np.diag(2 * zeta * np.sqrt(np.clip(w2, 0, None))) @ Phi.T @ Mee
        self.frequencies_hz = np.sqrt(np.clip(w2, 0, None)) / (2 * np.pi)
        J = np.asarray(inv["I7"], float) if "I7" in inv else np.eye(3) * mass * 1e-6  # about the FE origin (info only)
        super().__init__(name, mass, J, pos, R, np.zeros(3) if velocity is None else finite_array(f"FlexibleBody '{name}' velocity", velocity, (3,)),
                         np.zeros(3) if angular_velocity is None else finite_array(f"FlexibleBody '{name}' angular_velocity", angular_velocity, (3,)))

        self.stress_points, self.stress_modes = None, None
        if stress is not None:
            pts, fn = stress
            T = reduced.basis
            self.stress_points = np.asarray(pts, float)
            self.stress_modes = np.stack([np.asarray(fn(T[:, c]), float) for c in self.eta_cols], -1)  # (k, 3, 3, n_eta)

    @property
    def n_eta(self) -> int:
        return len(self.eta_cols)

    def node_marker(self, name, node, orientation=None) -> Marker:
        """A marker at FE node ``node`` (body axes = FE axes unless ``orientation``)."""
        n_nodes = self.X.shape[0]
        if not (0 <= int(node) < n_nodes):
            raise ModelError(f"Marker '{name}': node {node} is not a node of flexible body '{self.name}' (0..{n_nodes - 1}).")
        C = np.eye(3) if orientation is None else self.orientation.T @ rotation(f"Marker '{name}' orientation", orientation)
        m = Marker(name, self, self.X[int(node)].copy(), C)
        m.node = int(node)
        return m

    def nearest_node(self, position, tol=1e-6) -> int:
        local = self.orientation.T @ (np.asarray(position, float) - self.position)
        d = np.linalg.norm(self.X - local, axis=1)
        k = int(np.argmin(d))
        if d[k] > tol:
            raise ModelError(
                f"Marker on flexible body '{self.name}': position {np.round(position, 6).tolist()} is not on the mesh "
                f"(nearest node {k} is {d[k]:.3g} m away). Attach markers at FE nodes (node=...)."
            )
        return k

    def __repr__(self):
        return f"FlexibleBody({self.name!r}, mass={self.mass:g} kg, {self.n_eta} deformation coordinates)"
