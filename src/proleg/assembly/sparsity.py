"""Sparsity of the Newton matrix and its column colouring (compressed forward-mode Jacobians).

In absolute coordinates every row of the equations of motion or of Φ depends on the
coordinates of at most a few parts: a joint row on its two parts, a force element's load on
the parts of its markers, a part's inertia on its own coordinates. Columns (coordinates) that
never appear in the same row can share one forward-mode tangent, so the Jacobian
[∂(M q̈ − Q)/∂q, ∂Q/∂v; Φ_q] costs one JVP per colour instead of one per coordinate
(Curtis, Powell & Reid 1974; Coleman & Moré 1983). For a chain of parts two part colours
suffice (14 tangents whatever the length) instead of 7 per part.

The pattern is structural, from the topology: constraint rows, force-element and extension
groups (their marker selections), flexible bodies (frame and modal coordinates together).
Elements whose coupling cannot be read from the topology (a Force or Torque given as a
function of the state) make the pattern dense, which is always correct, only slower.
``tests/test_sparsity.py`` checks the compressed Jacobian against the dense one on every
element type.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .select import Select


@dataclass(eq=False)
class Coloring:
    """Static colouring data (numpy; part of the hashed-by-identity topology)."""

    color: np.ndarray  # (nq,) colour of each coordinate column (the seed matrix S[i, color[i]] = 1)
    mask_q: np.ndarray  # (nq, nq) structural non-zeros of the dynamic rows
    mask_phi: np.ndarray  # (nc, nq) structural non-zeros of the constraint rows
    dense: bool  # True when the pattern had to be taken dense

    @property
    def ncolors(self) -> int:
        return int(self.color.max()) + 1 if self.color.size else 0


def _column_groups(topo) -> list[np.ndarray]:
    """Coordinate columns of each part: its 7 frame coordinates plus its modal coordinates."""
    groups = [list(range(7 * b, 7 * b + 7)) for b in range(topo.nbody)]
    if topo.flex is not None:
        for k, b in enumerate(topo.flex.b):
            o = topo.flex.off[k]
            groups[b] += list(range(o, o + topo.flex.bodies[k].n_eta))
    return [np.array(g, int) for g in groups]


def _selects(group) -> list[Select]:
    return [v for v in vars(group).values() if isinstance(v, Select)]


def _element_body_sets(topo) -> list[set] | None:
    """Sets of parts whose coordinates one element's load depends on (None: unknown → dense)."""
    nb = topo.nbody
    mb = topo.marker_body
    out = []
    for g in list(topo.groups) + list(topo.extensions):
        if not len(g) or not hasattr(g, "loads"):
            continue
        if getattr(g, "state_dependent", False):
            return None
        sels = _selects(g)
        if sels and all(len(s) == len(g) for s in sels) and not getattr(g, "clique", False):
            for k in range(len(g)):
                out.append({int(mb[s.idx[k]]) for s in sels} - {nb})
        else:
            # Selections of different lengths (e.g. a controller's joint list): one clique.
            out.append({int(b) for s in sels for b in mb[s.idx]} - {nb})
    return out


def _constraint_row_bodies(topo) -> list[set]:
    ct = topo.ct
    mb = topo.marker_body
    nb = topo.nbody
    rows = []
    for si, sj in ((ct.sph_i, ct.sph_j), (ct.d1_i, ct.d1_j), (ct.d2_i, ct.d2_j), (ct.sc_i, ct.sc_j), (ct.drv_i, ct.drv_j)):
        for a, b in zip(si.idx, sj.idx):
            rows.append({int(mb[a]), int(mb[b])} - {nb})
    if ct.cp_i1 is not None:
        for sel in zip(ct.cp_i1.idx, ct.cp_j1.idx, ct.cp_i2.idx, ct.cp_j2.idx):
            rows.append({int(mb[m]) for m in sel} - {nb})
    rows += [{b} for b in range(ct.nbody)]
    return rows


def greedy_coloring(pattern: np.ndarray) -> np.ndarray:
    """Colour columns so that no two columns of one colour share a non-zero row (greedy, in order)."""
    ncol = pattern.shape[1]
    conflict = (pattern.T.astype(np.int32) @ pattern.astype(np.int32)) > 0
    color = np.full(ncol, -1, int)
    for c in range(ncol):
        used = set(color[conflict[c] & (color >= 0)])
        k = 0
        while k in used:
            k += 1
        color[c] = k
    return color


def jacobian_coloring(topo) -> Coloring:
    """Structural pattern and colouring of the Newton matrix of ``topo``."""
    nq, nc = topo.nq, topo.nc
    cols = _column_groups(topo)
    mask_q = np.zeros((nq, nq), bool)
    for g in cols:
        mask_q[np.ix_(g, g)] = True  # inertia, velocity terms, flexible-body coupling
    sets = _element_body_sets(topo)
    dense = sets is None
    if dense:
        mask_q[:] = True
    else:
        for s in sets:
            idx = np.concatenate([cols[b] for b in s]) if s else np.zeros(0, int)
            mask_q[np.ix_(idx, idx)] = True
    mask_phi = np.zeros((nc, nq), bool)
    for r, s in enumerate(_constraint_row_bodies(topo)):
        for b in s:
            mask_phi[r, cols[b]] = True
    color = greedy_coloring(np.concatenate([mask_q, mask_phi], 0))
    return Coloring(color=color, mask_q=mask_q, mask_phi=mask_phi, dense=dense)
