"""Constraint equations Φ(q, t) from Haug's basic constraints (formulation note §2).

Joint equations are decomposed into primitive rows, grouped by kind and evaluated vectorised
(constant-index selections of marker frames, select.py), so compile time does not grow with the number of joints:

- ``sph``:  component k of d = r_J − r_I (ground)
- ``dot1``: a_I · b_J   (axes of the I and J marker frames)
- ``dot2``: a_I · d
- ``screw``: z_J·(r_I − r_J) − ℓ θ,  θ = atan2(x_I·y_J, x_I·x_J),  ℓ = pitch/2π
- ``drv``:  joint coordinate of I relative to J − f(t) (motions, issue "Contacts, motions ...")
- ``cpl``:  wrap(θ₁ − r θ₂ − c) between the coordinates of two joints (Coupler; translations
  unwrapped), r = ``coupler_ratio``, c = ``coupler_offset`` (the value at the modelled pose)
- ``norm``: pᵀp − 1 per body (always last, never dropped)
"""

from __future__ import annotations

from dataclasses import dataclass, field

import jax.numpy as jnp
import numpy as np

from ..errors import ModelError
from .select import Select


@dataclass(eq=False)
class ConstraintTopology:
    """Static description of the kept constraint rows (selections and numpy arrays, hashed by identity)."""

    #: one-hot float selectors: structure, keyed exactly by the compile cache (never model data)
    _structure_fields = ("sph_k", "d1_a", "d1_b", "d2_a")

    sph_i: Select  # (n, nm) selection of marker rows
    sph_j: Select
    sph_k: np.ndarray  # (n, 3) one-hot component
    d1_i: Select
    d1_a: np.ndarray  # (n, 3) axis of I
    d1_j: Select
    d1_b: np.ndarray  # (n, 3) axis of J
    d2_i: Select
    d2_a: np.ndarray
    d2_j: Select
    sc_i: Select
    sc_j: Select
    sc_param: np.ndarray  # (n,) int, index into params["screw_lead"]
    drv_i: Select
    drv_j: Select
    drv_rot: np.ndarray  # (n,) bool: rotational (True) or translational driver
    drv_fn: tuple = ()  # callables f(t) per driver row
    cp_i1: Select = None  # coupler rows: markers of joint 1 (I, J) and of joint 2 (I, J)
    cp_j1: Select = None
    cp_i2: Select = None
    cp_j2: Select = None
    cp_rot: np.ndarray = None  # (n,) bool: rotations (True) or translations
    cp_param: np.ndarray = None  # (n,) int index into params["coupler_ratio"/"coupler_offset"]
    nbody: int = 0
    labels: list = field(default_factory=list)  # (element name, equation label) per row, in Φ order
    row_owner: np.ndarray = None  # (nrows,) int index into owners (joints, then motions); -1 for norm rows
    owners: list = field(default_factory=list)

    @property
    def n_rows(self) -> int:
        return len(self.labels)


ROW_KINDS = ("sph", "dot1", "dot2", "screw", "drv", "cpl")  # the order of the rows in Φ


def _oh(idx, n):
    """Selection of rows ``idx`` out of ``n`` (gather / scatter-add, see select.py)."""
    return Select(idx, n)


def build_constraint_topology(rows, nm: int, nbody: int, owners) -> ConstraintTopology:
    """``rows``: list of dicts with kind, mi, mj, args, owner (int), label; normalization appended."""
    by = {k: [r for r in rows if r["kind"] == k] for k in ROW_KINDS}
    eye3 = np.eye(3)

    def ax(lst, pos):
        return np.array([eye3[r["args"][pos]] for r in lst]).reshape(len(lst), 3)

    ct = ConstraintTopology(
        sph_i=_oh([r["mi"] for r in by["sph"]], nm),
        sph_j=_oh([r["mj"] for r in by["sph"]], nm),
        sph_k=ax(by["sph"], 0),
        d1_i=_oh([r["mi"] for r in by["dot1"]], nm),
        d1_a=ax(by["dot1"], 0),
        d1_j=_oh([r["mj"] for r in by["dot1"]], nm),
        d1_b=ax(by["dot1"], 1),
        d2_i=_oh([r["mi"] for r in by["dot2"]], nm),
        d2_a=ax(by["dot2"], 0),
        d2_j=_oh([r["mj"] for r in by["dot2"]], nm),
        sc_i=_oh([r["mi"] for r in by["screw"]], nm),
        sc_j=_oh([r["mj"] for r in by["screw"]], nm),
        sc_param=np.array([r["args"][0] for r in by["screw"]], int),
        drv_i=_oh([r["mi"] for r in by["drv"]], nm),
        drv_j=_oh([r["mj"] for r in by["drv"]], nm),
        drv_rot=np.array([r["args"][0] for r in by["drv"]], bool),
        drv_fn=tuple(r["args"][1] for r in by["drv"]),
        cp_i1=_oh([r["mi"] for r in by["cpl"]], nm),
        cp_j1=_oh([r["mj"] for r in by["cpl"]], nm),
        cp_i2=_oh([r["args"][0] for r in by["cpl"]], nm),
        cp_j2=_oh([r["args"][1] for r in by["cpl"]], nm),
        cp_rot=np.array([r["args"][2] for r in by["cpl"]], bool),
        cp_param=np.array([r["args"][3] for r in by["cpl"]], int),
        nbody=nbody,
        owners=list(owners),
    )
    ordered = [r for k in ROW_KINDS for r in by[k]]
    ct.labels = [(owners[r["owner"]].name, r["label"]) for r in ordered] + [
        (f"body{b}", "normalization") for b in range(nbody)
    ]
    ct.row_owner = np.array([r["owner"] for r in ordered] + [-1] * nbody, int)
    return ct


def joint_angle(RI, RJ):
    """Rotation of I relative to J about z_J: atan2(x_I·y_J, x_I·x_J); (..., 3, 3) → (...)."""
    xi = RI[..., :, 0]
    return jnp.arctan2(jnp.sum(xi * RJ[..., :, 1], -1), jnp.sum(xi * RJ[..., :, 0], -1))


def joint_translation(rI, rJ, RJ):
    """Translation of I relative to J along z_J: z_Jᵀ(r_I − r_J)."""
    return jnp.sum(RJ[..., :, 2] * (rI - rJ), -1)


def _wrap(a):
    """An angle difference wrapped to (−π, π]."""
    return jnp.arctan2(jnp.sin(a), jnp.cos(a))


def _coordinate(sel_i, sel_j, rot, mr, R9):
    """Joint coordinates of the selected (I, J) marker pairs: angle where ``rot``, else translation."""
    RI = (sel_i @ R9).reshape(-1, 3, 3)
    RJ = (sel_j @ R9).reshape(-1, 3, 3)
    return jnp.where(rot, joint_angle(RI, RJ), joint_translation(sel_i @ mr, sel_j @ mr, RJ))


def _axes(sel: Select, axes, R9):
    """The marker axes ``axes`` (one-hot rows, (n, 3)) of the selected markers' frames (rows of
    ``R9``, (nm, 9)), ground components (n, 3): one gather of the three entries of each column
    (the frames times a one-hot vector would trace a gather, a product and its reshapes)."""
    k = np.argmax(axes, 1)
    flat = 9 * sel.idx[:, None] + 3 * np.arange(3) + k[:, None]
    return (Select(flat.reshape(-1), R9.size) @ R9.reshape(-1)).reshape(-1, 3)


class VariableView:
    """What a motion law ``f(t, state)`` receives in Φ: the design variables (``state.variable``)
    and the time; the configuration is not offered (a motion law is a function of time)."""

    def __init__(self, params, t):
        self._P, self.t = params, t

    def variable(self, name):
        key = f"variable_{name}"
        if self._P is None or key not in self._P:
            have = sorted(k[9:] for k in (self._P or {}) if k.startswith("variable_"))
            raise ModelError(f"Motion law: no design variable named '{name}'. Known: {have}. Add it with model.add_variable or model.add_law.")
        return self._P[key]


def call_time_function(fn, t, params):
    """``fn(t)``, or ``fn(t, VariableView)`` for a law of two arguments (design variables)."""
    from ..model.forces import _callable_arity

    if _callable_arity(fn) >= 2:
        return fn(t, VariableView(params, t))
    return fn(t)


def constraint_values(ct: ConstraintTopology, screw_lead, mr, mR, p, t, coupler=None, params=None):
    """Φ(q, t) from marker positions ``mr`` (nm, 3), frames ``mR`` (nm, 3, 3) and body p (nb, 4).

    ``coupler``: (ratio, offset) arrays of the Coupler rows (params ``coupler_ratio``,
    ``coupler_offset``). ``params``: the System's parameters, for motion laws that read design
    variables (``f(t, state)``)."""
    parts = []
    R9 = mR.reshape(mR.shape[0], 9)
    if ct.sph_i.shape[0]:
        d = ct.sph_j @ mr - ct.sph_i @ mr
        parts.append(jnp.sum(d * ct.sph_k, -1))
    if ct.d1_i.shape[0]:
        a = _axes(ct.d1_i, ct.d1_a, R9)
        b = _axes(ct.d1_j, ct.d1_b, R9)
        parts.append(jnp.sum(a * b, -1))
    if ct.d2_i.shape[0]:
        a = _axes(ct.d2_i, ct.d2_a, R9)
        d = ct.d2_j @ mr - ct.d2_i @ mr
        parts.append(jnp.sum(a * d, -1))
    if ct.sc_i.shape[0]:
        RI = (ct.sc_i @ R9).reshape(-1, 3, 3)
        RJ = (ct.sc_j @ R9).reshape(-1, 3, 3)
        th = joint_angle(RI, RJ)
        z = joint_translation(ct.sc_i @ mr, ct.sc_j @ mr, RJ)
        lead = screw_lead[ct.sc_param] / (2.0 * jnp.pi)
        parts.append(z - lead * th)
    if ct.drv_i.shape[0]:
        f = jnp.stack([jnp.asarray(call_time_function(fn, t, params), dtype=mr.dtype).reshape(()) for fn in ct.drv_fn])
        d = _coordinate(ct.drv_i, ct.drv_j, ct.drv_rot, mr, R9) - f
        # Rotations: the wrapped difference, so a driven joint can turn through any number of turns.
        parts.append(jnp.where(ct.drv_rot, _wrap(d), d))
    if ct.cp_i1 is not None and ct.cp_i1.shape[0]:
        ratio, offset = coupler[0][ct.cp_param], coupler[1][ct.cp_param]
        c1 = _coordinate(ct.cp_i1, ct.cp_j1, ct.cp_rot, mr, R9)
        c2 = _coordinate(ct.cp_i2, ct.cp_j2, ct.cp_rot, mr, R9)
        d = c1 - ratio * c2 - offset
        parts.append(jnp.where(ct.cp_rot, _wrap(d), d))
    parts.append(jnp.sum(p * p, -1) - 1.0)
    return jnp.concatenate(parts)


def _frames(oh, mk):
    return (oh @ mk.R.reshape(-1, 9)).reshape(-1, 3, 3)


def joint_coordinate(oh_i, oh_j, rot, mk):
    """Joint coordinate (angle or translation of I relative to J) and its rate; vectorised."""
    RI, RJ = _frames(oh_i, mk), _frames(oh_j, mk)
    rI, rJ = oh_i @ mk.r, oh_j @ mk.r
    wI, wJ = oh_i @ mk.w, oh_j @ mk.w
    zJ = RJ[:, :, 2]
    th = joint_angle(RI, RJ)
    th_d = jnp.sum(zJ * (wI - wJ), -1)
    x = joint_translation(rI, rJ, RJ)
    delta = rI - rJ
    x_d = jnp.sum(zJ * (oh_i @ mk.v - oh_j @ mk.v), -1) + jnp.sum(jnp.cross(wJ, zJ) * delta, -1)
    return jnp.where(rot, th, x), jnp.where(rot, th_d, x_d), zJ, delta


def _joint_rows(model, marker_index, owners):
    """The constraint rows of ``owners`` (joints, motions, couplers): one dict per equation, in
    model order; also the screw leads and the coupler (ratio, offset) pairs."""
    rows = []
    screw_leads = []
    couplers = []
    for oi, j in enumerate(owners):
        mi, mj = marker_index[id(j.marker_i)], marker_index[id(j.marker_j)]
        for eq in j.equations:
            kind = eq[0]
            if kind == "sph":
                rows.append(dict(kind="sph", mi=mi, mj=mj, args=(eq[1],), owner=oi, label=f"d{'xyz'[eq[1]]}"))
            elif kind == "dot1":
                rows.append(
                    dict(kind="dot1", mi=mi, mj=mj, args=(eq[1], eq[2]), owner=oi, label=f"{'xyz'[eq[1]]}_I.{'xyz'[eq[2]]}_J")
                )
            elif kind == "dot2":
                rows.append(dict(kind="dot2", mi=mi, mj=mj, args=(eq[1],), owner=oi, label=f"{'xyz'[eq[1]]}_I.d"))
            elif kind == "screw":
                rows.append(dict(kind="screw", mi=mi, mj=mj, args=(len(screw_leads),), owner=oi, label="screw"))
                screw_leads.append(j.pitch)
            elif kind == "drv":
                rows.append(dict(kind="drv", mi=mi, mj=mj, args=(eq[1], eq[2]), owner=oi, label=eq[3]))
            elif kind == "cpl":
                j2 = j.joint_2
                mi2, mj2 = marker_index[id(j2.marker_i)], marker_index[id(j2.marker_j)]
                rows.append(dict(kind="cpl", mi=mi, mj=mj, args=(mi2, mj2, j.dof == "rotation", len(couplers)), owner=oi, label="q1 - r q2"))
                couplers.append((j.ratio, j.offset))
    return rows, np.array(screw_leads, float), np.array(couplers, float).reshape(-1, 2)
