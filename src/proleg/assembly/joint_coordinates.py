"""Joint (minimal) coordinates for models whose joints form a tree, closed loops as constraints.

The spanning tree is found from ground by breadth-first search over the joints that have a
joint coordinate and no other freedom: revolute (angle θ), prismatic (translation s),
cylindrical (θ, s) and fixed (none). Every other joint (spherical, universal, planar, screw,
and any joint that closes a loop) is a *cut joint*: its equations stay constraints, evaluated
by the absolute constraint functions of ``constraints.py`` on the markers placed by forward
kinematics, together with motions and couplers. A part that the tree joints do not reach is a
floating base (a free part): its 7 coordinates are the absolute ones, COM position r and Euler
parameters p (the quaternion, scalar first), its velocities ṙ and ṗ, with the normalization
row pᵀp − 1 = 0 among the constraints, exactly as in absolute coordinates. That choice
(ṗ rather than an angular velocity) keeps q and q̇ the same size, which the generalized-α
step needs (q₁ = q + h q̇ + …); ω = 2 G(p) ṗ.

Joint coordinates are the motion of marker I relative to marker J, as for motions and outputs
(model/joints.py): R_I = R_J R_z(θ), r_I = r_J + s z_J. The child part holds one of the two
markers (σ = +1 when it holds I, −1 when it holds J), and its pose follows from its parent's:

    R_out = R_in R_z(σθ),  o_out = o_in + σ s z_in,  R_child = R_out C_outᵀ,  r_child = o_out − R_child s_out

Dynamics (Featherstone 2008, ch. 6 and 7) in spatial vectors about the ground origin, angular
part first: S_k is the motion subspace of coordinate k (revolute about axis a through o:
(a, o × a); prismatic: (0, a); floating: (0, e_i) for ṙ_i and (2G_i, r × 2G_i) for ṗ_i),
V_b = Σ_{k ≤ b} S_k q̇_k, the bias acceleration c_b = Σ_{k ≤ b} Ṡ_k q̇_k − (0, g) (gravity
as an acceleration of the base), I_b the spatial inertia about the origin, and

    RNEA:  f_b = I_b c_b + V_b ×* I_b V_b − f_ext,b,    Q_k = −S_kᵀ Σ_{b ≥ k} f_b
    CRBA:  I^c_k = Σ_{b ≥ k} I_b,                       M_kl = S_kᵀ I^c_k S_l   (l ≤ k)

where "k ≤ b" means that coordinate k belongs to the path from the root to part b. Both are
written with the constant ancestor matrix (nb, nq) instead of recursions: the sums over
ancestors and over subtrees are matrix products, so there is no Python loop per body or per
level in velocities, CRBA or RNEA. Only the forward kinematics of poses (a composition of
rotations) runs one vectorised step per depth level of the tree. For the trees of legged
robots (≤ 20 parts) the O(nb·nq) products cost less than the recursions' gathers on XLA-CPU.

The equations of motion in these coordinates are M(x) ẍ + Φ_xᵀλ = Q(x, ẋ, t): the same
form as in absolute coordinates, so the generalized-α/HHT step (solvers/galpha.py) and the
ODE integrators (solvers/ode.py) run on it unchanged. Element loads are those of
``system.body_loads`` at the absolute kinematics of the tree: force elements, contacts,
drives and controllers act unchanged, and results come out in absolute coordinates.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from ..errors import ModelError
from ..spatial.rotation import A_of_p, G_of_p, mm, mv, p_of_A
from .constraints import ROW_KINDS, build_constraint_topology, constraint_values
from .kinematics import BodyKin, marker_kin
from .sparsity import Coloring
from .constraints import _joint_rows
from .system import System, body_loads, element_power
from ..compile_cache import jit

TREE_KINDS = ("revolute", "prismatic", "cylindrical", "fixed")


class TreePass(NamedTuple):
    """One pass of a tree's forward kinematics (:meth:`JointCoordinates.tree_pass`): poses r, A,
    motion subspace S, spatial velocities V, body and marker kinematics, spatial inertias."""

    r: jnp.ndarray
    A: jnp.ndarray
    S: jnp.ndarray
    V: jnp.ndarray
    bk: BodyKin
    mk: object
    I: jnp.ndarray
ROT, TRANS, FLOAT_R, FLOAT_P = 0, 1, 2, 3


@dataclass(eq=False)
class JointTree:
    """Static data of a joint-coordinate set (hashed by identity; cached on ``Topology.joint_tree``).

    Arrays are indexed by part (model order) unless named ``dof_*`` (per coordinate). Its numbers
    are data (``_numbers_are_data``): the compile cache checks once per structure that a
    trace reads none of them."""

    _numbers_are_data = True
    #: signs (±1) and the 0/1 ancestry matrix: structure, keyed exactly
    _structure_fields = ("sigma", "anc")

    parent: np.ndarray  # (nb,) parent part, nb = ground; -1 for a floating base
    levels: list  # [array of parts] per depth, roots of jointed parts first
    level_parent_pos: list  # per level: position of each part's parent in the concatenated blocks
    body_pos: np.ndarray  # (nb+1,) position of each part (ground last) in the concatenated blocks
    joint: list  # (nb,) tree joint object or None
    m_in: np.ndarray  # (nb,) marker on the parent (inboard), 0 for floating bases
    m_out: np.ndarray  # (nb,) marker on the part (outboard)
    m_i: np.ndarray  # (nb,) the joint's I and J markers
    m_j: np.ndarray
    sigma: np.ndarray  # (nb,) +1: the part holds I; -1: it holds J
    rot_col: np.ndarray  # (nb,) column of θ in x, or nq (reads 0)
    trans_col: np.ndarray  # (nb,) column of s in x, or nq
    floating: np.ndarray  # (nf,) floating-base parts
    float_col: np.ndarray  # (nf,) first of their 7 columns
    dof_body: np.ndarray  # (nq,) part of each coordinate
    dof_type: np.ndarray  # (nq,) ROT, TRANS, FLOAT_R, FLOAT_P
    dof_k: np.ndarray  # (nq,) component (0..2 for FLOAT_R, 0..3 for FLOAT_P)
    dof_pcol: np.ndarray  # (nq, 4) columns of the floating base's p for FLOAT_P coordinates (else 0)
    anc: np.ndarray  # (nb, nq) 1 where coordinate k lies on the path from the root to part b
    ct: object  # ConstraintTopology of the kept cut-joint / motion / coupler rows
    row_abs: np.ndarray  # (nc,) an absolute row of the same element (failure messages)
    coloring: Coloring
    cut: list  # names of the cut joints
    why: str = "joint"

    def __repr__(self):
        return (f"JointTree({self.nq} coordinates, {len(self.parent)} parts, {self.floating.size} floating bases, "
                f"cut joints {self.cut})")

    @property
    def nq(self) -> int:
        return int(self.dof_body.size)


def _spanning_tree(topo):
    """Breadth-first spanning tree from ground over the tree-capable joints; unreached parts
    become floating bases (the first unreached part in model order, then its subtree)."""
    nb = topo.nbody
    mb = topo.marker_body
    edges = [(k, j) for k, j in enumerate(topo.joints) if getattr(j, "kind", "") in TREE_KINDS]
    parent = np.full(nb, -2)
    joint = [None] * nb
    depth = np.zeros(nb, int)
    order = []

    def bfs(start_nodes):
        queue = list(start_nodes)
        while queue:
            u = queue.pop(0)
            for k, j in edges:
                bi, bj = int(mb[topo.joint_marker_i[k]]), int(mb[topo.joint_marker_j[k]])
                if u not in (bi, bj):
                    continue
                w = bj if u == bi else bi
                if w == nb or parent[w] != -2:
                    continue
                parent[w], joint[w] = u, (k, j)
                depth[w] = 0 if u == nb else depth[u] + 1
                order.append(w)
                queue.append(w)

    bfs([nb])
    while np.any(parent == -2):
        root = int(np.flatnonzero(parent == -2)[0])
        parent[root] = -1
        order.append(root)
        bfs([root])
    return parent, joint, depth, order


def build_joint_tree(system: System) -> JointTree:
    """The joint-coordinate description of ``system`` (plain Python, outside jit).

    Raises
    ------
    ModelError
        When the model has flexible bodies, or the cut-joint rows do not leave the absolute
        model's degrees of freedom (a singular loop at the modelled pose).
    """
    topo = system.topo
    nb = topo.nbody
    if topo.n_eta:
        raise ModelError(f"Model '{topo.name}' has flexible bodies: joint coordinates cover rigid parts only. Use coordinates='absolute'.")
    parent, joint, depth, order = _spanning_tree(topo)
    mb = topo.marker_body
    m_in, m_out, m_i, m_j = (np.zeros(nb, int) for _ in range(4))
    sigma = np.ones(nb)
    rot_col, trans_col = np.full(nb, -1), np.full(nb, -1)
    floating, float_col, dof_body, dof_type, dof_k = [], [], [], [], []
    for b in order:
        if parent[b] == -1:
            floating.append(b)
            float_col.append(len(dof_body))
            dof_body += [b] * 7
            dof_type += [FLOAT_R] * 3 + [FLOAT_P] * 4
            dof_k += [0, 1, 2, 0, 1, 2, 3]
            continue
        k, j = joint[b]
        mi, mj = int(topo.joint_marker_i[k]), int(topo.joint_marker_j[k])
        m_i[b], m_j[b] = mi, mj
        if mb[mi] == b:
            m_out[b], m_in[b], sigma[b] = mi, mj, 1.0
        else:
            m_out[b], m_in[b], sigma[b] = mj, mi, -1.0
        if j.dof_rotation:
            rot_col[b] = len(dof_body)
            dof_body.append(b), dof_type.append(ROT), dof_k.append(0)
        if j.dof_translation:
            trans_col[b] = len(dof_body)
            dof_body.append(b), dof_type.append(TRANS), dof_k.append(0)
    nq = len(dof_body)
    rot_col[rot_col < 0] = nq
    trans_col[trans_col < 0] = nq
    dof_body = np.array(dof_body, int)
    anc = np.zeros((nb, nq))
    for b in range(nb):
        u = b
        while u >= 0 and u != nb:
            anc[b, dof_body == u] = 1.0
            u = parent[u]
    jointed = [b for b in order if parent[b] != -1]
    levels = [np.array([b for b in jointed if depth[b] == d], int) for d in range(int(depth.max(initial=0)) + 1)]
    levels = [lv for lv in levels if lv.size]
    # Blocks: [floating bases, ground], then one per level (see JointCoordinates._poses).
    body_pos = np.zeros(nb + 1, int)
    body_pos[floating] = np.arange(len(floating))
    body_pos[nb] = len(floating)
    off = len(floating) + 1
    for lv in levels:
        body_pos[lv] = off + np.arange(lv.size)
        off += lv.size
    level_parent_pos = [body_pos[parent[lv]] for lv in levels]
    dof_pcol = np.zeros((nq, 4), int)
    for b, c0 in zip(floating, float_col):
        dof_pcol[c0 : c0 + 7] = c0 + 3 + np.arange(4)

    # Constraint rows: every joint, motion and coupler row that is not a tree joint's.
    model = topo.model
    marker_index = {id(m): k for k, m in enumerate(model.markers)}
    owners = list(model.joints) + list(getattr(model, "_constraint_owners_extra", lambda: [])())
    tree_ids = {id(joint[b][1]) for b in jointed}
    rows, _, _ = _joint_rows(model, marker_index, owners)
    rows = [r for r in rows if id(owners[r["owner"]]) not in tree_ids]
    nm = len(topo.marker_names)
    ct_all = build_constraint_topology(rows, nm, 0, owners)
    tree = JointTree(
        parent=np.where(parent == -1, -1, parent), levels=levels, level_parent_pos=level_parent_pos, body_pos=body_pos, joint=[None if jt is None else jt[1] for jt in joint],
        m_in=m_in, m_out=m_out, m_i=m_i, m_j=m_j, sigma=sigma, rot_col=rot_col, trans_col=trans_col,
        floating=np.array(floating, int), float_col=np.array(float_col, int), dof_body=dof_body,
        dof_type=np.array(dof_type, int), dof_k=np.array(dof_k, int), dof_pcol=dof_pcol, anc=anc, ct=ct_all, row_abs=np.zeros(0, int),
        coloring=None, cut=sorted({owners[r["owner"]].name for r in rows}),
    )
    # Keep independent rows: those whose gradient is not zero at sampled configurations
    # (e.g. the out-of-plane rows of a planar loop are constant), then a rank-revealing QR at
    # the assembled pose (as assemble() does for absolute coordinates).
    ordered = [r for kind in ROW_KINDS for r in rows if r["kind"] == kind]
    if ordered:
        import scipy.linalg

        jc = JointCoordinates(_concrete(system), tree)
        x0, _ = jit(jc.reduce)(system.params["q_init"], system.params["v_init"])
        jac = jit(jax.jacfwd(lambda x: jc._loop_rows(x, 0.0)))
        rng = np.random.default_rng(0)
        J0 = np.asarray(jac(x0))
        G = [J0] + [np.asarray(jac(x0 + rng.uniform(-1.0, 1.0, x0.shape) * (tree.dof_type <= TRANS))) for _ in range(6)]
        scale = max(1.0, max(float(np.max(np.abs(g))) for g in G))
        live = np.flatnonzero(np.max(np.abs(np.concatenate(G, 1)), 1) > 1e-9 * scale)
        keep = np.zeros(0, int)
        if live.size:
            _, R, piv = scipy.linalg.qr(J0[live].T, pivoting=True, mode="economic")
            d = np.abs(np.diag(R))
            rank = int(np.sum(d > 1e-9 * max(d[0], 1e-300))) if d.size else 0
            keep = np.sort(live[piv[:rank]])
        kept = [ordered[i] for i in keep]
        tree.ct = build_constraint_topology(kept, nm, 0, owners)
    nc = tree.ct.n_rows + tree.floating.size
    dof_abs = topo.nq - topo.nc
    if nq - nc != dof_abs:
        raise ModelError(
            f"Model '{topo.name}': joint coordinates leave {nq - nc} degrees of freedom where the absolute model has "
            f"{dof_abs} (cut joints: {', '.join(tree.cut) or 'none'}); the loop closure is singular at the modelled pose. "
            "Use coordinates='absolute'."
        )
    owner_row = {}
    for r, o in enumerate(topo.ct.row_owner):
        if o >= 0:
            owner_row.setdefault(topo.ct.owners[o].name, r)
    loop_abs = [owner_row.get(name, 0) for name, _ in tree.ct.labels]
    norm_abs = [topo.nc - nb + int(b) for b in tree.floating]
    tree.row_abs = topo.nq + np.array(loop_abs + norm_abs, int)
    tree.coloring = Coloring(color=np.arange(nq), mask_q=np.ones((nq, nq), bool), mask_phi=np.ones((nc, nq), bool), dense=True)
    return tree


def _concrete(system: System) -> System:
    """``system`` for the row selection when it is built inside jit/vmap (first use there):
    traced parameters other than the geometry do not change which rows are independent."""
    traced = [k for k, v in system.params.items() if isinstance(v, jax.core.Tracer)]
    if not traced:
        return system
    geometry = [k for k in traced if k in ("marker_s", "marker_C", "q_init", "v_init") or k.startswith("variable_")]
    if geometry:
        raise ModelError(
            f"Model '{system.topo.name}': the joint-coordinate tree is first built inside a transformation with traced "
            f"geometry ({', '.join(geometry)}). Build it once outside: proleg.assembly.joint_coordinates.joint_set(system)."
        )
    return System({k: jnp.zeros(v.shape, v.dtype) if k in traced else v for k, v in system.params.items()}, system.topo)


@jax.tree_util.register_pytree_node_class
class JointCoordinates:
    """Coordinates x = (joint angles/translations, floating-base r and p) of a tree."""

    kind = "joint"

    def __init__(self, system: System, tree: JointTree):
        self.system, self.tree = system, tree

    def tree_flatten(self):
        return (self.system,), self.tree

    @classmethod
    def tree_unflatten(cls, tree, children):
        return cls(*children, tree)

    @property
    def nq(self) -> int:
        return self.tree.nq

    @property
    def nc(self) -> int:
        return self.tree.ct.n_rows + self.tree.floating.size

    @property
    def coloring(self) -> Coloring:
        return self.tree.coloring

    def weights(self, x, rtol, atol, atol_p):
        """atol + rtol·|x| for translations, atol_p + rtol·|p| for Euler parameters; angles as in
        planar coordinates, 2·atol_p + rtol (δp ≈ δθ/2)."""
        T = self.tree
        ty = jnp.asarray(T.dof_type)
        a = jnp.where(ty == ROT, 2.0 * atol_p + rtol, jnp.where(ty == FLOAT_P, atol_p, atol) + rtol * jnp.abs(x))
        return a

    # -- kinematics -------------------------------------------------------------------------
    def _poses(self, x):
        """Part poses by forward kinematics: r (nb+1, 3), A (nb+1, 3, 3) (ground last), and per
        part the signed joint axis z (nb, 3) and the outboard marker origin o (nb, 3).

        Each jointed part's pose relative to its parent is one local 3×6 block computed for all
        parts at once before the levels, [C_in R_z(σθ) C_outᵀ | d | σ z_in | o_in] (rotation,
        COM offset d = o_in − Rel s_out, axis and joint origin in the parent's frame, o_in =
        s_in + σ s z_in); each depth level is then a gather of its parents' [A | r] and one
        batched product with those blocks. Fewer, larger kernels than composing the markers'
        rotations level by level (bench/step_kernels.py). Gathers, not scatters: XLA-CPU
        scatters run element by element (select.py)."""
        T, P = self.tree, self.system.params
        nb = T.parent.size
        dt = x.dtype
        nf = T.floating.size
        c = T.float_col[:, None]
        r0 = jnp.concatenate([x[c + np.arange(3)].reshape(nf, 3), jnp.zeros((1, 3), dt)], 0)
        A0 = jnp.concatenate([A_of_p(x[c + 3 + np.arange(4)].reshape(nf, 4)), jnp.eye(3, dtype=dt)[None]], 0)
        blk = [jnp.concatenate([A0, r0[:, :, None]], 2)]  # [A | r] per part, (n, 3, 4)
        z_blk, o_blk = [jnp.zeros((nf + 1, 3), dt)], [jnp.zeros((nf + 1, 3), dt)]
        if T.levels:  # (a model of free parts may have no markers at all)
            jp = np.concatenate(T.levels)  # the jointed parts, level by level
            xe = jnp.concatenate([x, jnp.zeros(1, dt)])
            th, sl = T.sigma[jp] * xe[T.rot_col[jp]], xe[T.trans_col[jp]]
            C, S = P["marker_C"], P["marker_s"]
            C_in, C_out, s_in, s_out = C[T.m_in[jp]], C[T.m_out[jp]], S[T.m_in[jp]], S[T.m_out[jp]]
            ct, st = jnp.cos(th)[:, None], jnp.sin(th)[:, None]
            xa, ya, za = C_in[:, :, 0], C_in[:, :, 1], C_in[:, :, 2]
            # C_in R_z(σθ): columns (c x + s y, −s x + c y, z) of C_in, then times C_outᵀ
            Rel = mm(jnp.stack([ct * xa + st * ya, ct * ya - st * xa, za], -1), jnp.swapaxes(C_out, -1, -2))
            a_loc = T.sigma[jp, None] * za
            o_loc = s_in + a_loc * sl[:, None]
            L = jnp.concatenate([Rel, (o_loc - mv(Rel, s_out))[:, :, None], a_loc[:, :, None], o_loc[:, :, None]], 2)
            start, first = 0, 0  # first position of the last block; first row of the level in L
            for idx, ppos in zip(T.levels, T.level_parent_pos):
                if np.all(ppos >= start):  # parents all in the last block (always, by BFS depth): no concatenation
                    Pp = blk[-1][ppos - start]
                else:
                    Pp = jnp.concatenate(blk, 0)[ppos]
                start += blk[-1].shape[0]
                W = mm(Pp[:, :, :3], L[first : first + idx.size])  # (k, 3, 6)
                first += idx.size
                rr = Pp[:, :, 3]
                blk.append(jnp.concatenate([W[:, :, :3], (rr + W[:, :, 3])[:, :, None]], 2))
                z_blk.append(W[:, :, 4])
                o_blk.append(rr + W[:, :, 5])
        pos = T.body_pos
        PA = jnp.concatenate(blk, 0)[pos]
        return PA[:, :, 3], PA[:, :, :3], jnp.concatenate(z_blk, 0)[pos[:nb]], jnp.concatenate(o_blk, 0)[pos[:nb]]

    def _subspace(self, x, r, axis, o_out):
        """Motion subspace S (nq, 6) about the ground origin, angular part first."""
        T = self.tree
        b, ty = T.dof_body, T.dof_type
        a, o = axis[b], o_out[b]
        eye = jnp.eye(3, dtype=x.dtype)[np.minimum(T.dof_k, 2)]
        Gk = 2.0 * jnp.take_along_axis(G_of_p(x[T.dof_pcol]), np.minimum(T.dof_k, 3)[:, None, None], -1)[..., 0]
        w = jnp.where((ty == ROT)[:, None], a, jnp.where((ty == FLOAT_P)[:, None], Gk, 0.0))
        v = jnp.where(
            (ty == ROT)[:, None], jnp.cross(o, a),
            jnp.where((ty == TRANS)[:, None], a, jnp.where((ty == FLOAT_R)[:, None], eye, jnp.cross(r[b], Gk))),
        )
        return jnp.concatenate([w, v], 1)

    def _state(self, x, xd=None):
        """(r, A, S, V): poses, motion subspace, spatial velocities of the parts (nb, 6)."""
        r, A, axis, o_out = self._poses(x)
        S = self._subspace(x, r, axis, o_out)
        V = None if xd is None else jnp.asarray(self.tree.anc) @ (S * xd[:, None])
        return r, A, S, V

    def _body_kin(self, r, A, V=None):
        """BodyKin of the tree (its p is not needed by the element loads: zeros)."""
        nb = self.tree.parent.size
        p0 = jnp.zeros((nb + 1, 4), r.dtype)
        if V is None:
            z = jnp.zeros_like(r)
            return BodyKin(r, p0, A, z, z)
        w = jnp.concatenate([V[:, :3], jnp.zeros((1, 3), V.dtype)], 0)
        rd = jnp.concatenate([V[:, 3:] + jnp.cross(V[:, :3], r[:nb]), jnp.zeros((1, 3), V.dtype)], 0)
        return BodyKin(r, p0, A, rd, w)

    def _markers(self, bk):
        P = self.system.params
        return marker_kin(self.system.topo.marker_oh, P["marker_s"], P["marker_C"], bk)

    def kinematics(self, x, xd):
        """(body, marker) kinematics at (x, ẋ) straight from the tree (what element laws and
        controller samples read; the parts' Euler parameters are not formed: zeros)."""
        tp = self.tree_pass(x, xd)
        return tp.bk, tp.mk

    def tree_pass(self, x, xd) -> "TreePass":
        """Everything one pass of forward kinematics gives at (x, ẋ), for callers that need
        several quantities of one state (a controller sample, the powers and the restart's
        dynamics after it: solvers/driver.py) without tracing the kinematics once for each."""
        r, A, S, V = self._state(x, xd)
        bk = self._body_kin(r, A, V)
        return TreePass(r, A, S, V, bk, self._markers(bk), self._spatial_inertia(r, A))

    def absolute(self, x, xd):
        """Absolute (q, v) of a joint-coordinate state (the Euler parameters' rates ½ Gᵀ ω, and
        the floating bases' own ṗ)."""
        T = self.tree
        nb = T.parent.size
        r, A, _, V = self._state(x, xd)
        bk = self._body_kin(r, A, V)
        p = p_of_A(A[:nb])
        if T.floating.size:  # the floating bases' own p and ṗ
            isf = np.isin(np.arange(nb), T.floating)[:, None]
            pcol = np.zeros((nb, 4), int)
            pcol[T.floating] = T.float_col[:, None] + 3 + np.arange(4)
            p = jnp.where(isf, x[pcol], p)
        pd = 0.5 * jnp.einsum("bij,bi->bj", G_of_p(p), bk.w[:nb])
        if T.floating.size:
            pd = jnp.where(isf, xd[pcol], pd)
        q = jnp.concatenate([r[:nb], p], 1).reshape(-1)
        v = jnp.concatenate([bk.rd[:nb], pd], 1).reshape(-1)
        return q, v

    # -- dynamics ---------------------------------------------------------------------------
    def _spatial_inertia(self, r, A):
        """Spatial inertias about the ground origin (nb, 6, 6): [[I_c + m c̃c̃ᵀ, m c̃], [m c̃ᵀ, m 1]]."""
        P = self.system.params
        nb = self.tree.parent.size
        A = A[:nb]
        # (batched 3×3 products as broadcast-and-sum: fused loops, where an einsum with a batch
        # axis is a dot kernel each on XLA-CPU; spatial/rotation.py)
        Ic = mm(mm(A, P["body_inertia"]), jnp.swapaxes(A, -1, -2))
        m = P["body_mass"][:, None, None]
        from ..spatial.rotation import skew

        cx = skew(r[:nb])
        top = jnp.concatenate([Ic - m * mm(cx, cx), m * cx], 2)
        bot = jnp.concatenate([-m * cx, m * jnp.eye(3, dtype=r.dtype)], 2)
        return jnp.concatenate([top, bot], 1)

    def mass_matrix(self, x):
        """M(x) (nq, nq) by the composite-rigid-body algorithm (module docstring)."""
        r, A, S, _ = self._state(x)
        return self._crba(S, self._spatial_inertia(r, A))

    def _crba(self, S, I):
        T = self.tree
        Ic = jnp.einsum("bk,bij->kij", jnp.asarray(T.anc), I)  # composite inertia of each coordinate's part
        F = mv(Ic, S)
        Gm = F @ S.T  # G[k, l] = S_kᵀ I^c_k S_l
        low = T.anc[T.dof_body] > 0  # l on the path to k's part (l ≤ k)
        return jnp.where(low, Gm, 0.0) + jnp.where(low.T & ~low, Gm.T, 0.0)

    def mass_action(self, x, a):
        return self.mass_matrix(x) @ a

    def _bias(self, x, xd, S, V):
        """Ṡ q̇ per coordinate (nq, 6): V_parent × S_k q̇_k for joints; for a floating base the
        whole (0, ṙ × ω) on its first coordinate (Ġ ṗ = 0)."""
        T = self.tree
        nb = T.parent.size
        Ve = jnp.concatenate([V, jnp.zeros((1, 6), V.dtype)], 0)
        par = np.where(T.parent[T.dof_body] < 0, nb, T.parent[T.dof_body])
        Vp = Ve[par]
        w, v = Vp[:, :3], Vp[:, 3:]
        c = jnp.concatenate([jnp.cross(w, S[:, :3]), jnp.cross(w, S[:, 3:]) + jnp.cross(v, S[:, :3])], 1) * xd[:, None]
        jointed = (T.dof_type == ROT) | (T.dof_type == TRANS)
        c = jnp.where(jointed[:, None], c, 0.0)
        if T.floating.size:
            fc = T.float_col
            rd = xd[fc[:, None] + np.arange(3)]
            om = V[T.floating, :3]
            c = c.at[fc].set(jnp.concatenate([jnp.zeros_like(rd), jnp.cross(rd, om)], 1))
        return c

    def generalized_forces(self, x, xd, t, z=None):
        """Q(x, ẋ, t) = −RNEA(x, ẋ, ẍ = 0): applied loads, gravity and the velocity terms."""
        r, A, S, V = self._state(x, xd)
        bk = self._body_kin(r, A, V)
        return self._rnea(x, xd, t, z, r, A, S, V, bk, self._markers(bk), self._spatial_inertia(r, A))

    def inverse_dynamics(self, x, xd, xdd, t, z=None):
        """M(x) ẍ − Q(x, ẋ, t) = RNEA(x, ẋ, ẍ) in one pass: the α-method's residual needs this
        combination only, and one pass of forward kinematics and element loads instead of a
        CRBA and an RNEA each with their own kinematics is about 40 % fewer kernels a Newton
        iteration on a quadruped (bench/results/whole_robot_kernels.md)."""
        r, A, S, V = self._state(x, xd)
        bk = self._body_kin(r, A, V)
        return -self._rnea(x, xd, t, z, r, A, S, V, bk, self._markers(bk), self._spatial_inertia(r, A), xdd)

    def dynamics(self, x, xd, t, z=None, tp=None):
        """(M, Q, powers) from one pass of forward kinematics: what the ODE's right-hand side
        needs (solvers/ode.py), without repeating the kinematics per quantity. ``tp``: that
        pass (:meth:`tree_pass`) if the caller has it."""
        tp = self.tree_pass(x, xd) if tp is None else tp
        Q = self._rnea(x, xd, t, z, tp.r, tp.A, tp.S, tp.V, tp.bk, tp.mk, tp.I)
        return self._crba(tp.S, tp.I), Q, element_power(self.system, tp.bk, tp.mk, t, z)

    def _rnea(self, x, xd, t, z, r, A, S, V, bk, mk, I, xdd=None):
        """Q − M ẍ (ẍ = 0 when not given): −Sᵀ of the subtree sums of the parts' net forces."""
        T, P = self.tree, self.system.params
        nb = T.parent.size
        anc = jnp.asarray(T.anc)
        Fb, Nb, _, _ = body_loads(self.system, bk, mk, t, z)
        Nw = mv(bk.A[:nb], Nb)
        fext = jnp.concatenate([Nw + jnp.cross(r[:nb], Fb), Fb], 1)
        c = self._bias(x, xd, S, V)
        if xdd is not None:  # S ẍ per coordinate (Ṡ ẋ is in the bias; Ġ ṗ = 0 for the floating p)
            c = c + S * xdd[:, None]
        acc = anc @ c - jnp.concatenate([jnp.zeros(3, x.dtype), P["gravity"]])
        h = mv(I, V)
        vxf = jnp.concatenate([jnp.cross(V[:, :3], h[:, :3]) + jnp.cross(V[:, 3:], h[:, 3:]), jnp.cross(V[:, :3], h[:, 3:])], 1)
        f = mv(I, acc) + vxf - fext
        return -jnp.sum(S * (anc.T @ f), 1)

    def _loop_rows(self, x, t):
        T, P = self.tree, self.system.params
        if T.ct.n_rows == 0:
            return jnp.zeros(0, x.dtype)
        r, A, _, _ = self._poses(x)
        mk = self._markers(self._body_kin(r, A))
        cpl = (P["coupler_ratio"], P["coupler_offset"]) if "coupler_ratio" in P else None
        return constraint_values(T.ct, P.get("screw_lead", jnp.zeros(0)), mk.r, mk.R, jnp.zeros((0, 4), x.dtype), t, cpl, P)

    def constraints(self, x, t):
        """Cut-joint, motion and coupler rows, then pᵀp − 1 of each floating base."""
        T = self.tree
        out = [self._loop_rows(x, t)]
        if T.floating.size:
            pf = x[T.float_col[:, None] + 3 + np.arange(4)]
            out.append(jnp.sum(pf * pf, 1) - 1.0)
        return jnp.concatenate(out)

    def power_terms(self, x, xd, t, z=None):
        r, A, _, V = self._state(x, xd)
        bk = self._body_kin(r, A, V)
        return element_power(self.system, bk, self._markers(bk), t, z)

    # -- from absolute coordinates ----------------------------------------------------------
    def _joint_values(self, q):
        """x of an absolute configuration: each tree joint's angle and translation (I relative to
        J, model/joints.py), the floating bases' own r and p."""
        from .constraints import joint_angle, joint_translation
        from .system import kinematics

        T = self.tree
        nb = T.parent.size
        x = jnp.zeros(self.nq, q.dtype)
        if T.levels:
            _, mk = kinematics(self.system, q)
            th = joint_angle(mk.R[T.m_i], mk.R[T.m_j])
            s = joint_translation(mk.r[T.m_i], mk.r[T.m_j], mk.R[T.m_j])
            x = jnp.zeros(self.nq + 1, q.dtype).at[T.rot_col].set(th).at[T.trans_col].set(s)[: self.nq]
        if T.floating.size:
            qb = q[: 7 * nb].reshape(nb, 7)
            x = x.at[T.float_col[:, None] + np.arange(7)].set(qb[T.floating])
        return x

    def _twists(self, x, xd):
        """(ω, ṙ) of every part, (nb, 6): linear in ẋ."""
        r, A, _, V = self._state(x, xd)
        bk = self._body_kin(r, A, V)
        nb = self.tree.parent.size
        return jnp.concatenate([bk.w[:nb], bk.rd[:nb]], 1).reshape(-1)

    def _abs_twists(self, q, v):
        nb = self.tree.parent.size
        qb, vb = q[: 7 * nb].reshape(nb, 7), v[: 7 * nb].reshape(nb, 7)
        w = 2.0 * mv(G_of_p(qb[:, 3:]), vb[:, 3:])
        return jnp.concatenate([w, vb[:, :3]], 1)

    def reduce(self, q, v):
        """(x, ẋ) of an absolute state; ẋ by least squares on the parts' (ω, ṙ), exact for states
        of the mechanism (and independent of the sign of each part's p)."""
        x = self._joint_values(q)
        J = jax.jacfwd(lambda u: self._twists(x, u))(jnp.zeros_like(x))
        xd = jnp.linalg.lstsq(J, self._abs_twists(q, v).reshape(-1))[0]
        return x, xd

    def reduce_acceleration(self, x, xd, qdd, q):
        """ẍ of absolute accelerations q̈ at the absolute configuration q: (ω̇, r̈) = J ẍ + J̇ ẋ,
        by least squares (ω̇ = 2 G(p) p̈ with the p that q̈ belongs to)."""
        nb = self.tree.parent.size
        pb = q[: 7 * nb].reshape(nb, 7)[:, 3:]
        ab = qdd[: 7 * nb].reshape(nb, 7)
        target = jnp.concatenate([2.0 * mv(G_of_p(pb), ab[:, 3:]), ab[:, :3]], 1).reshape(-1)
        J = jax.jacfwd(lambda u: self._twists(x, u))(jnp.zeros_like(x))
        Jd = jax.jvp(lambda y: self._twists(y, xd), (x,), (xd,))[1]
        return jnp.linalg.lstsq(J, target - Jd)[0]

    def reduce_multipliers(self, lam):
        """A start for the multipliers of the joint-coordinate rows: zero (the first step's Newton
        iteration solves for them; the HHT history term is −M ẍ, from the accelerations)."""
        return jnp.zeros(self.nc, lam.dtype)

    def absolute_row(self, i: int) -> int:
        i = int(i)
        if i < self.nq:
            return 7 * int(self.tree.dof_body[i])
        return int(self.tree.row_abs[i - self.nq])


def joint_set(system: System):
    """The joint-coordinate set of ``system`` (its tree cached on the topology)."""
    topo = system.topo
    tree = getattr(topo, "joint_tree", None)
    if tree is None:
        tree = build_joint_tree(system)
        topo.joint_tree = tree
    return JointCoordinates(system, tree)
