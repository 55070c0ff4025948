"""Euler-Bernoulli and Timoshenko beam finite elements, 2D and 3D, with consistent mass.

Element
-------
Bending uses the *interdependent interpolation* element (Reddy 1997; Friedman & Kosmatka 1993):
with xi = x / L and Phi = 12 E I / (kappa G A L^2) (Phi = 0 gives the Euler-Bernoulli cubic
Hermite element), the deflection and section rotation are

    w = sum N_w,i d_i,   theta = sum N_theta,i d_i,   d = [w1, theta1, w2, theta2],

which solves the Timoshenko equations exactly for end loads, so one element per span already
gives the exact static stiffness. Stiffness and consistent mass are

    K = int (E I N_theta'^T N_theta' + kappa G A (N_w' - N_theta)^T (N_w' - N_theta)) dx,
    M = int (rho A N_w^T N_w + rho I N_theta^T N_theta) dx,

integrated with 4-point Gauss quadrature (exact: integrands are polynomials of degree <= 6).
The rotary-inertia term rho I is kept for Timoshenko and dropped for Euler-Bernoulli (the
classical consistent mass). Axial (E A) and torsion (G J, mass rho I_p) use linear bars.

DOFs and frames
---------------
2D (nodes (n, 2), plane x-y): 3 DOFs per node (ux, uy, rz) [m, m, rad]; bending uses ``Iz``.
3D (nodes (n, 3)): 6 DOFs per node (ux, uy, uz, rx, ry, rz). Element axes: x' from node 1 to
node 2, y' along ``orientation`` projected normal to x' (default: z_ground x x', or y_ground for
vertical elements), z' = x' x y'. Bending in x'-y' uses ``Iz``, in x'-z' uses ``Iy``. For
:meth:`Section.rectangle` y' is along the width and z' along the thickness, so a horizontal
strip along ground x bends about its thin direction in the x-z plane.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ..errors import ModelError
from .craig_bampton import solve_modes, solve_static
from .materials import Material
from .materials import material as _material

THEORIES = ("euler-bernoulli", "timoshenko")
_COMPONENTS = {2: ("ux", "uy", "rz"), 3: ("ux", "uy", "uz", "rx", "ry", "rz")}
_GAUSS_X, _GAUSS_W = np.polynomial.legendre.leggauss(4)
_GAUSS_X, _GAUSS_W = 0.5 * (_GAUSS_X + 1.0), 0.5 * _GAUSS_W  # on [0, 1]

#: Euler-Bernoulli cantilever eigenvalues beta_n L (cos(bL) cosh(bL) = -1).
CANTILEVER_BETA_L = (1.8751040687, 4.6940911330, 7.8547574382, 10.9955407349, 14.1371683910)


def _positive(what: str, value) -> float:
    v = float(value)
    if not (math.isfinite(v) and v > 0):
        raise ModelError(f"{what} must be a positive finite number; got {value!r}.")
    return v


@dataclass(frozen=True)
class Section:
    """Beam cross-section constants.

    Parameters
    ----------
    A : float [m^2]             area
    Iy : float [m^4]            second moment about the section y' axis (bending in x'-z')
    Iz : float [m^4]            second moment about the section z' axis (bending in x'-y')
    J : float [m^4]             torsion constant (Saint-Venant)
    shear_factor : float [-]    Timoshenko shear coefficient kappa (A_shear = kappa A)
    name : str
    """

    A: float
    Iy: float
    Iz: float
    J: float
    shear_factor: float = 5.0 / 6.0
    name: str = "section"

    def __post_init__(self):
        for f in ("A", "Iy", "Iz", "J", "shear_factor"):
            _positive(f"Section '{self.name}' {f}", getattr(self, f))

    @property
    def Ip(self) -> float:
        """Polar second moment Iy + Iz [m^4] (torsional rotary inertia per unit rho L)."""
        return self.Iy + self.Iz

    @classmethod
    def rectangle(cls, width: float, thickness: float) -> Section:
        """Solid rectangle, ``width`` [m] along y', ``thickness`` [m] along z'.

        Iy = w t^3 / 12, Iz = t w^3 / 12, kappa = 5/6, and the torsion constant of Roark
        (Table 10.1): J = a b^3 [1/3 - 0.21 (b/a)(1 - b^4 / (12 a^4))], a >= b the two sides.
        """
        w = _positive("Section.rectangle width [m]", width)
        t = _positive("Section.rectangle thickness [m]", thickness)
        a, b = max(w, t), min(w, t)
        J = a * b**3 * (1.0 / 3.0 - 0.21 * (b / a) * (1.0 - b**4 / (12.0 * a**4)))
        return cls(w * t, w * t**3 / 12.0, t * w**3 / 12.0, J, 5.0 / 6.0, f"rectangle {w:g} x {t:g} m")

    @classmethod
    def tube(cls, outer_diameter: float, inner_diameter: float = 0.0, nu: float = 0.3) -> Section:
        """Circular tube (``inner_diameter`` 0 gives a solid rod) [m].

        I = pi (D^4 - d^4) / 64, J = 2 I, and Cowper's (1966) shear coefficient
        kappa = 6 (1 + nu)(1 + m^2)^2 / ((7 + 6 nu)(1 + m^2)^2 + (20 + 12 nu) m^2), m = d / D.
        """
        D = _positive("Section.tube outer_diameter [m]", outer_diameter)
        d = float(inner_diameter)
        if not (0.0 <= d < D):
            raise ModelError(f"Section.tube inner_diameter = {inner_diameter!r} must satisfy 0 <= d < D = {D:g} m.")
        m2 = (d / D) ** 2
        kappa = 6 * (1 + nu) * (1 + m2) ** 2 / ((7 + 6 * nu) * (1 + m2) ** 2 + (20 + 12 * nu) * m2)
        I = math.pi * (D**4 - d**4) / 64.0
        return cls(math.pi * (D**2 - d**2) / 4.0, I, I, 2 * I, kappa, f"tube {D:g}/{d:g} m")


def _bending(L, EI, kGA, rhoA, rhoI, timoshenko: bool):
    """(4, 4) stiffness and mass for [w1, theta1, w2, theta2], theta = dw/dx when Phi = 0."""
    phi = 12.0 * EI / (kGA * L**2) if timoshenko else 0.0
    mu = 1.0 / (1.0 + phi)
    x = _GAUSS_X
    one, zero = np.ones_like(x), np.zeros_like(x)
    Nw = mu * np.array([
        2 * x**3 - 3 * x**2 - phi * x + 1 + phi,
        L * (x**3 - (2 + phi / 2) * x**2 + (1 + phi / 2) * x),
        -(2 * x**3 - 3 * x**2 - phi * x),
        L * (x**3 - (1 - phi / 2) * x**2 - (phi / 2) * x),
    ])
    dNw = mu / L * np.array([
        6 * x**2 - 6 * x - phi * one,
        L * (3 * x**2 - (4 + phi) * x + (1 + phi / 2) * one),
        -(6 * x**2 - 6 * x - phi * one),
        L * (3 * x**2 - (2 - phi) * x - (phi / 2) * one),
    ])
    Nt = mu * np.array([
        6.0 / L * (x**2 - x), 3 * x**2 - (4 + phi) * x + 1 + phi, -6.0 / L * (x**2 - x), 3 * x**2 - (2 - phi) * x,
    ])
    dNt = mu / L * np.array(
        [6.0 / L * (2 * x - 1), 6 * x - (4 + phi), -6.0 / L * (2 * x - 1), 6 * x - (2 - phi) + zero]
    )
    w = _GAUSS_W * L
    gam = dNw - Nt
    K = EI * (dNt * w) @ dNt.T + (kGA * (gam * w) @ gam.T if timoshenko else 0.0)
    M = rhoA * (Nw * w) @ Nw.T + (rhoI * (Nt * w) @ Nt.T if rhoI else 0.0)
    return K, M


def _bar(L, stiff, mass_per_length):
    k = stiff / L * np.array([[1.0, -1.0], [-1.0, 1.0]])
    return k, mass_per_length * L / 6.0 * np.array([[2.0, 1.0], [1.0, 2.0]])


def element_frame(p1, p2, orientation=None) -> np.ndarray:
    """(3, 3) rotation whose rows are the element axes x', y', z' in ground coordinates."""
    e1 = np.asarray(p2, float) - np.asarray(p1, float)
    e1 = e1 / np.linalg.norm(e1)
    if orientation is None:
        ref = np.cross([0.0, 0.0, 1.0], e1) if abs(e1[2]) < 0.99 else np.array([0.0, 1.0, 0.0])
    else:
        ref = np.asarray(orientation, float)
    e2 = ref - e1 * (ref @ e1)
    n = np.linalg.norm(e2)
    if n < 1e-9:
        raise ModelError(f"Beam orientation {ref.tolist()} is parallel to an element axis {e1.tolist()}; "
                         "give an orientation vector (local y') not along the beam.")
    e2 = e2 / n
    return np.array([e1, e2, np.cross(e1, e2)])


def element_matrices(p1, p2, section: Section, mat: Material, theory: str = "euler-bernoulli", orientation=None):
    """Global-axes element stiffness and consistent mass, (6, 6) in 2D or (12, 12) in 3D [SI]."""
    p1, p2 = np.asarray(p1, float), np.asarray(p2, float)
    L = float(np.linalg.norm(p2 - p1))
    timo = theory == "timoshenko"
    E, G, rho = mat.E, mat.G, mat.rho
    s = section
    ka, ma = _bar(L, E * s.A, rho * s.A)
    if p1.size == 2:
        kb, mb = _bending(L, E * s.Iz, s.shear_factor * G * s.A, rho * s.A, rho * s.Iz if timo else 0.0, timo)
        K, M = np.zeros((6, 6)), np.zeros((6, 6))
        ia, ib = [0, 3], [1, 2, 4, 5]
        K[np.ix_(ia, ia)], M[np.ix_(ia, ia)] = ka, ma
        K[np.ix_(ib, ib)], M[np.ix_(ib, ib)] = kb, mb
        c, sn = (p2 - p1) / L
        lam = np.array([[c, sn, 0.0], [-sn, c, 0.0], [0.0, 0.0, 1.0]])
        T = np.kron(np.eye(2), lam)
    else:
        kz, mz = _bending(L, E * s.Iz, s.shear_factor * G * s.A, rho * s.A, rho * s.Iz if timo else 0.0, timo)
        ky, my = _bending(L, E * s.Iy, s.shear_factor * G * s.A, rho * s.A, rho * s.Iy if timo else 0.0, timo)
        S = np.diag([1.0, -1.0, 1.0, -1.0])  # theta_y = -dw/dz'
        ky, my = S @ ky @ S, S @ my @ S
        kt, mt = _bar(L, G * s.J, rho * s.Ip)
        K, M = np.zeros((12, 12)), np.zeros((12, 12))
        blocks = {(0, 6): (ka, ma), (3, 9): (kt, mt), (1, 5, 7, 11): (kz, mz), (2, 4, 8, 10): (ky, my)}
        for idx, (k, m) in blocks.items():
            K[np.ix_(idx, idx)], M[np.ix_(idx, idx)] = k, m
        T = np.kron(np.eye(4), element_frame(p1, p2, orientation))
    return T.T @ K @ T, T.T @ M @ T


class BeamModel:
    """An assembled beam FE model (numpy/scipy).

    Parameters
    ----------
    nodes : (n, 2) or (n, 3) [m]     node coordinates; 2 columns give a planar (x-y) model
    elements : (ne, 2) int           node pairs
    section : Section                cross-section, one for all elements
    material : Material or str       see :func:`proleg.fem.material`
    theory : "euler-bernoulli" or "timoshenko"
    orientation : (3,), optional     local y' direction for 3D elements (see module docstring)

    Attributes
    ----------
    K, M : scipy.sparse.csr_matrix (ndof, ndof)    stiffness [N/m, N, N m/rad], consistent mass [kg, kg m^2]
    dofs_per_node : int                            3 (2D) or 6 (3D)
    """

    def __init__(self, nodes, elements, section: Section, material, *, theory: str = "euler-bernoulli",
                 orientation=None):
        self.material = _material(material)
        nodes = np.asarray(nodes, dtype=float)
        if nodes.ndim != 2 or nodes.shape[1] not in (2, 3) or nodes.shape[0] < 2 or not np.all(np.isfinite(nodes)):
            raise ModelError(f"BeamModel nodes must be a finite (n >= 2, 2 or 3) array [m]; got shape {nodes.shape}.")
        el = np.asarray(elements, dtype=int)
        if el.ndim != 2 or el.shape[1] != 2 or el.size == 0 or el.min() < 0 or el.max() >= nodes.shape[0]:
            raise ModelError(f"BeamModel elements must be (ne, 2) node indices in [0, {nodes.shape[0]}).")
        lengths = np.linalg.norm(nodes[el[:, 1]] - nodes[el[:, 0]], axis=1)
        if np.any(lengths <= 0):
            raise ModelError(f"BeamModel elements {np.flatnonzero(lengths <= 0).tolist()} have zero length; "
                             "remove duplicate nodes.")
        if theory not in THEORIES:
            raise ModelError(f"BeamModel theory '{theory}' is unknown; use one of {THEORIES}.")
        if not isinstance(section, Section):
            raise ModelError("BeamModel section must be a proleg.fem.Section (Section.rectangle, Section.tube, ...).")
        self.nodes, self.elements, self.section, self.theory = nodes, el, section, theory
        self.dim = nodes.shape[1]
        self.dofs_per_node = 3 if self.dim == 2 else 6
        self.components = _COMPONENTS[self.dim]
        self.ndof = self.dofs_per_node * nodes.shape[0]
        self.K, self.M = self._assemble(orientation)

    @classmethod
    def polyline(cls, points, n_elements, section: Section, material, *, theory: str = "euler-bernoulli",
                 orientation=None) -> BeamModel:
        """Mesh a straight beam or polyline through ``points`` (k >= 2, 2 or 3 columns) [m] with
        ``n_elements`` (int, or one int per segment) equal elements per segment."""
        P = np.asarray(points, dtype=float)
        if P.ndim != 2 or P.shape[0] < 2:
            raise ModelError(f"BeamModel.polyline needs at least two points (k, 2|3) [m]; got shape {P.shape}.")
        ns = np.broadcast_to(np.asarray(n_elements, int), (P.shape[0] - 1,))
        if np.any(ns < 1):
            raise ModelError(f"BeamModel.polyline n_elements must be >= 1 per segment; got {n_elements!r}.")
        pts = [P[:1]]
        for a, b, n in zip(P[:-1], P[1:], ns, strict=True):
            s = np.linspace(0.0, 1.0, n + 1)[1:, None]
            pts.append(a + s * (b - a))
        nodes = np.vstack(pts)
        el = np.column_stack([np.arange(nodes.shape[0] - 1), np.arange(1, nodes.shape[0])])
        return cls(nodes, el, section, material, theory=theory, orientation=orientation)

    def _assemble(self, orientation):
        nd = self.dofs_per_node
        rows, cols, kv, mv = [], [], [], []
        for a, b in self.elements:
            k, m = element_matrices(self.nodes[a], self.nodes[b], self.section, self.material, self.theory, orientation)
            idx = np.r_[a * nd: (a + 1) * nd, b * nd: (b + 1) * nd]
            rows.append(np.repeat(idx, idx.size))
            cols.append(np.tile(idx, idx.size))
            kv.append(k.ravel())
            mv.append(m.ravel())
        r, c = np.concatenate(rows), np.concatenate(cols)
        shape = (self.ndof, self.ndof)
        K = sp.coo_matrix((np.concatenate(kv), (r, c)), shape=shape).tocsr()
        M = sp.coo_matrix((np.concatenate(mv), (r, c)), shape=shape).tocsr()
        return K, M

    # -- DOFs --------------------------------------------------------------------------------
    def dof(self, node: int, component: str) -> int:
        """Global DOF index of ``component`` ('ux', 'uy', 'uz', 'rx', 'ry', 'rz') at ``node``."""
        if component not in self.components:
            raise ModelError(f"Beam DOF component '{component}' does not exist in {self.dim}D; use {self.components}.")
        if not 0 <= int(node) < self.nodes.shape[0]:
            raise ModelError(f"Beam node {node} does not exist; nodes are 0..{self.nodes.shape[0] - 1}.")
        return int(node) * self.dofs_per_node + self.components.index(component)

    def node_dofs(self, nodes) -> np.ndarray:
        """All DOF indices of ``nodes`` (flat, node-major)."""
        nodes = np.atleast_1d(np.asarray(nodes, int))
        return (nodes[:, None] * self.dofs_per_node + np.arange(self.dofs_per_node)).ravel()

    def node_at(self, point, tol: float = 1e-9) -> int:
        """Index of the node at ``point`` [m] (within ``tol`` [m]); ModelError if none is there."""
        p = np.asarray(point, float)
        d = np.linalg.norm(self.nodes - p[: self.dim], axis=1)
        i = int(np.argmin(d))
        if d[i] > tol:
            raise ModelError(f"No beam node at {p.tolist()} m (nearest is node {i} at {self.nodes[i].tolist()}, "
                             f"{d[i]:.3g} m away). Put a mesh point there (BeamModel.polyline points).")
        return i

    @property
    def node_coordinates(self) -> np.ndarray:
        """(n, 3) node positions [m] (z = 0 for 2D models)."""
        return np.column_stack([self.nodes, np.zeros(self.nodes.shape[0])]) if self.dim == 2 else self.nodes.copy()

    @property
    def node_dof_table(self) -> np.ndarray:
        """(n, 6) DOF indices for (ux, uy, uz, rx, ry, rz), -1 where absent (see craig_bampton)."""
        n = self.nodes.shape[0]
        tab = np.full((n, 6), -1, dtype=int)
        base = np.arange(n) * self.dofs_per_node
        for j, c in enumerate(self.components):
            tab[:, ("ux", "uy", "uz", "rx", "ry", "rz").index(c)] = base + j
        return tab

    @property
    def mass(self) -> float:
        """Total mass rho A sum(L_e) [kg]."""
        L = np.linalg.norm(self.nodes[self.elements[:, 1]] - self.nodes[self.elements[:, 0]], axis=1)
        return float(self.material.rho * self.section.A * L.sum())

    # -- solves ------------------------------------------------------------------------------
    def load_vector(self, loads: dict) -> np.ndarray:
        """Load vector from ``{(node, component): value}`` [N or N m]."""
        f = np.zeros(self.ndof)
        for (node, comp), val in loads.items():
            f[self.dof(node, comp)] += float(val)
        return f

    def static(self, loads, clamp=()) -> np.ndarray:
        """Static displacements (n, dofs_per_node) [m, rad] under ``loads`` (dict as in
        :meth:`load_vector`, or a (ndof,) vector) with every DOF of the ``clamp`` nodes held."""
        f = self.load_vector(loads) if isinstance(loads, dict) else np.asarray(loads, float)
        return solve_static(self.K, f, self.node_dofs(clamp) if len(clamp) else None).reshape(-1, self.dofs_per_node)

    def modes(self, n_modes: int, clamp=()) -> tuple[np.ndarray, np.ndarray]:
        """Lowest natural frequencies omega (n_modes,) [rad/s] and mass-normalised shapes (ndof, n_modes)
        with every DOF of the ``clamp`` nodes held (see :func:`proleg.fem.solve_modes`)."""
        return solve_modes(self.K, self.M, n_modes, self.node_dofs(clamp) if len(clamp) else None)


def cantilever_omega(n: int, length: float, E: float, I: float, mass_per_length: float) -> float:
    """Euler-Bernoulli cantilever natural frequency omega_n = (beta_n L)^2 / L^2 sqrt(E I / lambda) [rad/s]."""
    return CANTILEVER_BETA_L[n - 1] ** 2 / length**2 * math.sqrt(E * I / mass_per_length)
