"""Model → System: a frozen pytree of parameters (JAX arrays) plus static topology.

``assemble(model)`` is the only door into JAX. Everything inconsistent is raised here, in plain
Python. The resulting :class:`System` is a pytree whose leaves are the numeric parameters
(masses, inertias, marker geometry, stiffnesses, ...): replace them with
``system.with_params(...)`` without recompiling, ``jax.vmap`` over them, differentiate them.
"""

from __future__ import annotations

import dataclasses
import warnings
from dataclasses import dataclass, field

import jax
import jax.numpy as jnp
import numpy as np

from ..errors import ModelError, ProlegWarning
from ..model.forces import Bushing, Force, RotationalBacklash, RotationalSpringDamper, SpringDamper, Torque
from ..model.model import Model
from ..spatial.rotation import G_of_p, L_of_p, mtv, mv, p_from_matrix
from .constraints import ROW_KINDS, ConstraintTopology, build_constraint_topology, constraint_values
from .elements import BushingGroup, PartLoadGroup, RotationalBacklashGroup, RotationalSpringDamperGroup, SpringDamperGroup
from .kinematics import body_kin, marker_kin
from .select import Select
from .sparsity import jacobian_coloring


@dataclass(eq=False)
class Topology:
    """Static (hashed by identity) part of a System: names, counts, index maps, callables."""

    name: str
    body_names: list
    marker_names: list
    marker_body: np.ndarray  # (nm,) body index; nbody = ground
    marker_oh: Select  # (nm, nb+1) marker → body
    joints: list  # model joint objects (kept for names, kinds and marker indices)
    joint_marker_i: np.ndarray
    joint_marker_j: np.ndarray
    ct: ConstraintTopology = None
    groups: list = field(default_factory=list)
    dropped: list = field(default_factory=list)  # (joint name, equation label) of removed redundant rows
    extensions: list = field(default_factory=list)  # contact/actuator/controller groups (later issues)
    model: Model = None
    flex: object = None  # FlexGroup or None
    n_eta: int = 0
    coloring: object = None  # sparsity.Coloring of the Newton matrix (set by assemble)
    planar: tuple = (None, "not checked")  # (coordinates.PlanarBasis or None, why) (set by assemble)
    # Degrees of freedom at the modelled pose (set by assemble): "gruebler" (6 per part + modal
    # coordinates − equations), "rank" (coordinates − rank of the constraint Jacobian, the true
    # count), "redundant" rows, "initial_residual" (max |Φ| at the modelled pose, element, equation).
    dof: dict = field(default_factory=dict)
    joint_tree: object = None  # joint_coordinates.JointTree (built on first use of coordinates="joint")

    @property
    def nbody(self) -> int:
        return len(self.body_names)

    @property
    def nq(self) -> int:
        return 7 * self.nbody + self.n_eta

    @property
    def nc(self) -> int:
        return self.ct.n_rows

    def group(self, kind):
        for g in self.groups:
            if g.kind == kind:
                return g
        return None


@jax.tree_util.register_pytree_node_class
class System:
    """Assembled model: ``params`` (dict of arrays, the pytree leaves) and ``topo`` (static)."""

    def __init__(self, params: dict, topo: Topology):
        self.params = params
        self.topo = topo

    def tree_flatten(self):
        return (self.params,), self.topo

    @classmethod
    def tree_unflatten(cls, topo, children):
        return cls(children[0], topo)

    # -- parameters -------------------------------------------------------------------------
    def param_names(self) -> list[str]:
        """Names accepted by :meth:`with_params`: array names and ``element.field`` names."""
        out = sorted(self.params) + sorted(k[len("variable_"):] for k in self.params if k.startswith("variable_"))
        out += [f"{n}.mass" for n in self.topo.body_names] + [f"{n}.inertia" for n in self.topo.body_names]
        for g in self.topo.groups + self.topo.extensions:
            for n in g.names:
                out += [f"{n}.{k[len(g.kind) + 1:]}" for k in g.params()]
        return out

    def _locate(self, key: str):
        if key in self.params:
            return key, None
        if f"variable_{key}" in self.params:
            return f"variable_{key}", None
        if "." not in key:
            raise ModelError(f"Unknown parameter '{key}'. Valid names: {self.param_names()}")
        elem, fld = key.rsplit(".", 1)
        if elem in self.topo.body_names and fld in ("mass", "inertia"):
            return f"body_{fld}", self.topo.body_names.index(elem)
        for g in self.topo.groups + self.topo.extensions:
            if elem in g.names and f"{g.kind}_{fld}" in self.params:
                return f"{g.kind}_{fld}", g.names.index(elem)
        raise ModelError(f"Unknown parameter '{key}'. Valid names: {self.param_names()}")

    def with_params(self, updates: dict | None = None, **kw) -> System:
        """A copy with some parameters replaced (traceable: use inside vmap/grad).

        Keys are array names (``spring_damper_stiffness``, full array) or element fields
        (``"spring.stiffness"``, ``"upper.mass"``, one element's value).
        """
        new = dict(self.params)
        for key, val in {**(updates or {}), **kw}.items():
            name, idx = self._locate(key)
            try:
                val = jnp.asarray(val, dtype=jnp.float64)
            except (TypeError, ValueError):
                raise ModelError(f"Parameter '{key}' must be numeric, got {val!r}.") from None
            expected = new[name].shape if idx is None else new[name].shape[1:]
            if val.shape != expected and [d for d in val.shape if d != 1] == [d for d in expected if d != 1]:
                val = val.reshape(expected)  # only unit axes differ, e.g. (1,) for a scalar
            if val.shape != expected:
                what = "the whole array" if idx is None else "one element's value"
                raise ModelError(
                    f"Parameter '{key}' ({what}) has shape {expected}; got {val.shape}."
                    + (f" Give one value per element ({expected[0]}) or set one element with 'name.field'." if idx is None and expected else "")
                )
            if not isinstance(val, jax.core.Tracer) and not np.all(np.isfinite(np.asarray(val))):
                raise ModelError(f"Parameter '{key}' contains NaN or inf: {np.asarray(val).tolist()}. Give finite values.")
            new[name] = val if idx is None else new[name].at[idx].set(val)
        return System(new, self.topo)

    def get(self, key: str):
        name, idx = self._locate(key)
        return self.params[name] if idx is None else self.params[name][idx]

    # -- sizes -----------------------------------------------------------------------------
    @property
    def nq(self):
        return self.topo.nq

    @property
    def nc(self):
        return self.topo.nc

    def __repr__(self):
        return f"System({self.topo.name!r}: nq={self.nq}, nc={self.nc})"


# ---------------------------------------------------------------------------------------------
# Pure physics functions
# ---------------------------------------------------------------------------------------------
class StateView:
    """What user force/torque/motion functions see: ``state.position('upper')`` etc. (traceable)."""

    def __init__(self, topo: Topology, bk, mk, t, z=None, params=None):
        self._topo, self._bk, self._mk, self.t, self.z, self._P = topo, bk, mk, t, z, params

    def _b(self, part):
        name = getattr(part, "name", part)
        if name == "ground":
            return self._topo.nbody
        try:
            return self._topo.body_names.index(name)
        except ValueError:
            raise ModelError(f"State access: no part named '{name}'.") from None

    def _m(self, marker):
        name = getattr(marker, "name", marker)
        try:
            return self._topo.marker_names.index(name)
        except ValueError:
            raise ModelError(f"State access: no marker named '{name}'.") from None

    def position(self, part):
        return self._bk.r[self._b(part)]

    def velocity(self, part):
        return self._bk.rd[self._b(part)]

    def orientation(self, part):
        return self._bk.A[self._b(part)]

    def angular_velocity(self, part):
        return self._bk.w[self._b(part)]

    def marker_position(self, marker):
        return self._mk.r[self._m(marker)]

    def marker_velocity(self, marker):
        return self._mk.v[self._m(marker)]

    def marker_orientation(self, marker):
        return self._mk.R[self._m(marker)]

    def _joint_markers(self, joint):
        name = getattr(joint, "name", joint)
        for j in self._topo.joints:
            if j.name == name:
                return self._m(j.marker_i.name), self._m(j.marker_j.name)
        raise ModelError(f"State access: no joint named '{name}'.")

    def joint_angle(self, joint):
        """Rotation [rad] of the joint's marker I relative to J about z_J."""
        from .constraints import joint_angle

        i, j = self._joint_markers(joint)
        return joint_angle(self._mk.R[i], self._mk.R[j])

    def joint_rate(self, joint):
        """d/dt of :meth:`joint_angle` [rad/s]."""
        i, j = self._joint_markers(joint)
        return jnp.dot(self._mk.R[j][:, 2], self._mk.w[i] - self._mk.w[j])

    def joint_translation(self, joint):
        from .constraints import joint_translation

        i, j = self._joint_markers(joint)
        return joint_translation(self._mk.r[i], self._mk.r[j], self._mk.R[j])

    def variable(self, name):
        """Value of the design variable ``name`` (``model.add_variable``), a traced parameter."""
        key = f"variable_{name}"
        if self._P is None or key not in self._P:
            have = sorted(k[9:] for k in (self._P or {}) if k.startswith("variable_"))
            raise ModelError(f"State access: no design variable named '{name}'. Known: {have}. Add it with model.add_variable.")
        return self._P[key]

    def contact_force(self, contact):
        """Normal force [N] of a contact (for touchdown / lift-off guards)."""
        name = getattr(contact, "name", contact)
        for g in self._topo.extensions:
            if g.kind == "contact" and name in g.names:
                out = g.outputs(self._P, self._mk, self.t, self)
                return out["normal_force"][0][g.names.index(name)]
        raise ModelError(f"State access: no contact named '{name}'.")


def kinematics(system: System, q, v=None):
    topo, P = system.topo, system.params
    bk = body_kin(topo.nbody, q, v)
    flex = None
    if topo.n_eta:
        n0 = 7 * topo.nbody
        flex = (q[n0:], None if v is None else v[n0:], P["marker_phi"], P["marker_psi"])
    mk = marker_kin(topo.marker_oh, P["marker_s"], P["marker_C"], bk, flex)
    return bk, mk


def constraints(system: System, q, t):
    """Φ(q, t) of the kept rows (joints, motions, then Euler-parameter normalization)."""
    topo, P = system.topo, system.params
    bk, mk = kinematics(system, q)
    cpl = (P["coupler_ratio"], P["coupler_offset"]) if "coupler_ratio" in P else None
    return constraint_values(topo.ct, P.get("screw_lead", jnp.zeros(0)), mk.r, mk.R, bk.p[:-1], t, cpl)


def mass_action(system: System, q, qdd):
    """M(q) q̈ per body: [m r̈; 4 LᵀJ'L p̈] as an (nq,) vector."""
    P = system.params
    topo = system.topo
    nb = topo.nbody
    qb, ab = q[: 7 * nb].reshape(nb, 7), qdd[: 7 * nb].reshape(nb, 7)
    p = qb[:, 3:]
    L = L_of_p(p)
    Jp = mv(P["body_inertia"], mv(L, ab[:, 3:]))
    out = jnp.concatenate([P["body_mass"][:, None] * ab[:, :3], 4.0 * mtv(L, Jp)], 1).reshape(-1)
    if topo.n_eta:
        out = jnp.concatenate([out, jnp.zeros(topo.n_eta)]) + topo.flex.mass_action(P, q, qdd)
    return out


def element_loads(system: System, bk, mk, t, z=None):
    """Per-marker force and torque accumulations (ground) from all force elements."""
    topo, P = system.topo, system.params
    ctx = StateView(topo, bk, mk, t, z, P)
    nm = len(topo.marker_names)
    Fm = jnp.zeros((nm, 3))
    Tm = jnp.zeros((nm, 3))
    for g in topo.groups + topo.extensions:
        if len(g) and hasattr(g, "loads"):
            F, T = g.loads(P, mk, t, ctx)
            Fm, Tm = Fm + F, Tm + T
    return Fm, Tm


def body_loads(system: System, bk, mk, t, z=None):
    """Applied element loads per part: force Fb (nb, 3) [N, ground] at the COM and torque about
    the COM Nb (nb, 3) [N·m, body components]; also the per-marker Aᵀ F and Aᵀ T (body components)."""
    topo, P = system.topo, system.params
    nb = topo.nbody
    Fm, Tm = element_loads(system, bk, mk, t, z)
    AtF = mtv(mk.Ab, Fm)
    AtT = mtv(mk.Ab, Tm)
    s_loc = mtv(mk.Ab, mk.s) if topo.n_eta else P["marker_s"]
    n_local = AtT + jnp.cross(s_loc, AtF)
    return (topo.marker_oh.T @ Fm)[:nb], (topo.marker_oh.T @ n_local)[:nb], AtF, AtT


def generalized_forces(system: System, q, v, t, z=None):
    """Q(q, v, t): applied loads, gravity and the quadratic-velocity term, (nq,)."""
    topo, P = system.topo, system.params
    nb = topo.nbody
    bk, mk = kinematics(system, q, v)
    # Marker loads → generalized forces: Q_r += F, Q_p += 2 Lᵀ (Aᵀ T + s' × Aᵀ F).
    Fb, Nb, AtF, AtT = body_loads(system, bk, mk, t, z)
    p = bk.p[:nb]
    L = L_of_p(p)
    pd = v[: 7 * nb].reshape(nb, 7)[:, 3:]
    wl = 2.0 * mv(L, pd)  # body-frame angular velocity
    Jw = mv(P["body_inertia"], wl)
    Nb = Nb - jnp.cross(wl, Jw)
    Qr = Fb + P["body_mass"][:, None] * P["gravity"]
    Qp = 2.0 * mtv(L, Nb)
    Q = jnp.concatenate([Qr, Qp], 1).reshape(-1)
    if topo.n_eta:
        Qe = jnp.einsum("mij,mi->j", P["marker_phi"], AtF) + jnp.einsum("mij,mi->j", P["marker_psi"], AtT)
        Q = jnp.concatenate([Q, Qe]) + topo.flex.forces(P, q, v, P["gravity"])
    return Q


def kinetic_energy(system: System, q, v):
    P = system.params
    nb = system.topo.nbody
    vb, qb = v[: 7 * nb].reshape(nb, 7), q[: 7 * nb].reshape(nb, 7)
    wl = 2.0 * mv(L_of_p(qb[:, 3:]), vb[:, 3:])
    T = 0.5 * jnp.sum(P["body_mass"] * jnp.sum(vb[:, :3] ** 2, -1)) + 0.5 * jnp.sum(
        jnp.einsum("bi,bij,bj->b", wl, P["body_inertia"], wl)
    )
    if system.topo.n_eta:
        T = T + system.topo.flex.kinetic(P, q, v)
    return T


def potential_energy(system: System, q, t=0.0, z=None):
    topo, P = system.topo, system.params
    bk, mk = kinematics(system, q)
    ctx = StateView(topo, bk, mk, t, z, P)
    vg = -jnp.sum(P["body_mass"] * (bk.r[:-1] @ P["gravity"]))
    if topo.n_eta:
        vg = vg + topo.flex.potential(P, q, P["gravity"])
    return vg + sum(g.potential(P, mk, t, ctx) for g in topo.groups + topo.extensions if len(g))


def power_terms(system: System, q, v, t, z=None):
    """(dissipated power ≥ 0, input power of external loads) [W]."""
    bk, mk = kinematics(system, q, v)
    return element_power(system, bk, mk, t, z, None if not system.topo.n_eta else system.topo.flex.dissipative(system.params, q, v)[1])


def element_power(system: System, bk, mk, t, z=None, d_flex=None):
    """(dissipated power, input power) [W] of the elements at given body and marker kinematics."""
    topo, P = system.topo, system.params
    ctx = StateView(topo, bk, mk, t, z, P)
    gs = [g for g in topo.groups + topo.extensions if len(g)]
    d = sum((g.dissipation(P, mk, t, ctx) for g in gs), jnp.zeros(()))
    if d_flex is not None:
        d = d + d_flex
    w = sum((g.input_power(P, mk, t, ctx) for g in gs), jnp.zeros(()))
    return jnp.stack([d, w])


def constraint_jacobian(system: System, q, t):
    return jax.jacfwd(lambda qq: constraints(system, qq, t))(q)


_jit_constraint_jacobian = jax.jit(constraint_jacobian)


def initial_coordinates(model: Model):
    q, v = [], []
    for part in model.parts:
        p = p_from_matrix(part.orientation)
        pd = 0.5 * np.asarray(G_of_p(jnp.asarray(p))).T @ part.angular_velocity
        q.append(np.concatenate([part.position, p]))
        v.append(np.concatenate([part.velocity, pd]))
    n_eta = sum(p.n_eta for p in model.parts if getattr(p, "is_flexible", False))
    return np.concatenate(q + [np.zeros(n_eta)]), np.concatenate(v + [np.zeros(n_eta)])


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
    from .extensions import build_extensions

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
        from .coordinates import planar_basis

        topo.planar = planar_basis(system, q0)
    else:
        topo.planar = (None, "no revolute joints" if topo.flex is None else "flexible bodies")
    _check_part_loads(system)
    ctrl = next((g for g in extensions if g.kind == "controller"), None)
    if ctrl is not None:
        _check_controllers(system, ctrl)
    if ctrl is not None and "controller_setpoint0" in params:
        from .extensions import joint_coordinate

        th = jax.jit(lambda s, q, v: joint_coordinate(ctrl.pid_oh_i, ctrl.pid_oh_j, ctrl.pid_rot, kinematics(s, q, v)[1])[0])(
            system, jnp.asarray(q0), jnp.asarray(v0)
        )
        system = system.with_params(controller_setpoint0=th)
    return system


_TRACE_HINT = (
    "Write it with jax.numpy or proleg.fn, not math or numpy (jnp.sin(t), not math.sin(t)), and use "
    "jnp.where(t < t1, a, b) instead of an `if` on t or float(t)."
)


def _trace(who: str, fn, *args, shapes=((),), unit=""):
    """``jax.eval_shape(fn, *args)``; a tracer (or any) error → ModelError naming ``who``; the
    output must have one of ``shapes`` (after dropping unit axes)."""
    try:
        out = jax.eval_shape(fn, *args)
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
    t = jax.ShapeDtypeStruct((), jnp.float64)
    for m in getattr(model, "motions", []):
        for what in ("displacement", "velocity", "acceleration"):
            f = getattr(m, what, None)
            if f is not None:
                _trace(f"Motion '{m.name}': its {what} function f(t)", lambda tt, f=f: jnp.asarray(f(tt), jnp.float64), t,
                       unit="rad or m")
    for c in getattr(model, "controllers", []):
        if getattr(c, "kind", "") == "pid" and callable(c.setpoint):
            _trace(f"PID '{c.name}': its setpoint function f(t)", lambda tt, f=c.setpoint: jnp.asarray(f(tt), jnp.float64), t)


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
            jax.eval_shape(trace, system, q0, v0, z0)
        except ModelError as exc:
            raise ModelError(f"{type(e).__name__} '{e.name}': {exc}") from None


def dof_report(system: System) -> dict:
    """Degrees of freedom by Gruebler count and by constraint-Jacobian rank, redundant rows and the
    constraint residual at the modelled pose (``system.topo.dof``, computed by :func:`assemble`)."""
    return {"parts": system.topo.nbody, **system.topo.dof}


def unconnected_parts(topo: Topology) -> list[str]:
    """Parts that no joint, motion, force element, contact or actuator attaches to anything."""
    connected = set()
    for j in list(topo.joints) + list(getattr(topo.model, "motions", [])):
        for m in (getattr(j, "marker_i", None), getattr(j, "marker_j", None)):
            if m is not None:
                connected.add(m.part.name)
    for g in topo.groups + topo.extensions:
        for e in getattr(g, "elements", []):
            for attr in ("i", "j", "marker", "plane", "marker_i", "marker_j"):
                m = getattr(e, attr, None)
                if m is not None and hasattr(m, "part"):
                    connected.add(m.part.name)
            if hasattr(e, "part_names"):
                connected.update(e.part_names())
    return [n for n in topo.body_names if n not in connected]


def _dof_at_assembly(model: Model, topo: Topology, owners, Phi, keep, drop=()) -> dict:
    """DOF counts at the modelled pose, with a warning for a locked model, a part attached to
    nothing (when others are attached) and joints the modelled pose violates."""
    nb = topo.nbody
    n_eq = sum(o.n_equations for o in owners)
    dof = {"gruebler": 6 * nb + topo.n_eta - n_eq, "rank": topo.nq - nb - len(keep)}
    nj = len(Phi) - nb
    worst = int(np.argmax(np.abs(Phi[:nj]))) if nj else None
    res = float(abs(Phi[worst])) if nj else 0.0
    elem, lab = topo.ct.labels[worst] if nj else (None, None)
    dof["initial_residual"] = (res, elem, lab)
    if dof["rank"] == 0 and not getattr(model, "motions", []):
        warnings.warn(
            f"Model '{model.name}' has 0 degrees of freedom (Gruebler count {dof['gruebler']}, Jacobian rank count 0): "
            "its joints lock every part, so nothing can move. Remove or free a joint (e.g. Fixed → Revolute) if it should.",
            ProlegWarning, stacklevel=3,
        )
    free = unconnected_parts(topo)
    if free and len(free) < nb:
        warnings.warn(
            f"Model '{model.name}': part(s) {free} are attached to nothing (no joint, force element or contact) and "
            "will fall freely. Connect them, or remove them.",
            ProlegWarning, stacklevel=3,
        )
    bad_drop = [int(i) for i in drop if abs(Phi[i]) > INITIAL_RESIDUAL_WARN]
    if bad_drop:
        i = max(bad_drop, key=lambda k: abs(Phi[k]))
        warnings.warn(
            f"Model '{model.name}': the modelled pose violates '{topo.ct.labels[i][0]}' ({topo.ct.labels[i][1]}) by "
            f"{abs(Phi[i]):.3g} (m or rad), and that equation is redundant, so it is removed and never enforced: the "
            "joints contradict each other. Fix the joint locations (a simulation would run with it violated).",
            ProlegWarning, stacklevel=3,
        )
    elif res > INITIAL_RESIDUAL_WARN:
        warnings.warn(
            f"Model '{model.name}': the modelled pose violates '{elem}' ({lab}) by {res:.3g} (m or rad); the "
            "initial-conditions analysis will move parts to assemble it. Check the joint location and part poses.",
            ProlegWarning, stacklevel=3,
        )
    return dof


INITIAL_RESIDUAL_WARN = 1e-4  # [m or rad]: above round-off and URDF rounding, below a modelling slip


@jax.jit
def _jit_constraints_and_jacobian(system: System, q, t):
    return constraints(system, q, t), constraint_jacobian(system, q, t)


def kinematic_energy_terms(system: System, q, v, t=0.0, z=None):
    """(kinetic, potential) energy [J]."""
    return kinetic_energy(system, q, v), potential_energy(system, q, t, z)
