"""Foot spheres for URDF feet whose collision shape is a mesh (Unitree Go2, Solo12).

:func:`proleg.io.load_urdf` puts a :class:`proleg.SphereContact` on every foot. Where a foot's
``<collision>`` is a mesh instead of a ``<sphere>``, the sphere is fitted to the mesh's lowest
region, the part of the foot that touches the ground:

1. the collision mesh vertices are put in ground axes at the initial pose (so "lowest" means
   along gravity at the modelled stance, where the robot first touches the ground);
2. the region is the vertices within :data:`CAP_FRACTION` of the mesh's vertical extent above its
   lowest point (at most :data:`CAP_MAX` [m]);
3. a sphere that touches the lowest point is fitted to that cap: for a point at height z above
   the lowest point and horizontal distance ρ from the cap's axis, a sphere of radius r gives
   ρ² = 2 r z − z², so r = Σ z (ρ² + z²) / (2 Σ z²) (least squares); the centre is r above the
   lowest point, under the cap's horizontal centroid;
4. r is at most half the mesh's largest extent (the sphere is no larger than the foot): a
   convex-hull foot is not exactly round (Go2's is 45 × 40 × 39 mm, and its cap fits 24 mm at
   the zero pose, 32 mm at the standing pose, where the foot is turned), so the fit is clamped
   to 22.7 mm there. A flat sole fits a far larger r: above :data:`FLAT_RATIO` times the bound
   the foot is called flat (one sphere under its centre is a rough model; the note says so).

Which links are feet (``feet=None`` on a floating base, and no link has a collision sphere):
the links of the leaf parts (no moving joint below them) whose collision meshes reach within
:data:`FOOT_BAND` [m] of the robot's lowest collision point (any shape) at the initial pose,
one per part (its lowest link). A robot whose lowest shapes are boxes (TALOS's box soles) or
on its base gets no feet and a note. Meshes are read with trimesh (the ``urdf`` extra).
"""

from __future__ import annotations

import numpy as np

CAP_FRACTION = 0.25  # [-] of the mesh's vertical extent
CAP_MAX = 0.02  # [m] at most this high a cap
FLAT_RATIO = 2.0  # [-] a fitted radius above this × half the foot's largest extent: a flat foot
FOOT_BAND = 0.02  # [m] feet reach within this of the lowest collision point


def mesh_vertices(link, X_W_link, urdf_path, package_dirs, cache=None):
    """Ground-frame vertices (n, 3) of every collision mesh of ``link`` at its pose ``X_W_link``
    (4, 4), or (None, why) when there is no mesh or one cannot be read. ``cache``: a dict file →
    vertices shared between calls (robots reuse a mesh for every leg)."""
    from .urdf_parse import _resolve_mesh

    out = []
    for c in link.collisions or []:
        g = c.geometry
        if g is None or g.mesh is None:
            continue
        f = _resolve_mesh(g.mesh.filename, urdf_path, package_dirs)
        if not f.is_file():
            return None, f"collision mesh '{g.mesh.filename}' not found (looked for {f})"
        cache = {} if cache is None else cache
        if str(f) not in cache:
            try:
                import trimesh

                cache[str(f)] = np.asarray(trimesh.load(str(f), force="mesh").vertices, float)
            except Exception as exc:  # a mesh trimesh cannot read (format, missing dependency)
                cache[str(f)] = f"{type(exc).__name__}: {exc}"
        v = cache[str(f)]
        if isinstance(v, str):
            return None, f"collision mesh '{g.mesh.filename}' could not be read ({v})"
        if v.size == 0:
            continue
        sc = np.ones(3) if g.mesh.scale is None else np.broadcast_to(np.asarray(g.mesh.scale, float), (3,))
        X = X_W_link @ (np.eye(4) if c.origin is None else np.asarray(c.origin, float))
        out.append((v * sc) @ X[:3, :3].T + X[:3, 3])
    if not out:
        return None, "no collision mesh"
    return np.vstack(out), None


def lowest_point(link, X_W_link):
    """Lowest ground z [m] of the link's box, cylinder and sphere collisions at its pose (None without any)."""
    zs = []
    for c in link.collisions or []:
        g = c.geometry
        if g is None:
            continue
        X = X_W_link @ (np.eye(4) if c.origin is None else np.asarray(c.origin, float))
        R, p = X[:3, :3], X[:3, 3]
        if g.sphere is not None:
            zs.append(p[2] - float(g.sphere.radius))
        elif g.box is not None:
            half = 0.5 * np.asarray(g.box.size, float)
            zs.append(p[2] - np.abs(R[2]) @ half)
        elif g.cylinder is not None:  # axis z of the shape: rim radius r, half length l/2
            r, hl = float(g.cylinder.radius), 0.5 * float(g.cylinder.length)
            zs.append(p[2] - abs(R[2, 2]) * hl - r * np.hypot(R[2, 0], R[2, 1]))
    return min(zs) if zs else None


def fit_foot_sphere(V):
    """Sphere (centre (3,) in ground [m], radius [m], flat: bool) fitted to the lowest region
    of the vertices ``V`` (n, 3) in ground axes (module docstring)."""
    z0 = V[:, 2].min()
    h = min(CAP_FRACTION * (V[:, 2].max() - z0), CAP_MAX)
    cap = V[V[:, 2] <= z0 + max(h, 1e-9)]
    xy = cap[:, :2].mean(axis=0)
    z = cap[:, 2] - z0
    rho2 = ((cap[:, :2] - xy) ** 2).sum(axis=1)
    r_max = 0.5 * float(np.ptp(V, axis=0).max())
    den = 2.0 * (z * z).sum()
    r = float((z * (rho2 + z * z)).sum() / den) if den > 0 else np.inf
    flat = not (np.isfinite(r) and r <= FLAT_RATIO * r_max)
    r = min(r, r_max)
    return np.array([xy[0], xy[1], z0 + r]), r, flat


def mesh_sphere(link, X_W_link, path, package_dirs):
    """(centre (3,) in the link frame, radius, flat) of the sphere fitted to the link's collision
    meshes (urdf_feet), or None without a readable mesh."""
    V, _ = mesh_vertices(link, X_W_link, path, package_dirs)
    if V is None:
        return None
    c, r, flat = fit_foot_sphere(V)
    return (np.linalg.inv(X_W_link) @ np.append(c, 1.0))[:3], r, flat


def mesh_feet(order, links, group, parent_joint, welded, X_W, path, package_dirs, notes):
    """Feet of a floating robot without collision spheres: the collision meshes of its leaf parts
    that reach within FOOT_BAND of the robot's lowest collision point, one per part (urdf_feet),
    as {link: None}."""
    moving_child = {group[j.parent] for ln, j in parent_joint.items() if j.type != "fixed" and j.name not in welded}
    lowest, why, z_all = {}, [], []
    cache: dict = {}
    for ln in order:
        if not links[ln].collisions:
            continue
        z_prim = lowest_point(links[ln], X_W[ln])  # boxes, cylinders, spheres
        if z_prim is not None:
            z_all.append(z_prim)
        if not any(c.geometry is not None and c.geometry.mesh is not None for c in links[ln].collisions):
            continue
        V, err = mesh_vertices(links[ln], X_W[ln], path, package_dirs, cache)
        if V is None:
            why.append(f"'{ln}': {err}")
            continue
        z = float(V[:, 2].min())
        z_all.append(z)
        g = group[ln]
        if g == "ground" or g in moving_child or g == group[order[0]]:
            continue  # feet are on the leaf parts
        if g not in lowest or z < lowest[g][1]:
            lowest[g] = (ln, z)
    if why:
        notes.append("foot search skipped collision meshes it could not read: " + "; ".join(why))
    if not lowest:
        return {}
    z_min = min(z_all)
    feet = {ln: None for ln, z in lowest.values() if z <= z_min + FOOT_BAND}
    if not feet:
        notes.append(
            "no feet found: no collision sphere, and no leaf part's collision mesh is the robot's lowest collision shape; "
            "give feet=[link names] (a sphere is fitted to each one's collision mesh) or feet={link: radius}"
        )
    return feet
