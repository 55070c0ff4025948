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
from .solid import compact_tets, gmsh_model


def mesh_occ(build, h: float, *, name: str = "proleg_occ", h_min: float | None = None,
             refine=None, curvature_points: int = 12) -> tuple[np.ndarray, np.ndarray]:
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
        gmsh.option.setNumber("Mesh.MeshSizeMax", float(h))
        gmsh.option.setNumber("Mesh.MeshSizeMin", float(h_min if h_min is not None else h / 4))
        gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", int(curvature_points))
        if refine:
            fields = []
            for point, radius, size in refine:
                f = gmsh.model.mesh.field.add("Ball")
                gmsh.model.mesh.field.setNumber(f, "Radius", float(radius))
                gmsh.model.mesh.field.setNumber(f, "VIn", float(size))
                gmsh.model.mesh.field.setNumber(f, "VOut", float(h))
                gmsh.model.mesh.field.setNumber(f, "Thickness", float(radius))
                for c, v in zip("XYZ", point, strict=True):
                    gmsh.model.mesh.field.setNumber(f, f"{c}Center", float(v))
                fields.append(f)
            fmin = gmsh.model.mesh.field.add("Min")
            gmsh.model.mesh.field.setNumbers(fmin, "FieldsList", fields)
            gmsh.model.mesh.field.setAsBackgroundMesh(fmin)
        gmsh.model.mesh.generate(3)
        tags, coords, _ = gmsh.model.mesh.getNodes()
        types, _, conn = gmsh.model.mesh.getElements(3)
        tets_tags = [np.asarray(c, np.int64).reshape(-1, 4) for t, c in zip(types, conn, strict=True) if t == 4]
        if not tets_tags:
            raise ModelError(f"gmsh produced no tetrahedra for '{name}' with h = {h}; reduce h.")
        tets_tags = np.vstack(tets_tags)
    return compact_tets(tags, coords, tets_tags)


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
