"""The coordinates the integrator runs on: absolute (every model) or planar (planar mechanisms).

``Absolute`` is the formulation of ../shared/notes/formulation.md: per part the COM position
and four Euler parameters, 7 coordinates, plus modal coordinates of flexible bodies.

``Planar`` runs a planar mechanism on 3 coordinates per part, (dx, dy, θ): the displacement in
the plane and the rotation about the plane normal n from a reference configuration q_ref, so

    r = r_ref + E (dx, dy),    p = p_n(θ) ⊗ p_ref,   p_n(θ) = (cos θ/2, n sin θ/2)

with E the 3×2 in-plane basis. Every element and joint is still evaluated by the absolute
functions of ``system.py`` through this map (nothing is re-implemented in 2-D): with
T = ∂q/∂x, the equations of motion are Tᵀ(M q̈ − Q) + Φ_xᵀλ = 0 and q̈ = T ẍ + Ṫ ẋ, where
M Ṫ ẋ = 0 because the only second-order term is p̈ ∋ −p θ̇²/4 and 4LᵀJ'L p = 0. The reduction
is exact (virtual work), not a 2-D approximation: it is used only when the joints confine every
part to the plane, which ``planar_basis`` proves numerically: the rows of Φ that are not
identically zero on the planar manifold, combined per joint into independent rows, leave
exactly the degrees of freedom of the absolute model (nq − nc). Reactions out of the plane,
energies and every output are then computed in absolute coordinates from q(x), v(x, ẋ)
(analyses/result.py), so results look the same whichever coordinates ran.

Why: a 7-part planar chain has a Newton matrix of n = 35 instead of 91, and on XLA-CPU the
LU, triangular solves and n²-sized copies of that matrix are most of the cost of a step
(bench/README.md).
"""

from __future__ import annotations

from dataclasses import dataclass

import jax
import jax.numpy as jnp
import numpy as np

from ..errors import ModelError
from ..spatial.rotation import A_of_p, quat_mul
from .select import Select
from .sparsity import Coloring, greedy_coloring
from .system import System, constraints, generalized_forces, mass_action, power_terms


@jax.tree_util.register_pytree_node_class
class Absolute:
    """The model's own coordinates: q = [r, p] per part (+ modal coordinates)."""

    kind = "absolute"

    def __init__(self, system: System):
        self.system = system

    @staticmethod
    def of(system_or_coords):
        """``Absolute(system)`` for a System, the coordinate set itself otherwise."""
        return Absolute(system_or_coords) if isinstance(system_or_coords, System) else system_or_coords

    def tree_flatten(self):
        return (self.system,), None

    @classmethod
    def tree_unflatten(cls, aux, children):
        return cls(*children)

    @property
    def nq(self) -> int:
        return self.system.nq

    @property
    def nc(self) -> int:
        return self.system.nc

    @property
    def coloring(self) -> Coloring:
        return self.system.topo.coloring

    def weights(self, q, rtol, atol, atol_p):
        """Error weights atol + rtol·|q| per coordinate."""
        nb = self.system.topo.nbody
        a = jnp.concatenate([jnp.tile(jnp.array([atol] * 3 + [atol_p] * 4), nb), jnp.full(self.system.topo.n_eta, atol)])
        return a + rtol * jnp.abs(q)

    def constraints(self, q, t):
        return constraints(self.system, q, t)

    def mass_action(self, q, a):
        return mass_action(self.system, q, a)

    def generalized_forces(self, q, v, t, z=None):
        return generalized_forces(self.system, q, v, t, z)

    def inverse_dynamics(self, q, v, a, t, z=None):
        """M(q) a − Q(q, v, t): the equations of motion's residual without the constraint forces."""
        return mass_action(self.system, q, a) - generalized_forces(self.system, q, v, t, z)

    def power_terms(self, q, v, t, z=None):
        return power_terms(self.system, q, v, t, z)

    def absolute(self, q, v):
        return q, v

    def absolute_row(self, i: int) -> int:
        return int(i)


@dataclass(eq=False)
class PlanarBasis:
    """Static data of a planar reduction (hashed by identity; ``Topology.planar``, set by assemble).

    Its numbers (the plane, the reduction's weights) are part of a model's structure: a trace
    bakes them in, and the compile cache keys them exactly (``_numbers_are_structure``)."""

    _numbers_are_structure = True

    normal: np.ndarray  # (3,) plane normal, ground
    E: np.ndarray  # (3, 2) in-plane basis, E[:, 0] × E[:, 1] = normal
    P: np.ndarray  # (m, nc) rows of the planar constraints as combinations of the absolute rows
    coloring: Coloring
    row_map: np.ndarray  # (3 nb + m,) absolute residual row of each planar row (failure messages)

    def __post_init__(self):
        # P as (m, kmax) row indices and weights: Φ_x = Σ_k w Φ[idx] is one fused gather-reduce
        # (a dense P @ Φ ran as a 20 µs library call inside the Newton-matrix build).
        m = self.P.shape[0]
        nz = [np.flatnonzero(r) for r in self.P]
        kmax = max([len(z) for z in nz] + [1])
        self.P_idx = np.zeros((m, kmax), np.int32)
        self.P_w = np.zeros((m, kmax))
        for r, z in enumerate(nz):
            self.P_idx[r, : len(z)] = z
            self.P_w[r, : len(z)] = self.P[r, z]
        self._pick = Select(self.P_idx.reshape(-1), self.P.shape[1])

    def __repr__(self):  # the arrays are hundreds of numbers: say what the basis is
        n = np.round(self.normal, 6) + 0.0
        return f"PlanarBasis(normal={n.tolist()}, {self.P.shape[0]} planar rows of {self.P.shape[1]})"

    def combine(self, phi):
        """P @ phi."""
        return jnp.sum(jnp.asarray(self.P_w) * (self._pick @ phi).reshape(self.P_idx.shape), 1)


def _in_plane(E, d):
    """E d per row, (k, 2) → (k, 3), as a broadcast sum (tiny matmuls are library calls on CPU)."""
    return jnp.sum(d[:, None, :] * jnp.asarray(E), -1)


def _on_plane(E, f):
    """Eᵀ f per row, (k, 3) → (k, 2)."""
    return jnp.sum(f[:, :, None] * jnp.asarray(E)[None], 1)


def _normal_product(normal):
    """(4, 4) N with (0, n) ⊗ b = b N for rows b (numpy constant)."""
    return np.asarray(quat_mul(np.concatenate([[0.0], normal])[None], np.eye(4)))


@jax.tree_util.register_pytree_node_class
class Planar:
    """Coordinates x = (dx, dy, θ) per part about the reference configuration ``q_ref``."""

    kind = "planar"

    def __init__(self, system: System, q_ref, basis: PlanarBasis):
        self.system, self.q_ref, self.basis = system, q_ref, basis

    def tree_flatten(self):
        return (self.system, self.q_ref), self.basis

    @classmethod
    def tree_unflatten(cls, basis, children):
        return cls(*children, basis)

    @property
    def nq(self) -> int:
        return 3 * self.system.topo.nbody

    @property
    def nc(self) -> int:
        return self.basis.P.shape[0]

    @property
    def coloring(self) -> Coloring:
        return self.basis.coloring

    def weights(self, x, rtol, atol, atol_p):
        """The absolute run's weights in planar terms: translations scaled by the in-plane
        position components, θ by twice the Euler parameters' (δp ≈ δθ/2, |p_i| ≤ 1 → 1/2)."""
        nb = self.system.topo.nbody
        r = self.q_ref.reshape(nb, 7)[:, :3] + _in_plane(self.basis.E, x.reshape(nb, 3)[:, :2])
        rp = jnp.abs(_on_plane(self.basis.E, r))
        w = jnp.concatenate([atol + rtol * rp, jnp.full((nb, 1), 2.0 * atol_p + rtol)], 1)
        return w.reshape(-1)

    def _frames(self, x, rates: bool = True):
        """Absolute q (7 nb,) at x and, with ``rates``, ∂p/∂θ per part (nb, 4).

        p = p_n(θ) ⊗ p_ref = cos(θ/2) p_ref + sin(θ/2) (0, n) ⊗ p_ref is linear in (cos, sin):
        the product with the reference is a constant of x (not differentiated, not traced
        twice), and ∂p/∂θ = (cos(θ/2) (0, n) ⊗ p_ref − sin(θ/2) p_ref)/2."""
        nb = self.system.topo.nbody
        xb = x.reshape(nb, 3)
        qr = self.q_ref.reshape(nb, 7)
        pr = qr[:, 3:]
        npr = jnp.sum(pr[:, :, None] * _normal_product(self.basis.normal), 1)
        half = 0.5 * xb[:, 2:3]
        c, s = jnp.cos(half), jnp.sin(half)
        r = qr[:, :3] + _in_plane(self.basis.E, xb[:, :2])
        q = jnp.concatenate([r, c * pr + s * npr], 1).reshape(-1)
        return (q, 0.5 * (c * npr - s * pr)) if rates else q

    def _q(self, x):
        return self._frames(x, rates=False)

    def _T(self, dp, xd):
        """T ẋ (velocities in absolute coordinates); ``dp`` = ∂p/∂θ of :meth:`_frames`."""
        xdb = xd.reshape(dp.shape[0], 3)
        return jnp.concatenate([_in_plane(self.basis.E, xdb[:, :2]), dp * xdb[:, 2:3]], 1).reshape(-1)

    def _Tt(self, dp, f):
        """Tᵀ f (absolute generalized forces → planar); ``dp`` = ∂p/∂θ of :meth:`_frames`."""
        fb = f.reshape(dp.shape[0], 7)
        return jnp.concatenate([_on_plane(self.basis.E, fb[:, :3]), jnp.sum(dp * fb[:, 3:], 1, keepdims=True)], 1).reshape(-1)

    # Each evaluation computes the frames at x once and shares them between q(x), T ẋ and Tᵀ.
    def constraints(self, x, t):
        return self.basis.combine(constraints(self.system, self._q(x), t))

    def mass_action(self, x, a):
        q, dp = self._frames(x)
        return self._Tt(dp, mass_action(self.system, q, self._T(dp, a)))

    def generalized_forces(self, x, xd, t, z=None):
        q, dp = self._frames(x)
        return self._Tt(dp, generalized_forces(self.system, q, self._T(dp, xd), t, z))

    def inverse_dynamics(self, x, xd, a, t, z=None):
        """Tᵀ M T a − Tᵀ Q: the reduced residual without the constraint forces (each reduced on
        its own, the arithmetic of the α-methods' residual before it was one call)."""
        return self.mass_action(x, a) - self.generalized_forces(x, xd, t, z)

    def power_terms(self, x, xd, t, z=None):
        q, dp = self._frames(x)
        return power_terms(self.system, q, self._T(dp, xd), t, z)

    def absolute(self, x, xd):
        q, dp = self._frames(x)
        return q, self._T(dp, xd)

    def reduce(self, q, v):
        """(x, ẋ) of an absolute state on the plane through q_ref: least squares, exact for
        states of the mechanism (|∂p/∂θ|² = 1/4)."""
        nb = self.system.topo.nbody
        qb, vb, qr = q.reshape(nb, 7), v.reshape(nb, 7), self.q_ref.reshape(nb, 7)
        E = jnp.asarray(self.basis.E)
        n = jnp.asarray(self.basis.normal)
        d = (qb[:, :3] - qr[:, :3]) @ E
        # Rotation of p relative to p_ref about n: p ⊗ p_ref⁻¹ = (cos θ/2, n sin θ/2).
        pr_inv = qr[:, 3:] * jnp.array([1.0, -1.0, -1.0, -1.0])
        rel = quat_mul(qb[:, 3:], pr_inv)
        th = 2.0 * jnp.arctan2(rel[:, 1:] @ n, rel[:, 0])
        x = jnp.concatenate([d, th[:, None]], 1).reshape(-1)
        _, dp = self._frames(x)
        xd = jnp.concatenate([vb[:, :3] @ E, 4.0 * jnp.sum(dp * vb[:, 3:], 1, keepdims=True)], 1).reshape(-1)
        return x, xd

    def reduce_acceleration(self, x, xd, qdd, q=None):
        """ẍ of absolute accelerations q̈ = T ẍ + Ṫ ẋ (Ṫ ẋ = −p θ̇²/4 is orthogonal to ∂p/∂θ)."""
        nb = self.system.topo.nbody
        ab = qdd.reshape(nb, 7)
        _, dp = self._frames(x)
        return jnp.concatenate([_on_plane(self.basis.E, ab[:, :3]), 4.0 * jnp.sum(dp * ab[:, 3:], 1, keepdims=True)], 1).reshape(-1)

    def reduce_multipliers(self, lam):
        """λ_x of absolute multipliers λ: the planar rows are P_r·Φ with P's rows orthogonal
        within a joint and the dropped combinations constant on the plane, so Tᵀ Φ_qᵀ λ =
        Φ_xᵀ λ_x with λ_x,r = P_r·λ / |P_r|²."""
        P = self.basis.P
        return jnp.asarray(P / np.sum(P * P, 1, keepdims=True)) @ lam

    def absolute_row(self, i: int) -> int:
        return int(self.basis.row_map[int(i)])


def _revolute_normal(system: System, q):
    """Common axis (ground) of the model's revolute and planar joints at ``q``, or None."""
    topo = system.topo
    idx = [k for k, j in enumerate(topo.joints) if getattr(j, "kind", "") in ("revolute", "planar")]
    if not idx:
        return None
    nb = topo.nbody
    qb = np.asarray(q)[: 7 * nb].reshape(nb, 7)
    A = np.concatenate([A_of_p(qb[:, 3:]), np.eye(3)[None]], 0)  # ground last
    mj = np.asarray(topo.joint_marker_j)[idx]
    C = np.asarray(system.params["marker_C"])[mj]
    axes = np.einsum("kij,kj->ki", A[topo.marker_body[mj]], C[:, :, 2])
    n = axes[0] / np.linalg.norm(axes[0])
    if np.max(np.linalg.norm(np.cross(axes, n), axis=1)) > 1e-9:
        return None
    return n


def _planar_q(q_ref, x, normal, E):
    """Absolute q of planar coordinates x about q_ref (numpy; the map of Planar._q)."""
    nb = len(x) // 3
    xb, qr = x.reshape(nb, 3), np.asarray(q_ref).reshape(nb, 7)
    half = 0.5 * xb[:, 2:3]
    pn = np.concatenate([np.cos(half), np.sin(half) * normal], 1)
    return np.concatenate([qr[:, :3] + xb[:, :2] @ E.T, quat_mul(pn, qr[:, 3:])], 1).reshape(-1)


def _planar_T(q, normal, E):
    """T = ∂q/∂x at the absolute configuration q (numpy, (7 nb, 3 nb))."""
    nb = len(q) // 7
    dp = quat_mul(np.tile(np.concatenate([[0.0], 0.5 * normal]), (nb, 1)), q.reshape(nb, 7)[:, 3:])
    T = np.zeros((7 * nb, 3 * nb))
    for b in range(nb):
        T[7 * b : 7 * b + 3, 3 * b : 3 * b + 2] = E
        T[7 * b + 3 : 7 * b + 7, 3 * b + 2] = dp[b]
    return T


def planar_basis(system: System, q_ref) -> tuple[PlanarBasis | None, str]:
    """Planar reduction of ``system`` about the configuration ``q_ref`` (assembly), or (None, why).

    Every part must be confined to planar motion by the joints: a common revolute axis n, and
    the rows of Φ whose gradient along the plane (Φ_q T) is not zero at random planar
    configurations (dx, dy, θ per part; the other rows are constant there: the planarity rows)
    must leave exactly the absolute model's degrees of freedom. Rows are combined per joint
    (SVD of the sampled gradients), so the planar constraints keep the absolute sparsity.
    """
    try:
        return _planar_basis(system, jnp.asarray(q_ref))
    except Exception as e:  # a model the sampling cannot evaluate simply runs in absolute coordinates
        return None, f"planar check failed: {type(e).__name__}: {e}"


def _planar_basis(system: System, q_ref):
    topo = system.topo
    nb, nc = topo.nbody, topo.nc
    if topo.n_eta:
        return None, "flexible bodies"
    if nb == 0:
        return None, "no parts"
    n = _revolute_normal(system, q_ref)
    if n is None:
        return None, "no common revolute axis"
    a = np.eye(3)[int(np.argmin(np.abs(n)))]
    e1 = np.cross(n, a)
    e1 /= np.linalg.norm(e1)
    E = np.stack([e1, np.cross(n, e1)], 1)
    # Constraint gradients along the plane, Φ_q T, at random planar configurations and times:
    # rows whose gradient vanishes at every sample are constant on the plane (planarity rows).
    # Uses the function assemble() has already compiled for this topology (Φ and Φ_q; one
    # executable fewer to compile or load than a Jacobian of its own).
    from .system import _jit_constraints_and_jacobian

    rng = np.random.default_rng(0)
    size = 1.0 + float(np.max(np.abs(np.asarray(q_ref).reshape(nb, 7)[:, :3])))
    G = []
    for k in range(12):
        x = np.zeros(3 * nb)
        if k:
            x = np.concatenate([rng.uniform(-size, size, (nb, 2)), rng.uniform(-np.pi, np.pi, (nb, 1))], 1).reshape(-1)
        qk = _planar_q(q_ref, x, n, E)
        Jk = np.asarray(_jit_constraints_and_jacobian(system, jnp.asarray(qk), float(rng.uniform(0.0, 1.0)) if k else 0.0)[1])
        G.append(Jk @ _planar_T(qk, n, E))
    if not np.all(np.isfinite(np.concatenate(G, 1))):
        return None, "constraints not finite on the plane"
    J3 = G[0]  # at x = 0
    G = np.concatenate(G, 1)  # (nc, 12 · 3 nb)
    owner = topo.ct.row_owner
    rows = []
    for o in np.unique(owner[owner >= 0]):
        idx = np.flatnonzero(owner == o)
        U, sv, _ = np.linalg.svd(G[idx], full_matrices=False)
        tol = 1e-9 * max(1.0, float(np.max(np.abs(G[idx]))))
        for u in _canonical_basis(U[:, sv > tol]):
            row = np.zeros(nc)
            row[idx] = u
            rows.append(row)
    P = np.array(rows).reshape(len(rows), nc)
    m = P.shape[0]
    dof_abs = topo.nq - nc
    if 3 * nb - m != dof_abs:
        return None, f"{3 * nb - m} planar vs {dof_abs} spatial degrees of freedom"
    Jx = P @ J3
    if m and np.linalg.matrix_rank(Jx, tol=1e-9 * max(1.0, np.max(np.abs(Jx)))) < m:
        return None, "dependent planar constraints"
    # Sparsity: the body blocks of the absolute pattern; constraint rows through P.
    col = topo.coloring
    mask_q = np.kron(col.mask_q[: 7 * nb, : 7 * nb].reshape(nb, 7, nb, 7).any((1, 3)), np.ones((3, 3), bool))
    body_phi = col.mask_phi[:, : 7 * nb].reshape(nc, nb, 7).any(2)  # (nc, nb)
    mask_phi = np.kron((np.abs(P) > 0).astype(int) @ body_phi.astype(int) > 0, np.ones((1, 3), bool))
    row_map = np.concatenate([7 * np.repeat(np.arange(nb), 3), topo.nq + np.argmax(np.abs(P) > 0, 1)]) if m else 7 * np.repeat(np.arange(nb), 3)
    color = greedy_coloring(np.concatenate([mask_q, mask_phi], 0))
    coloring = Coloring(color=color, mask_q=mask_q, mask_phi=mask_phi, dense=col.dense)
    return PlanarBasis(normal=n, E=E, P=P, coloring=coloring, row_map=row_map), "planar"


def _canonical_basis(U) -> list:
    """Rows spanning the columns of ``U`` (orthonormal, (k, r)) that depend on that span only.

    The SVD's singular vectors of one joint's sampled gradients are a basis of its live rows that
    turns with the geometry (a longer link gives other combinations of the same rows), and P is
    compiled into the simulation as constants: two builds that differ only in parameter values
    would then compile differently (proleg.study groups a builder's variants by their traced
    simulation). The projector U Uᵀ does not depend on the basis: Gram–Schmidt of its columns in
    index order, entries below 1e-12 set to zero, each row scaled to a largest entry of 1 and
    rounded to 12 decimals (a change of 1e-12 in the combination of rows that vanish on the
    plane changes nothing) gives the same rows for the same span. Rows stay orthogonal within
    the joint (``Planar.reduce_multipliers`` relies on it)."""
    r = U.shape[1]
    if r == 0:
        return []
    proj = U @ U.T
    basis = []
    for i in range(proj.shape[0]):
        v = proj[:, i].copy()
        for b in basis:
            v -= (b @ v) * b
        nv = np.linalg.norm(v)
        if nv > 1e-6:
            basis.append(v / nv)
        if len(basis) == r:
            break
    if len(basis) < r:  # never for an orthonormal U (the columns of U Uᵀ span its range)
        basis = list(U.T)
    out = []
    for v in basis:
        v = np.where(np.abs(v) > 1e-12, v, 0.0)
        k = int(np.argmax(np.round(np.abs(v), 9)))  # the first of (nearly) equal largest entries
        out.append(np.round(v / v[k], 12) + 0.0)
    return out


def floating_tree(system: System) -> tuple[bool, str]:
    """(True, why) when ``system`` is a loop-free tree hanging from a floating base: in joint
    coordinates (assembly/joint_coordinates.py) at least one part is free (no tree joint to
    ground), at least one part hangs from it by a revolute/prismatic/cylindrical/fixed joint, and
    no constraint row is left but each free part's quaternion normalisation (no cut joint, motion
    or coupler). A legged robot is one; a free part held only by bushings or contacts is not
    (its joint coordinates are its absolute ones). Read from the topology, plain Python; the
    tree is cached on ``system.topo.joint_tree`` (joint_set)."""
    topo = system.topo
    if topo.n_eta:
        return False, "flexible bodies"
    # The spanning tree first (plain Python): a model with a cut joint, a motion or a coupler
    # stops here, before joint_set selects its loop rows (which compiles a Jacobian).
    from .joint_coordinates import _spanning_tree, joint_set

    parent, joint, _, _ = _spanning_tree(topo)
    if not np.any(parent == -1):
        return False, "no floating base"
    nb = topo.nbody
    if not any(0 <= parent[b] < nb and parent[parent[b]] == -1 for b in range(nb)):
        # free parts, none carrying a jointed part (a block on bushings beside a pendulum): not a
        # robot on a floating base; its joint coordinates are its absolute ones
        return False, "free parts without jointed parts hanging from them"
    in_tree = {id(joint[b][1]) for b in range(topo.nbody) if parent[b] >= 0}
    cut = [j.name for j in topo.joints if id(j) not in in_tree]
    if cut:
        return False, f"closed loops or joints outside the tree ({', '.join(cut[:4])})"
    joint_ids = {id(j) for j in topo.joints}
    other = [getattr(o, "name", "?") for o in getattr(topo.ct, "owners", ()) if id(o) not in joint_ids]
    if other:
        return False, f"motions or couplers on the tree ({', '.join(other[:4])})"
    try:
        tree = joint_set(system).tree
    except ModelError as e:  # no joint-coordinate tree: the model runs in absolute coordinates
        out = (False, f"no joint-coordinate tree ({str(e).splitlines()[0][:80]})")
    else:
        if not tree.floating.size:
            out = (False, "no floating base")
        elif tree.nq <= 7 * tree.floating.size:
            out = (False, "free parts without joints")
        elif tree.ct.n_rows:
            out = (False, f"closed loops or constraints on the tree ({', '.join(tree.cut) or 'motions, couplers'})")
        else:
            out = (True, "loop-free tree on a floating base")
    return out


def auto_coordinates(system: System) -> tuple[str, str]:
    """What ``coordinates="auto"`` runs, decided from the topology alone: ("planar", why) where the
    joints confine every part to one plane; ("joint", why) for a loop-free tree on a floating
    base (:func:`floating_tree`: a legged robot); else ("absolute", why).

    The rule is measured (bench/coordinates.py, bench/results/coordinates.md; bench/whole_robot.py,
    bench/results/whole_robot.md). Models without a floating base: joint coordinates cost about
    the same per step as planar ones on loop-free chains but take more steps and compile 2–3×
    longer; with cut joints (closed loops) they cost about twice as much per step as planar or
    absolute coordinates; FLEGX's tendon-rod loops leave joint coordinates with free degrees of
    freedom (ModelError). Floating-base trees are the other way round: absolute coordinates give
    every leg link 7 coordinates and 5 joint rows (HyQ: 91 coordinates + 73 rows against 19
    coordinates + 1 row), so the Newton matrix of a whole quadruped is ~8× larger, and joint
    coordinates are several times faster per step and to compile, contacts, servos and
    actuators included."""
    basis, why = getattr(system.topo, "planar", (None, "not checked"))
    if basis is not None:
        return "planar", "every part confined to one plane by its joints"
    ok, why_tree = floating_tree(system)
    if ok:
        return "joint", f"{why_tree} (not planar: {why})"
    return "absolute", f"not planar ({why}); not a floating-base tree ({why_tree})"


def coordinate_set(system: System, q_ref, coordinates: str = "auto"):
    """The coordinates to integrate ``system`` in: "absolute", "planar" (error if the model is not
    planar), "joint" (joint coordinates of the spanning tree, loops as constraints:
    assembly/joint_coordinates.py) or "auto" (:func:`auto_coordinates`: planar where the joints
    confine every part to one plane, joint coordinates for a loop-free tree on a floating base,
    else absolute; its docstring has the measurements)."""
    if coordinates not in ("auto", "absolute", "planar", "joint"):
        raise ValueError(f"coordinates must be 'auto', 'absolute', 'planar' or 'joint', got {coordinates!r}.")
    if coordinates == "absolute":
        return Absolute(system)
    if coordinates == "joint":
        from .joint_coordinates import joint_set

        return joint_set(system)
    basis, why = getattr(system.topo, "planar", (None, "not checked"))
    if basis is None:
        if coordinates == "planar":
            raise ValueError(
                f"Model '{system.topo.name}' cannot run in planar coordinates ({why}): every part must be "
                "confined by its joints to one plane (revolute axes parallel to its normal). Use coordinates='absolute'."
            )
        if floating_tree(system)[0]:
            from .joint_coordinates import joint_set

            return joint_set(system)
        return Absolute(system)
    return Planar(system, q_ref, basis)
