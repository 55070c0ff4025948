"""Repairs of the mass properties real URDF files carry, for :func:`proleg.io.load_urdf`.

Real URDFs are messy: links with no ``<inertial>`` between two joints (a spherical hip written
as three revolutes), zero-mass fingers, point masses with a zero inertia tensor, inertias that
break the triangle inequality. Pinocchio builds such models (its recursive algorithms need only
the joint-space mass matrix to be positive definite); proleg integrates every moving part with
its own mass and inertia, so each part needs mass > 0 and a physical inertia. The repairs
follow MuJoCo's compiler options, scaled to the robot instead of absolute bounds:

* **a massless subtree** (a moving link whose link and descendants all have zero mass: romeo's
  fingers) is welded to its parent at the initial joint positions, as MuJoCo merges static
  bodies: its joints are dropped (they would move nothing) and its link frames stay markers;
* **a massless link that carries massive links** (human's ``*_virtual`` links between the
  revolutes of a hip) gets :data:`BOUND_MASS_FRACTION` of the mass of the robot's lightest
  massive part, with a solid-sphere inertia (MuJoCo ``boundmass``/``boundinertia``);
* **an inertia that is not positive definite** (a point mass: icub's ``r_hip_1``) has every
  principal moment raised to at least the moment of a solid sphere of water of the same mass,
  2/5 m r² with r = (3 m / 4π ρ)^(1/3), ρ = 1000 kg/m³ (a robot link is a few times denser than
  water, so this is a generous floor, of the link's own scale; MuJoCo ``boundinertia``);
* **an inertia that violates the triangle inequality** (romeo_small's ``RShoulderYawLink``)
  has its two smaller principal moments raised, by equal amounts, until the largest equals
  their sum (MuJoCo's ``balanceinertia`` sets all three to their mean instead; the smallest
  change keeps more of the file's data). The principal axes are kept.

Each repair is one line in ``model.urdf.notes`` (and the import warning) naming the link and
the values before and after. ``load_urdf(strict=True)`` raises the former errors instead.
"""

from __future__ import annotations

import numpy as np

WATER_DENSITY = 1000.0  # [kg/m³] the density of the floor sphere
BOUND_MASS_FRACTION = 1e-3  # a massless link carrying links: this fraction of the lightest massive part's mass


def sphere_moment(mass: float) -> float:
    """Principal moment [kg m²] of a solid sphere of water of ``mass`` [kg]: 2/5 m r²."""
    r = (3.0 * mass / (4.0 * np.pi * WATER_DENSITY)) ** (1.0 / 3.0)
    return 0.4 * mass * r * r


def repair_inertia(mass: float, J):
    """A physical inertia tensor close to ``J`` (3, 3) [kg m²] about the COM of a part of ``mass``.

    Returns (J_fixed, what) with ``what`` a short description of the change (None when ``J`` was
    already physical; module docstring for the rules)."""
    from ..model._validate import inertia_problem

    J = 0.5 * (np.asarray(J, float) + np.asarray(J, float).T)
    if inertia_problem(J) is None:
        return J, None
    w, R = np.linalg.eigh(J)
    before = w.copy()
    floor = sphere_moment(mass)
    changes = []
    if w.min() <= 1e-12 * max(abs(w).max(), floor):
        w = np.maximum(w, floor)
        changes.append(f"moments raised to ≥ {floor:.3g} kg m² (water sphere of {mass:.4g} kg)")
    if w[0] + w[1] < w[2]:
        d = 0.5 * (w[2] - w[0] - w[1]) * (1 + 1e-9)
        w = np.array([w[0] + d, w[1] + d, w[2]])
        changes.append("two smaller moments raised to meet the triangle inequality")
    Jf = R @ np.diag(w) @ R.T
    what = (
        f"principal moments {np.round(before, 9).tolist()} → {np.round(np.sort(w), 9).tolist()} kg m² ({'; '.join(changes)})"
    )
    return 0.5 * (Jf + Jf.T), what


def massless_links(order, group, parent_joint, link_mass, floating_base):
    """Split the moving groups of zero mass into (welded, bounded).

    ``welded``: names of the moving joints whose child subtree is massless (to be treated as
    fixed); ``bounded``: top links of zero-mass groups that carry mass (to get a bound mass).
    ``order``: links, parents first; ``group``: link → top link of its fixed-joint group;
    ``link_mass``: link → mass [kg]."""
    subtree = {ln: link_mass[ln] for ln in order}
    for ln in reversed(order):  # children before parents
        j = parent_joint.get(ln)
        if j is not None:
            subtree[j.parent] += subtree[ln]
    gmass = {}
    for ln in order:
        gmass[group[ln]] = gmass.get(group[ln], 0.0) + link_mass[ln]
    welded, bounded = set(), []
    root = order[0]
    for g in dict.fromkeys(group[ln] for ln in order):
        if gmass[g] > 0 or g == "ground" or (g == root and not floating_base):
            continue
        if g != root and subtree[g] == 0:
            j = parent_joint[g]
            if not any(parent_joint.get(a) is not None and parent_joint[a].name in welded for a in _ancestors(g, parent_joint)):
                welded.add(j.name)
        else:
            bounded.append(g)
    # every moving joint inside a welded subtree is welded too
    out = set(welded)
    for ln in order:
        j = parent_joint.get(ln)
        if j is not None and j.type != "fixed" and any(parent_joint[a].name in welded for a in _ancestors(ln, parent_joint, self_too=True)):
            out.add(j.name)
    return out, bounded


def _ancestors(ln, parent_joint, self_too=False):
    out = [ln] if self_too else []
    j = parent_joint.get(ln)
    while j is not None:
        out.append(j.parent)
        j = parent_joint.get(j.parent)
    return [a for a in out if a in parent_joint]
