"""Isotropic linear elasticity on tetrahedral meshes (scikit-fem assembly, gmsh meshing).

Weak form: find u with  int sigma(u) : eps(v) dV = int t . v dA  for all v, where
eps = (grad u + grad u^T) / 2 and sigma = lambda tr(eps) I + 2 mu eps (Lamé parameters of the
:class:`proleg.fem.Material`). Consistent mass: M = int rho u . v dV.

Elements: linear (``order=1``, ElementTetP1) or quadratic (``order=2``, ElementTetP2)
tetrahedra, vectorised with ElementVector; the geometry is always the straight-sided linear
tetrahedron. Choosing the order: quadratic tets are the default because linear tets lock in
bending (a thin strip needs many linear elements through the thickness to bend correctly);
one quadratic element through the thickness of a slender strip gives its bending
frequencies within ~1-2 %.

"Nodes" of a :class:`SolidModel` are the DOF locations (vertices, plus edge midpoints for
``order=2``); each carries ux, uy, uz.

scikit-fem and gmsh are imported inside the functions that need them.
"""

from __future__ import annotations

from contextlib import contextmanager

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from ..errors import ModelError
from .craig_bampton import solve_modes, solve_static
from .materials import material as _material


def mesh_box(size, h: float, origin=(0.0, 0.0, 0.0)) -> tuple[np.ndarray, np.ndarray]:
    """Tetrahedral mesh of an axis-aligned box with gmsh (headless).

    Parameters
    ----------
    size : (3,) [m]     box edge lengths along x, y, z, all > 0 (e.g. (0.3, 0.05, 0.003))
    h : float [m]       target element size (gmsh Mesh.MeshSizeMax), > 0
    origin : (3,) [m]   corner with the smallest coordinates

    Returns
    -------
    points : (n, 3) [m], tets : (ne, 4) int (positively oriented, linear)
    """
    size = np.asarray(size, float)
    if size.shape != (3,) or not np.all(np.isfinite(size)) or np.any(size <= 0):
        raise ModelError(f"mesh_box size must be three positive lengths [m]; got {np.asarray(size).tolist()}.")
    if not (np.isfinite(h) and h > 0):
        raise ModelError(f"mesh_box element size h must be positive [m]; got {h!r}.")
    with gmsh_model("proleg_box") as gmsh:
        gmsh.model.occ.addBox(*[float(v) for v in origin], *size)
        gmsh.model.occ.synchronize()
        gmsh.option.setNumber("Mesh.MeshSizeMax", float(h))
        gmsh.option.setNumber("Mesh.MeshSizeMin", 0.0)
        gmsh.model.mesh.generate(3)
        tags, coords, _ = gmsh.model.mesh.getNodes()
        _, _, conn = gmsh.model.mesh.getElements(3)
        if not conn:
            raise ModelError(f"gmsh produced no tetrahedra for box {size.tolist()} with h = {h}; reduce h.")
        tets_tags = np.asarray(conn[0], dtype=np.int64).reshape(-1, 4)
    return compact_tets(tags, coords, tets_tags)


@contextmanager
def gmsh_model(name: str):
    """A gmsh model ``name`` for the duration of the block (yields the ``gmsh`` module, terminal
    output off). gmsh is initialised here only if the caller has no session running, and then
    finalised at the end; otherwise the model is removed and the caller's session left running."""
    import gmsh

    owner = not gmsh.isInitialized()
    if owner:
        gmsh.initialize(interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add(name)
        yield gmsh
    finally:
        if owner:
            gmsh.finalize()
        else:
            gmsh.model.remove()


def compact_nodes(tags, coords, cells_tags):
    """gmsh node tags, coordinates and cells of any kind (as node tags) → (points (n, 3), cells):
    only the nodes the cells use, renumbered from 0."""
    pts = np.asarray(coords, float).reshape(-1, 3)
    lookup = np.zeros(int(np.max(tags)) + 1, dtype=np.int64)
    lookup[tags] = np.arange(np.size(tags))
    cells = lookup[cells_tags]
    used = np.unique(cells)
    renum = np.zeros(pts.shape[0], dtype=np.int64)
    renum[used] = np.arange(used.size)
    return pts[used], renum[cells]


def orient_tets(points, tets):
    """``tets`` (m, 4) with every negatively oriented tetrahedron's vertices 1 and 2 swapped (in place)."""
    vol = _signed_volumes(points, tets)
    tets[vol < 0] = tets[vol < 0][:, [0, 2, 1, 3]]
    return tets


def compact_tets(tags, coords, tets_tags):
    """gmsh node tags, coordinates and tetrahedra (as node tags) → (points (n, 3), tets (m, 4)):
    only the nodes the tetrahedra use, renumbered from 0, every tet positively oriented."""
    pts, tets = compact_nodes(tags, coords, tets_tags)
    return pts, orient_tets(pts, tets)


def hooke_stress(G, material):
    """Stress (3, 3, ...) [Pa] of the displacement gradient ``G`` (3, 3, ...) for an isotropic
    ``material`` (its Lamé constants)."""
    eps = 0.5 * (G + np.swapaxes(G, 0, 1))
    lam, mu = material.lame
    tr = eps[0, 0] + eps[1, 1] + eps[2, 2]
    return 2 * mu * eps + lam * tr * np.eye(3).reshape((3, 3) + (1,) * (G.ndim - 2))


def von_mises(S):
    """von Mises stress sqrt(3/2 s:s) (s the deviator) of stresses ``S`` (3, 3, ...)."""
    dev = S - (S[0, 0] + S[1, 1] + S[2, 2]) / 3 * np.eye(3).reshape((3, 3) + (1,) * (S.ndim - 2))
    return np.sqrt(1.5 * np.einsum("ij...,ij...->...", dev, dev))


def _signed_volumes(points, tets) -> np.ndarray:
    p = points[tets]
    return np.einsum("ij,ij->i", np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), p[:, 3] - p[:, 0]) / 6.0


@dataclass
class StressResult:
    """Stress and strain at query points (small strain, SI).

    points : (k, 3) [m]; strain : (k, 3, 3) [-]; stress : (k, 3, 3) [Pa]; von_mises : (k,) [Pa];
    displacement : (k, 3) [m]
    """

    points: np.ndarray
    displacement: np.ndarray
    strain: np.ndarray
    stress: np.ndarray
    von_mises: np.ndarray


class SolidModel:
    """Linear-elastic tetrahedral FE model (scikit-fem).

    Parameters
    ----------
    points : (n, 3) [m]       vertex coordinates
    tets : (ne, 4) int        vertex indices, positively oriented (det of the map > 0)
    material : Material or str
    order : 1 or 2            linear or quadratic tetrahedra

    Attributes
    ----------
    K, M : scipy.sparse.csr_matrix (ndof, ndof) [N/m], [kg]
    node_coordinates : (n_nodes, 3) [m]   DOF locations (vertices and, for order 2, edge midpoints)
    node_dof_table : (n_nodes, 6) int     ux, uy, uz DOF indices; -1 for rotations
    """

    def __init__(self, points, tets, material, order: int = 2):
        from skfem import Basis, BilinearForm, ElementTetP1, ElementTetP2, ElementVector, MeshTet, asm
        from skfem.helpers import dot
        from skfem.models.elasticity import linear_elasticity

        self.material = _material(material)
        pts = np.asarray(points, float)
        tt = np.asarray(tets)
        if pts.ndim != 2 or pts.shape[1] != 3 or not np.all(np.isfinite(pts)):
            raise ModelError(f"SolidModel points must be a finite (n, 3) array [m]; got shape {pts.shape}.")
        if tt.ndim != 2 or tt.shape[1] != 4 or tt.size == 0 or tt.min() < 0 or tt.max() >= pts.shape[0]:
            raise ModelError(f"SolidModel tets must be (ne, 4) vertex indices in [0, {pts.shape[0]}).")
        if order not in (1, 2):
            raise ModelError(f"SolidModel order must be 1 (linear tets) or 2 (quadratic tets); got {order!r}.")
        vol = _signed_volumes(pts, tt)
        bad = np.flatnonzero(vol <= 0)
        if bad.size:
            raise ModelError(
                f"SolidModel mesh has {bad.size} inverted or degenerate tetrahedra (negative Jacobian), e.g. elements "
                f"{bad[:5].tolist()}. Swap two vertices of each inverted element (tets[i] = tets[i][[0, 2, 1, 3]]) "
                "or remesh.")
        self.points, self.tets, self.order = pts, tt.astype(np.int64), order
        self.mesh = MeshTet(pts.T.copy(), self.tets.T.copy())
        elem = ElementVector(ElementTetP2() if order == 2 else ElementTetP1())
        self.basis = Basis(self.mesh, elem, intorder=2 * order)
        lam, mu = self.material.lame
        rho = self.material.rho

        @BilinearForm
        def mass(u, v, w):
            return rho * dot(u, v)

        self.K = asm(linear_elasticity(lam, mu), self.basis).tocsr()
        self.M = asm(mass, self.basis).tocsr()
        self.ndof = self.K.shape[0]
        # DOF locations: nodal_dofs (3, nverts) and edge_dofs (3, nedges) in skfem's numbering
        locs = self.basis.doflocs.T  # (ndof, 3)
        ids = [self.basis.nodal_dofs]
        if order == 2:
            ids.append(self.basis.edge_dofs)
        dof_xyz = np.hstack(ids)  # (3, n_nodes): dofs of ux, uy, uz per node
        self.node_coordinates = locs[dof_xyz[0]]
        tab = np.full((dof_xyz.shape[1], 6), -1, dtype=int)
        tab[:, :3] = dof_xyz.T
        self.node_dof_table = tab

    @classmethod
    def box(cls, size, h: float, material, order: int = 2, origin=(0.0, 0.0, 0.0)) -> SolidModel:
        """Mesh a box with :func:`mesh_box` and assemble it."""
        return cls(*mesh_box(size, h, origin), material, order)

    @property
    def mass(self) -> float:
        """Total mass [kg] (rigid x-translation through the consistent mass)."""
        e = np.zeros(self.ndof)
        e[self.node_dof_table[:, 0]] = 1.0
        return float(e @ (self.M @ e))

    # -- selections --------------------------------------------------------------------------
    def nodes_where(self, predicate) -> np.ndarray:
        """Node indices whose coordinates satisfy ``predicate(x, y, z) -> bool array``."""
        x = self.node_coordinates
        return np.flatnonzero(np.asarray(predicate(x[:, 0], x[:, 1], x[:, 2]), bool))

    def node_dofs(self, nodes) -> np.ndarray:
        """The (ux, uy, uz) DOF indices of ``nodes`` (flat, node-major)."""
        return self.node_dof_table[np.atleast_1d(np.asarray(nodes, int)), :3].ravel()

    def node_at(self, point, tol: float = 1e-9) -> int:
        """Index of the node at ``point`` [m] within ``tol`` [m]; ModelError if there is none."""
        p = np.asarray(point, float)
        d = np.linalg.norm(self.node_coordinates - p, axis=1)
        i = int(np.argmin(d))
        if d[i] > tol:
            raise ModelError(
                f"Interface node at {p.tolist()} m is not on the mesh (nearest node {i} at "
                f"{self.node_coordinates[i].tolist()} is {d[i]:.3g} m away). Choose a point on a mesh node, "
                "e.g. a box corner, or mesh with a size that puts a node there.")
        return i

    # -- loads -------------------------------------------------------------------------------
    def surface_load(self, predicate, total_force) -> np.ndarray:
        """Load vector [N] of a uniform traction on the boundary facets whose midpoints satisfy
        ``predicate(x, y, z)``, scaled so that its resultant is ``total_force`` (3,) [N]."""
        from skfem import FacetBasis, LinearForm, asm

        facets = self.mesh.facets_satisfying(lambda x: predicate(x[0], x[1], x[2]), boundaries_only=True)
        if facets.size == 0:
            raise ModelError("surface_load: no boundary facet satisfies the predicate; check the coordinates [m].")
        fb = FacetBasis(self.mesh, self.basis.elem, facets=facets, intorder=2 * self.order)
        F = np.asarray(total_force, float)

        @LinearForm
        def unit_area(v, w):
            return v[0] + 0.0 * w.x[0]

        area = float(asm(unit_area, fb)[self.node_dof_table[:, 0]].sum())

        @LinearForm
        def traction(v, w):
            return (F[0] * v[0] + F[1] * v[1] + F[2] * v[2]) / area

        return asm(traction, fb)

    # -- solves ------------------------------------------------------------------------------
    def static(self, f, fixed_dofs) -> np.ndarray:
        """Displacement vector (ndof,) [m] under load vector ``f`` [N] with ``fixed_dofs`` held."""
        return solve_static(self.K, f, fixed_dofs)

    def modes(self, n_modes: int, fixed_dofs=None) -> tuple[np.ndarray, np.ndarray]:
        """Lowest natural frequencies (n_modes,) [rad/s] and mass-normalised shapes (ndof, n_modes)."""
        return solve_modes(self.K, self.M, n_modes, fixed_dofs)

    def displacement_at(self, u, points) -> np.ndarray:
        """Interpolated displacement (k, 3) [m] at ``points`` (k, 3) [m]."""
        P = self._inside(points)
        return (self.basis.probes(P.T) @ u).reshape(3, -1).T

    def stress_at(self, u, points) -> StressResult:
        """Strain, stress and von Mises stress sqrt(3/2 s:s) (s the deviator) at ``points`` (k, 3) [m]."""
        P = self._inside(points)
        mapping = self.basis.mapping
        cells = self.mesh.element_finder(mapping=mapping)(*P.T)
        X = mapping.invF(P.T[:, :, None], tind=cells)
        G = np.zeros((P.shape[0], 3, 3))
        for k in range(self.basis.Nbfun):
            g = self.basis.elem.gbasis(mapping, X, k, tind=cells)[0].grad[..., 0]  # (3, 3, k)
            G += u[self.basis.element_dofs[k, cells]][:, None, None] * np.moveaxis(g, -1, 0)
        eps = 0.5 * (G + np.swapaxes(G, 1, 2))
        lam, mu = self.material.lame
        tr = np.trace(eps, axis1=1, axis2=2)
        sig = lam * tr[:, None, None] * np.eye(3) + 2 * mu * eps
        dev = sig - np.trace(sig, axis1=1, axis2=2)[:, None, None] * np.eye(3) / 3.0
        vm = np.sqrt(1.5 * np.einsum("kij,kij->k", dev, dev))
        return StressResult(P, self.displacement_at(u, P), eps, sig, vm)

    def vertex_stress(self, u) -> tuple[np.ndarray, np.ndarray]:
        """Nodal-averaged stress recovery: the stress (nverts, 3, 3) [Pa] and von Mises (nverts,) [Pa]
        at the mesh vertices ``self.points``.

        Each element's stress is evaluated at its own four vertices (exact for P2, whose strain is
        linear in the element; constant for P1) and averaged over the elements that share the
        vertex (Nastran's averaged corner stress). Unlike the largest value at a quadrature point,
        which sits inside the element at a mesh-dependent depth below a surface peak, the
        averaged vertex value at a fillet converges with the mesh to the surface stress.
        """
        sig = hooke_stress(self._corner_basis.interpolate(u).grad, self.material)  # (3, 3, ne, 4): at vertex k of each element
        total = np.zeros((self.points.shape[0], 3, 3))
        np.add.at(total, self.tets.ravel(), np.moveaxis(sig, (0, 1), (2, 3)).reshape(-1, 3, 3))
        count = np.bincount(self.tets.ravel(), minlength=self.points.shape[0])
        sig = total / np.maximum(count, 1)[:, None, None]
        return sig, von_mises(np.moveaxis(sig, (1, 2), (0, 1)))

    @cached_property
    def _corner_basis(self):
        """The element basis evaluated at each element's four vertices (built once per model)."""
        from skfem import Basis

        X = np.array([[0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]])  # reference vertices
        return Basis(self.mesh, self.basis.elem, quadrature=(X, np.full(4, 1.0 / 24)))

    def _inside(self, points) -> np.ndarray:
        P = np.atleast_2d(np.asarray(points, float))
        if P.shape[1] != 3:
            raise ModelError(f"Query points must be (k, 3) [m]; got shape {P.shape}.")
        lo, hi = self.points.min(0), self.points.max(0)
        tol = 1e-9 * float(np.max(hi - lo))
        out = np.flatnonzero(np.any((P < lo - tol) | (P > hi + tol), axis=1))
        if out.size:
            raise ModelError(f"Query point {P[out[0]].tolist()} m lies outside the mesh bounding box "
                             f"{lo.tolist()} .. {hi.tolist()}.")
        return P
