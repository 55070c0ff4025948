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

from ..errors import ModelError, ProlegWarning
from ..model.forces import Bushing, Force, RotationalBacklash, RotationalSpringDamper, SpringDamper, Torque
from ..model.model import Model
from .constraints import ROW_KINDS, _joint_rows, build_constraint_topology, joint_coordinate
from .coordinates import planar_basis
from .elements import BushingGroup, PartLoadGroup, RotationalBacklashGroup, RotationalSpringDamperGroup, SpringDamperGroup
from .extensions import build_extensions
from .kinematics import StateView, kinematics
from .select import Select
from .sparsity import jacobian_coloring
from .system import System, Topology, _dof_at_assembly, _jit_constraints_and_jacobian, initial_coordinates
from ..compile_cache import jit
from .. import memguard


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


def find_redundant_rows(Phi_q: np.ndarray, nbody: int, scale: np.ndarray | None = None, tol: float = 1e-9):
    """Indices of independent joint rows (model order) and of dropped ones (formulation note §6).

    ``Phi_q`` has the joint rows first and the ``nbody`` normalization rows last; the latter
    are always kept. Rank-revealing QR with column pivoting on the joint rows projected onto
    the complement of the normalization rows. Where the singular values already prove every
    joint row independent (the usual case) the QR is skipped: for any QR, |r_kk| ≥ σ_min and
    |r_11| ≤ σ_max, so σ_min > tol·σ_max keeps all rows. That spares a start importing
    ``scipy.linalg``, a sizeable part of a warm start (docs/performance.md, "Time from import to the table").
    """
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
    if nj <= Pj.shape[1]:
        sv = np.linalg.svd(Pj, compute_uv=False)
        if sv[0] > 0 and sv[nj - 1] > 2.0 * tol * sv[0]:  # a factor 2 for the SVD's own round-off
            return np.arange(nj), np.arange(0)
    import scipy.linalg

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
    memguard.release_if_needed()  # a loop over new models must not reach the kernel's map limit
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

    _check_time_functions(model)
    # Redundancy: full row set at the modelled pose, then keep independent rows.
    ct_full = build_constraint_topology(rows, nm, nb, owners)
    topo.ct = ct_full
    sys_full = System({k: jnp.asarray(v, dtype=jnp.float64) for k, v in params.items()}, topo)
    Phi, Phi_q = (np.asarray(a) for a in _jit_constraints_and_jacobian(sys_full, jnp.asarray(q0), 0.0))
    if not np.all(np.isfinite(Phi_q)):
        raise ModelError(f"Model '{model.name}': the constraint Jacobian is not finite at the modelled pose.")
    ordered = [r for k in ROW_KINDS for r in rows if r["kind"] == k]
    keep, drop = find_redundant_rows(Phi_q, nb, tol=redundancy_tol)
    dof = _dof_at_assembly(model, topo, owners, Phi, keep, drop)
    dropped = [(owners[ordered[i]["owner"]].name, ordered[i]["label"]) for i in drop]
    if dropped:
        warnings.warn(
            f"Model '{model.name}': {len(dropped)} redundant constraint equation(s) removed: "
            + ", ".join(f"{j} ({lab})" for j, lab in dropped)
            + ". Their reactions are statically indeterminate (reported as 0); replace joints by "
            "lower-equation joints or bushings if the split matters.",
            ProlegWarning, stacklevel=2,
        )
        kept_rows = [ordered[i] for i in keep]
        # A new Topology object, not a mutated one: jit caches key on the topology's identity,
        # and executables compiled above for the full row set must not be reused for it.
        topo = dataclasses.replace(topo, ct=build_constraint_topology(kept_rows, nm, nb, owners))
    topo.dropped = dropped
    topo.dof = {**dof, "redundant": list(dropped)}
    topo.coloring = jacobian_coloring(topo)
    system = System({k: jnp.asarray(v, dtype=jnp.float64) for k, v in params.items()}, topo)
    if topo.flex is None and any(getattr(j, "kind", "") in ("revolute", "planar") for j in topo.joints):
        topo.planar = planar_basis(system, q0)
    else:
        topo.planar = (None, "no revolute joints" if topo.flex is None else "flexible bodies")
    _check_part_loads(system)
    ctrl = next((g for g in extensions if g.kind == "controller"), None)
    if ctrl is not None:
        _check_controllers(system, ctrl)
    if ctrl is not None and "controller_setpoint0" in params:
        th = jit(lambda s, q, v: joint_coordinate(ctrl.pid_oh_i, ctrl.pid_oh_j, ctrl.pid_rot, kinematics(s, q, v)[1])[0])(
            system, jnp.asarray(q0), jnp.asarray(v0)
        )
        system = system.with_params(controller_setpoint0=th)
    return system


_TRACE_HINT = (
    "Write it with jax.numpy or proleg.fn, not math or numpy (jnp.sin(t), not math.sin(t)), and use "
    "jnp.where(t < t1, a, b) instead of an `if` on t or float(t)."
)


def _eval_shape(fn, *args):
    """``jax.eval_shape(fn, *args)`` with each System argument's topology closed over, only its
    parameters passed: JAX keeps the argument structures of its calls in a cache of 4,096
    entries, and a topology there would keep its whole model alive after the user dropped it
    (a loop over new models grew by each one; compile_cache.traced_raw has the other half)."""
    topos = [a.topo if isinstance(a, System) else None for a in args]

    def split(*xs):
        return fn(*(System(x, t) if t is not None else x for x, t in zip(xs, topos)))

    return jax.eval_shape(split, *(a.params if isinstance(a, System) else a for a in args))


def _trace(who: str, fn, *args, shapes=((),), unit=""):
    """``jax.eval_shape(fn, *args)``; a tracer (or any) error → ModelError naming ``who``; the
    output must have one of ``shapes`` (after dropping unit axes)."""
    try:
        out = _eval_shape(fn, *args)
    except ModelError as exc:
        raise ModelError(f"{who}: {exc}") from None
    except Exception as exc:  # noqa: BLE001 - any failure to trace is the user's function
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else ""
        raise ModelError(f"{who} cannot be traced by JAX ({type(exc).__name__}: {first[:160]}). {_TRACE_HINT}") from None
    shape = tuple(d for d in getattr(out, "shape", (None,)) if d != 1)
    if not hasattr(out, "shape") or shape not in [tuple(d for d in s if d != 1) for s in shapes]:
        got = getattr(out, "shape", type(out).__name__)
        exp = " or ".join(str(s) for s in shapes)
        raise ModelError(f"{who} returns {got}; expected shape {exp}{(' [' + unit + ']') if unit else ''}.")


def _check_time_functions(model: Model):
    """Trace every function of time once (motions, PID setpoints): a ``math.sin`` or an ``if`` on
    t is a ModelError naming the element here, not a ConcretizationTypeError inside a solver."""
    from ..model.forces import _callable_arity
    from .constraints import VariableView

    t = jax.ShapeDtypeStruct((), jnp.float64)
    P = {f"variable_{k}": jnp.asarray(v[0], jnp.float64) for k, v in getattr(model, "variables", {}).items()}

    def call(f, tt):
        return jnp.asarray(f(tt) if _callable_arity(f) <= 1 else f(tt, VariableView(P, tt)), jnp.float64)

    for m in getattr(model, "motions", []):
        for what in ("displacement", "velocity", "acceleration"):
            f = getattr(m, what, None)
            if f is not None:
                _trace(f"Motion '{m.name}': its {what} function f(t{'' if _callable_arity(f) <= 1 else ', state'})",
                       lambda tt, f=f: call(f, tt), t, unit="rad or m")
    for c in getattr(model, "controllers", []):
        if getattr(c, "kind", "") == "pid" and callable(c.setpoint):
            _trace(f"PID '{c.name}': its setpoint function f(t)", lambda tt, f=c.setpoint: call(f, tt), t)


def _check_part_loads(system: System):
    """Trace every Force/Torque function ``f(t)`` or ``f(t, state)`` once at the modelled state."""
    from .elements import PartLoadGroup

    q0, v0 = system.params["q_init"], system.params["v_init"]
    for g in system.topo.groups:
        if not isinstance(g, PartLoadGroup):
            continue
        for e in g.elements:
            if e.fn is None:
                continue

            def call(s, q, v, t, e=e):
                if e.arity <= 1:
                    return jnp.asarray(e.fn(t), jnp.float64)
                bk, mk = kinematics(s, q, v)
                return jnp.asarray(e.fn(t, StateView(s.topo, bk, mk, t, None, s.params)), jnp.float64)

            unit = "N" if g.kind == "force" else "N m"
            _trace(f"{type(e).__name__} '{e.name}': its function f(t{'' if e.arity <= 1 else ', state'})", call, system, q0, v0,
                   jax.ShapeDtypeStruct((), jnp.float64), shapes=((3,), ()), unit=f"{unit} in ground")


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
            _eval_shape(trace, system, q0, v0, z0)
        except ModelError as exc:
            raise ModelError(f"{type(e).__name__} '{e.name}': {exc}") from None
