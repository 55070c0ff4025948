"""Tetrahedral meshes of OpenCASCADE solids with gmsh (headless), and boundary-load helpers.

:func:`mesh_occ` runs a caller's geometry builder on gmsh's OpenCASCADE kernel and returns the
linear tetrahedra (vertices and connectivity) that :class:`proleg.fem.SolidModel` takes.
:func:`torque_load` and :func:`axial_rotation` apply and measure a torque about an axis, the
load case of a shaft, a tube in torsion or a torque sensor.

gmsh and scikit-fem are imported inside the functions.
"""

from __future__ import annotations

import numpy as np

from ..errors import ModelError
from .solid import compact_nodes, compact_tets, gmsh_model, orient_tets


def mesh_occ(build, h: float, *, name: str = "proleg_occ", h_min: float | None = None,
             refine=None, curvature_points: int = 12, fillet_radius: float = 0.0,
             fillet_size: float = 0.35) -> tuple[np.ndarray, np.ndarray]:
    """Mesh the solid(s) made by ``build(occ)`` with linear tetrahedra.

    Parameters
    ----------
    build : callable(occ) -> None
        Adds OpenCASCADE entities with ``gmsh.model.occ`` (passed in); it may fuse, cut and
        fillet. :func:`mesh_occ` synchronises afterwards and meshes every volume.
    h : float [m]             target element size (Mesh.MeshSizeMax), > 0
    h_min : float [m]         smallest element size gmsh may use (default h / 4)
    curvature_points : int    elements per 2 pi of a curved edge or face (gmsh
                              Mesh.MeshSizeFromCurvature; 0: sizes from h, h_min and refine only)
    refine : list of ((3,) point [m], radius [m], size [m]), optional
        Balls around ``point`` meshed with element size ``size`` (gmsh Ball fields), e.g. a finer
        mesh at a strain-gauge location.
    fillet_radius : float [m]  local refinement of fillets: every curved surface whose radius of
                              curvature is <= ``fillet_radius`` (0: none) gets elements of
                              ``fillet_size`` x its radius within half a radius of it, growing to h
                              over h (gmsh Distance + Threshold fields), at any h: a global h / 4
                              does not resolve a fillet much smaller than h. Choosing values:
                              fillet_size 0.35 (three P2 elements along a quarter arc) puts the peak
                              von Mises at a fillet within 1 % of 0.25 (8.6 % at 0.5; measured on
                              the torque sensor, :mod:`proleg.robots.torque_sensor`).

    Returns
    -------
    points : (n, 3) [m], tets : (ne, 4) int (positively oriented)
    """
    if not (np.isfinite(h) and h > 0):
        raise ModelError(f"mesh_occ element size h must be positive [m]; got {h!r}.")
    with gmsh_model(name) as gmsh:
        build(gmsh.model.occ)
        gmsh.model.occ.synchronize()
        if not gmsh.model.getEntities(3):
            raise ModelError(f"mesh_occ '{name}': the geometry builder made no volume.")
        _size_fields(gmsh, h, h_min, curvature_points, refine, fillet_radius, fillet_size)
        gmsh.model.mesh.generate(3)
        tags, coords, _ = gmsh.model.mesh.getNodes()
        types, _, conn = gmsh.model.mesh.getElements(3)
        tets_tags = [np.asarray(c, np.int64).reshape(-1, 4) for t, c in zip(types, conn, strict=True) if t == 4]
        if not tets_tags:
            raise ModelError(f"gmsh produced no tetrahedra for '{name}' with h = {h}; reduce h.")
        tets_tags = np.vstack(tets_tags)
    return compact_tets(tags, coords, tets_tags)


def mesh_extruded(build, h: float, thickness: float, *, name: str = "proleg_extruded", h_min: float | None = None,
                  refine=None, fillet_radius: float = 0.0, fillet_size: float = 0.35, layers: int | None = None
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Swept tetrahedral mesh of a prismatic solid: the face z = 0 of the solid(s) made by
    ``build(occ)`` meshed with triangles (sizes as in :func:`mesh_occ`: ``h``, ``h_min``,
    ``refine`` balls, ``fillet_radius`` / ``fillet_size``), extruded through ``thickness`` [m] in
    ``layers`` layers of prisms (default max(1, round(thickness / (2 h))): quadratic elements
    follow the near-uniform through-thickness field of an in-plane load with one layer; measured on
    the torque sensor, 1 against 2 layers changes the gauge strain by 0.8 %, the stiffness by
    0.2 %), each split into three tetrahedra.

    For a part milled from a plate (every feature through the thickness: the torque-sensor discs)
    the stress varies across the plate far more than through it, so the in-plane size resolves the
    fillets (a fraction of a millimetre) while the layers stay ~h thick: a few times fewer
    elements than an isotropic mesh with the same fillet resolution (measured on the torque
    sensor: ~10x). Prisms are split by the global vertex order (the diagonal of each side face
    from its lowest-numbered bottom vertex to the highest-numbered top one), so neighbouring
    prisms share their side-face diagonals and the mesh is conforming.

    Returns
    -------
    points : (n, 3) [m], tets : (ne, 4) int (positively oriented)
    """
    if not (np.isfinite(h) and h > 0):
        raise ModelError(f"mesh_extruded element size h must be positive [m]; got {h!r}.")
    if not (np.isfinite(thickness) and thickness > 0):
        raise ModelError(f"mesh_extruded thickness must be positive [m]; got {thickness!r}.")
    nz = max(1, round(thickness / (2 * h))) if layers is None else int(layers)
    if nz < 1:
        raise ModelError(f"mesh_extruded layers must be >= 1; got {layers!r}.")
    with gmsh_model(name) as gmsh:
        build(gmsh.model.occ)
        gmsh.model.occ.synchronize()
        tol = 1e-3 * thickness  # OCC pads bounding boxes by ~1e-7 m
        bottom = [s for _, s in gmsh.model.getEntities(2)
                  if gmsh.model.getType(2, s) == "Plane" and abs(gmsh.model.getBoundingBox(2, s)[5]) < tol]
        if not bottom:
            raise ModelError(f"mesh_extruded '{name}': the solid has no planar face at z = 0 to sweep.")
        balls = [((p[0], p[1], 0.0), r, size) for p, r, size in refine or ()]  # onto the swept face
        _size_fields(gmsh, h, h_min, 0, balls, fillet_radius, fillet_size, at_z0=True)
        # only the swept face is meshed: drop the volumes and the other faces (their curves at z = 0 stay)
        gmsh.model.removeEntities(gmsh.model.getEntities(3))
        gmsh.model.removeEntities([(2, s) for _, s in gmsh.model.getEntities(2) if s not in bottom])
        gmsh.model.mesh.generate(2)
        tri = []
        for s in bottom:
            types, _, conn = gmsh.model.mesh.getElements(2, s)
            tri += [np.asarray(c, np.int64).reshape(-1, 3) for t, c in zip(types, conn, strict=True) if t == 2]
        tags, coords, _ = gmsh.model.mesh.getNodes()
    pts, tri = compact_nodes(np.asarray(tags, np.int64), coords, np.vstack(tri))
    xy, tri = pts[:, :2], np.sort(tri, axis=1)  # sorted: a < b < c in every triangle
    n2 = xy.shape[0]
    z = np.linspace(0.0, thickness, nz + 1)
    points = np.column_stack([np.tile(xy, (nz + 1, 1)), np.repeat(z, n2)])
    a, b, c = tri.T
    tets = []
    for k in range(nz):
        lo, hi = k * n2, (k + 1) * n2
        tets += [np.column_stack(v) for v in ((a + lo, b + lo, c + lo, c + hi), (a + lo, b + lo, b + hi, c + hi),
                                              (a + lo, a + hi, b + hi, c + hi))]
    return points, orient_tets(points, np.vstack(tets))


def _size_fields(gmsh, h, h_min, curvature_points, refine, fillet_radius, fillet_size, at_z0=False):
    """Element sizes for :func:`mesh_occ` and :func:`mesh_extruded` (see their parameters)."""
    gmsh.option.setNumber("Mesh.MeshSizeMax", float(h))
    h_min = float(h_min if h_min is not None else h / 4)
    gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", int(curvature_points))
    fields, h_fillet = _fillet_fields(gmsh, h, fillet_radius, fillet_size, at_z0) if fillet_radius > 0 else ([], h)
    gmsh.option.setNumber("Mesh.MeshSizeMin", min(h_min, h_fillet))
    for point, radius, size in refine or ():
        f = gmsh.model.mesh.field.add("Ball")
        gmsh.model.mesh.field.setNumber(f, "Radius", float(radius))
        gmsh.model.mesh.field.setNumber(f, "VIn", float(size))
        gmsh.model.mesh.field.setNumber(f, "VOut", float(h))
        gmsh.model.mesh.field.setNumber(f, "Thickness", float(radius))
        for c, v in zip("XYZ", point, strict=True):
            gmsh.model.mesh.field.setNumber(f, f"{c}Center", float(v))
        fields.append(f)
    if fields:
        fmin = gmsh.model.mesh.field.add("Min")
        gmsh.model.mesh.field.setNumbers(fmin, "FieldsList", fields)
        gmsh.model.mesh.field.setAsBackgroundMesh(fmin)


def _fillet_fields(gmsh, h, r_max, size, at_z0=False):
    """Threshold fields (one per distinct radius) around the surfaces of radius of curvature <= r_max,
    and the smallest element size they ask for [m]. ``at_z0``: distance to their edges at z = 0."""
    groups = {}
    for _, s in gmsh.model.getEntities(2):
        if gmsh.model.getType(2, s) == "Plane":
            continue
        lo, hi = gmsh.model.getParametrizationBounds(2, s)
        k1, k2 = gmsh.model.getPrincipalCurvatures(s, [0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1])])[:2]
        k = float(np.max(np.abs(np.concatenate([k1, k2, [0.0]]))))
        if k > 0 and 1.0 / k <= r_max * (1 + 1e-6):
            groups.setdefault(round(1.0 / k, 7), []).append(s)
    fields = []
    for r, surfaces in groups.items():
        d = gmsh.model.mesh.field.add("Distance")
        if at_z0:
            curves = {abs(c) for _, c in gmsh.model.getBoundary([(2, s) for s in surfaces], combined=False,
                                                                oriented=False)}
            curves = [c for c in curves if abs(gmsh.model.getBoundingBox(1, c)[5]) < 1e-6]
            gmsh.model.mesh.field.setNumbers(d, "CurvesList", curves)
        else:
            gmsh.model.mesh.field.setNumbers(d, "SurfacesList", surfaces)
        gmsh.model.mesh.field.setNumber(d, "Sampling", 30 if not at_z0 else 10)
        t = gmsh.model.mesh.field.add("Threshold")
        gmsh.model.mesh.field.setNumber(t, "InField", d)
        gmsh.model.mesh.field.setNumber(t, "SizeMin", float(size * r))
        gmsh.model.mesh.field.setNumber(t, "SizeMax", float(h))
        gmsh.model.mesh.field.setNumber(t, "DistMin", float(0.5 * r))
        gmsh.model.mesh.field.setNumber(t, "DistMax", float(0.5 * r + h))
        fields.append(t)
    return fields, min([size * r for r in groups], default=h)


def _axis(axis_point, axis):
    a = np.asarray(axis, float)
    n = np.linalg.norm(a)
    if a.shape != (3,) or not n > 0:
        raise ModelError(f"Torque axis must be a non-zero 3-vector; got {axis!r}.")
    return np.asarray(axis_point, float), a / n


def torque_load(model, predicate, torque: float, axis_point=(0.0, 0.0, 0.0), axis=(0.0, 0.0, 1.0)) -> np.ndarray:
    """Load vector [N] of a torque ``torque`` [N m] about an axis, spread over boundary facets.

    The traction on the facets whose midpoints satisfy ``predicate(x, y, z)`` (or the facet
    indices ``predicate``) is tangential,
    t = tau0 (a x r) with r the position relative to the axis (the Saint-Venant shear flow of a
    circular section, tau proportional to the distance from the axis), and tau0 chosen so that
    the resultant moment about the axis is exactly ``torque`` on the discrete surface (the
    moment of the assembled load vector is computed and scaled). A positive torque turns
    counter-clockwise seen from the tip of ``axis`` (right-hand rule).
    """
    from skfem import FacetBasis, LinearForm, asm

    c, a = _axis(axis_point, axis)
    if callable(predicate):
        facets = model.mesh.facets_satisfying(lambda x: predicate(x[0], x[1], x[2]), boundaries_only=True)
    else:  # facet indices
        facets = np.asarray(predicate, dtype=np.int64)
    if facets.size == 0:
        raise ModelError("torque_load: no boundary facet satisfies the predicate; check the face coordinates [m].")
    fb = FacetBasis(model.mesh, model.basis.elem, facets=facets, intorder=2 * model.order + 1)

    @LinearForm
    def shear(v, w):
        r = [w.x[i] - c[i] for i in range(3)]
        t = [a[1] * r[2] - a[2] * r[1], a[2] * r[0] - a[0] * r[2], a[0] * r[1] - a[1] * r[0]]
        return t[0] * v[0] + t[1] * v[1] + t[2] * v[2]

    f = asm(shear, fb)
    moment = float(rotation_field(model, axis_point, axis) @ f)
    if not moment > 0:
        raise ModelError("torque_load: the selected facets carry no moment about the axis (they lie on it).")
    return f * (float(torque) / moment)


def rotation_field(model, axis_point=(0.0, 0.0, 0.0), axis=(0.0, 0.0, 1.0)) -> np.ndarray:
    """DOF vector (ndof,) of a unit rigid rotation about the axis: u = a x (x - c) [m/rad].

    ``rotation_field @ f`` is the moment [N m] of a load vector f about the axis.
    """
    c, a = _axis(axis_point, axis)
    r = model.node_coordinates - c
    u = np.cross(a, r)
    out = np.zeros(model.ndof)
    out[model.node_dof_table[:, :3].ravel()] = u.ravel()
    return out


def axial_rotation(model, u, nodes, axis_point=(0.0, 0.0, 0.0), axis=(0.0, 0.0, 1.0)) -> float:
    """Least-squares rigid rotation [rad] about the axis of the ``nodes`` under displacement ``u``:
    theta = sum (a x r) . u_i / sum |a x r|^2."""
    c, a = _axis(axis_point, axis)
    r = model.node_coordinates[nodes] - c
    t = np.cross(a, r)
    ui = u[model.node_dof_table[nodes, :3]]
    return float(np.einsum("ij,ij->", t, ui) / np.einsum("ij,ij->", t, t))
