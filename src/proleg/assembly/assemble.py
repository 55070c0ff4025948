"""``assemble(model)``: the only door from a Model into JAX (Model → System).

Everything inconsistent is raised here, in plain Python: element data, joint rows (redundant
ones removed, note §6), controllers traced once, the planar reduction detected
(assembly/coordinates.py). This module sits above system.py, extensions.py and coordinates.py,
which do not import it (the layers import downward only).
"""

from __future__ import annotations

import dataclasses
import warnings

import jax
import jax.numpy as jnp
import numpy as np

from ..errors import ModelError
from ..model.forces import Bushing, Force, RotationalBacklash, RotationalSpringDamper, SpringDamper, Torque
from ..model.model import Model
from .constraints import ROW_KINDS, build_constraint_topology, joint_coordinate
from .coordinates import planar_basis
from .elements import BushingGroup, PartLoadGroup, RotationalBacklashGroup, RotationalSpringDamperGroup, SpringDamperGroup
from .extensions import build_extensions
from .kinematics import StateView, kinematics
from .select import Select
from .sparsity import jacobian_coloring
from .system import System, Topology, _jit_constraint_jacobian, initial_coordinates


# ---------------------------------------------------------------------------------------------
# assemble
# ---------------------------------------------------------------------------------------------
GROUP_BUILDERS = [
    (SpringDamper, SpringDamperGroup),
    (RotationalSpringDamper, RotationalSpringDamperGroup),
    (Bushing, BushingGroup),
    (RotationalBacklash, RotationalBacklashGroup),
]
def _extension_hook(model, topo, marker_index, params):
    return build_extensions(model, topo, marker_index, params)


EXTENSION_HOOKS: list = [_extension_hook]  # callables(model, topo, marker_index, params) → list of groups


def _joint_rows(model: Model, marker_index, owners):
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


def find_redundant_rows(Phi_q: np.ndarray, nbody: int, scale: np.ndarray | None = None, tol: float = 1e-9):
    """Indices of independent joint rows (model order) and of dropped ones (formulation note §6).

    ``Phi_q`` has the joint rows first and the ``nbody`` normalization rows last; the latter
    are always kept. Rank-revealing QR with column pivoting on the joint rows projected onto
    the complement of the normalization rows.
    """
    import scipy.linalg

    nj = Phi_q.shape[0] - nbody
    if nj == 0:
        return np.arange(0), np.arange(0)
    Pj = Phi_q[:nj].copy()
    if scale is not None:
        Pj = Pj * scale[None, :]
    N = Phi_q[nj:]
    if nbody:
        Qn, _ = np.linalg.qr(N.T)
        Pj = Pj - (Pj @ Qn) @ Qn.T
    _, R, piv = scipy.linalg.qr(Pj.T, pivoting=True, mode="economic")
    diag = np.abs(np.diag(R))
    if diag.size == 0 or diag[0] == 0:
        return np.arange(0), np.arange(nj)
    rank = int(np.sum(diag > tol * diag[0]))
    keep = np.sort(piv[:rank])
    drop = np.sort(piv[rank:])
    return keep, drop


def assemble(model: Model, *, redundancy_tol: float = 1e-9) -> System:
    """Build the System of ``model``: checks, parameter arrays, constraint rows, redundancy removal.

    Raises
    ------
    ModelError
        For anything inconsistent (no parts, unknown elements, a part connected to nothing, ...).
    """
    if not isinstance(model, Model):
        raise ModelError(f"assemble expects a proleg.Model, got {type(model).__name__}.")
    if not model.parts:
        raise ModelError(f"Model '{model.name}' has no parts. Add parts with model.add_part.")
    body_index = {id(p): k for k, p in enumerate(model.parts)}
    nb = len(model.parts)
    body_index[id(model.ground)] = nb
    markers = list(model.markers)
    marker_index = {id(m): k for k, m in enumerate(markers)}
    nm = len(markers)
    marker_body = np.array([body_index[id(m.part)] for m in markers], int)
    marker_oh = Select(marker_body, nb + 1)

    flex_parts = [p for p in model.parts if getattr(p, "is_flexible", False)]
    params = {
        "gravity": np.asarray(model.gravity, float),
        # Flexible bodies get their inertia from their own Lagrangian (assembly/flexible.py).
        "body_mass": np.array([0.0 if getattr(p, "is_flexible", False) else p.mass for p in model.parts]),
        "body_inertia": np.array([np.zeros((3, 3)) if getattr(p, "is_flexible", False) else p.inertia for p in model.parts]),
        "marker_s": np.array([m.local_position for m in markers]).reshape(nm, 3),
        "marker_C": np.array([m.local_orientation for m in markers]).reshape(nm, 3, 3),
    }
    q0, v0 = initial_coordinates(model)
    params["q_init"], params["v_init"] = q0, v0
    for vname, (value, _unit, _desc) in getattr(model, "variables", {}).items():
        params[f"variable_{vname}"] = np.asarray(value, float)

    groups = []
    for cls, gcls in GROUP_BUILDERS:
        elems = [f for f in model.forces if type(f) is cls]
        groups.append(gcls(elems, marker_index, nm))
    for kind, cls in (("force", Force), ("torque", Torque)):
        groups.append(PartLoadGroup([f for f in model.forces if isinstance(f, cls)], marker_index, nm, kind))
    for g in groups:
        if len(g):
            params.update(g.params())

    topo = Topology(
        name=model.name,
        body_names=[p.name for p in model.parts],
        marker_names=[m.name for m in markers],
        marker_body=marker_body,
        marker_oh=marker_oh,
        joints=list(model.joints),
        joint_marker_i=np.array([marker_index[id(j.marker_i)] for j in model.joints], int),
        joint_marker_j=np.array([marker_index[id(j.marker_j)] for j in model.joints], int),
        groups=groups,
        model=model,
    )
    if flex_parts:
        from .flexible import FlexGroup

        topo.flex = FlexGroup(flex_parts, body_index, 7 * nb)
        topo.n_eta = topo.flex.n_eta
        params.update(topo.flex.params())
        params["marker_phi"], params["marker_psi"] = topo.flex.marker_fields(markers, nm, topo.n_eta)
    extensions = []
    for hook in EXTENSION_HOOKS:
        extensions += hook(model, topo, marker_index, params)
    topo.extensions = extensions
    owners = list(model.joints) + list(getattr(model, "_constraint_owners_extra", lambda: [])())
    rows, leads, cpl = _joint_rows(model, marker_index, owners)
    params["screw_lead"] = leads
    if len(cpl):
        params["coupler_ratio"], params["coupler_offset"] = cpl[:, 0], cpl[:, 1]

    # Redundancy: full row set at the modelled pose, then keep independent rows.
    ct_full = build_constraint_topology(rows, nm, nb, owners)
    topo.ct = ct_full
    sys_full = System({k: jnp.asarray(v, dtype=jnp.float64) for k, v in params.items()}, topo)
    Phi_q = np.asarray(_jit_constraint_jacobian(sys_full, jnp.asarray(q0), 0.0))
    if not np.all(np.isfinite(Phi_q)):
        raise ModelError(f"Model '{model.name}': the constraint Jacobian is not finite at the modelled pose.")
    ordered = [r for k in ROW_KINDS for r in rows if r["kind"] == k]
    keep, drop = find_redundant_rows(Phi_q, nb, tol=redundancy_tol)
    dropped = [(owners[ordered[i]["owner"]].name, ordered[i]["label"]) for i in drop]
    if dropped:
        warnings.warn(
            f"Model '{model.name}': {len(dropped)} redundant constraint equation(s) removed: "
            + ", ".join(f"{j} ({lab})" for j, lab in dropped)
            + ". Their reactions are statically indeterminate (reported as 0); replace joints by "
            "lower-equation joints or bushings if the split matters.",
            stacklevel=2,
        )
        kept_rows = [ordered[i] for i in keep]
        # A new Topology object, not a mutated one: jit caches key on the topology's identity,
        # and executables compiled above for the full row set must not be reused for it.
        topo = dataclasses.replace(topo, ct=build_constraint_topology(kept_rows, nm, nb, owners))
    topo.dropped = dropped
    topo.coloring = jacobian_coloring(topo)
    system = System({k: jnp.asarray(v, dtype=jnp.float64) for k, v in params.items()}, topo)
    if topo.flex is None and any(getattr(j, "kind", "") in ("revolute", "planar") for j in topo.joints):
        topo.planar = planar_basis(system, q0)
    else:
        topo.planar = (None, "no revolute joints" if topo.flex is None else "flexible bodies")
    ctrl = next((g for g in extensions if g.kind == "controller"), None)
    if ctrl is not None:
        _check_controllers(system, ctrl)
    if ctrl is not None and "controller_setpoint0" in params:
        th = jax.jit(lambda s, q, v: joint_coordinate(ctrl.pid_oh_i, ctrl.pid_oh_j, ctrl.pid_rot, kinematics(s, q, v)[1])[0])(
            system, jnp.asarray(q0), jnp.asarray(v0)
        )
        system = system.with_params(controller_setpoint0=th)
    return system


def _check_controllers(system: System, ctrl):
    """Trace every general controller's update once (``jax.eval_shape``, no compile): an unknown
    joint, contact or variable in a law or guard is a ModelError here, naming the controller,
    not a tracer error later."""
    z0 = jnp.concatenate([jnp.asarray(g.z0(system.params)) for g in system.topo.extensions if hasattr(g, "z0")])
    q0, v0 = system.params["q_init"], system.params["v_init"]
    for e, (off, _size) in zip(ctrl.elements, ctrl.slices):
        if e.kind == "pid":
            continue

        def trace(s, q, v, z, e=e, off=off):
            bk, mk = kinematics(s, q, v)
            return e.update(0.0, StateView(s.topo, bk, mk, 0.0, z, s.params), z[off : off + e.z0.size])

        try:
            jax.eval_shape(trace, system, q0, v0, z0)
        except ModelError as exc:
            raise ModelError(f"{type(e).__name__} '{e.name}': {exc}") from None
