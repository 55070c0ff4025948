"""Model → System: a frozen pytree of parameters (JAX arrays) plus static topology, and the pure
physics functions of a System.

``assemble(model)`` (assembly/assemble.py) is the only door into JAX. Everything inconsistent is raised here, in plain
Python. The resulting :class:`System` is a pytree whose leaves are the numeric parameters
(masses, inertias, marker geometry, stiffnesses, ...): replace them with
``system.with_params(...)`` without recompiling, ``jax.vmap`` over them, differentiate them.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import jax
import jax.numpy as jnp
import numpy as np

from ..compile_cache import cached_jit
from ..errors import ModelError, ProlegWarning
from ..model.model import Model
from ..spatial.rotation import G_of_p, L_of_p, mtv, mv, p_from_matrix
from .constraints import ConstraintTopology, constraint_values
from .elements import MarkerLoads, sum_marker_loads
from .kinematics import StateView as StateView
from .kinematics import kinematics
from .select import Select


@dataclass(eq=False)
class Topology:
    """Static part of a System: names, counts, index maps, callables (hashed by identity for
    JAX). Its numbers are data: the numbers a trace reads come from ``params``, so two
    assemblies of one structure share their compiled functions (``_numbers_are_data``;
    proleg.compile_cache.structure_fingerprint, which verifies it once per structure)."""

    _numbers_are_data = True
    #: the degree-of-freedom report (counts, the pose's largest joint residual): read by checks
    #: and messages, never by a trace
    _untraced_fields = ("dof",)

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

    def __repr__(self):  # a dataclass repr would print every index array and the whole model
        kinds = ", ".join(f"{len(g)} {g.kind}" for g in self.groups + self.extensions if _len(g))
        return (f"Topology({self.name!r}: {self.nbody} parts, {len(self.joints)} joints, {self.nc} constraint rows"
                + (f", {kinds}" if kinds else "") + (f", {self.n_eta} modal coordinates" if self.n_eta else "") + ")")

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


def _len(group) -> int:
    try:
        return len(group)
    except TypeError:
        return len(getattr(group, "elements", ()))


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
        return out + list(self._element_params())

    def _element_params(self) -> dict:
        """{"element.field": (array name, index or slice)} over every element group, in model
        order (AbstractGroup.element_params: a group knows where each element's numbers sit)."""
        out = {}
        for g in self.topo.groups + self.topo.extensions:
            out.update(g.element_params())
        return out

    def public_param_names(self) -> list[str]:
        """The parameters a designer sweeps, identifies or differentiates: ``element.field``
        (``"spring.stiffness"``), ``part.mass``/``part.inertia`` and design variables, in model
        order; not the assembled arrays (``q_init``, ``marker_C``, ...), which :meth:`param_names`
        also lists and :meth:`with_params` also accepts."""
        out = sorted(k[len("variable_"):] for k in self.params if k.startswith("variable_"))
        for n in self.topo.body_names:
            out += [f"{n}.mass", f"{n}.inertia"]
        return out + list(self._element_params())

    def _unknown(self, key: str) -> ModelError:
        """The error for a parameter name that is not one: a "did you mean" over the public
        names, and those names (the internal arrays are not offered)."""
        import difflib

        names = self.public_param_names()
        # 0.8: one or two letters off ('spring.stifness', 'bob.mas'), not every field of 'spring.'
        close = difflib.get_close_matches(str(key), names, n=3, cutoff=0.8)
        if not close:  # a bare field name: 'stiffness' → every 'element.stiffness'
            close = [n for n in names if n.rsplit(".", 1)[-1] == str(key).rsplit(".", 1)[-1]][:3]
        hint = f" Did you mean {' or '.join(repr(c) for c in close)}?" if close else ""
        shown = ", ".join(names[:40]) + (f", ... ({len(names)} in all: system.public_param_names())" if len(names) > 40 else "")
        return ModelError(f"Unknown parameter '{key}' of model '{self.topo.name}'.{hint} Parameters: {shown}.")

    def _locate(self, key: str):
        if key in self.params:
            return key, None
        if f"variable_{key}" in self.params:
            return f"variable_{key}", None
        if "." not in key:
            raise self._unknown(key)
        elem, fld = key.rsplit(".", 1)
        if elem in self.topo.body_names and fld in ("mass", "inertia"):
            return f"body_{fld}", self.topo.body_names.index(elem)
        where = self._element_params().get(key)
        if where is not None and where[0] in self.params:
            return where
        raise self._unknown(key)

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
            expected = new[name].shape if idx is None else np.empty(np.shape(new[name]), bool)[idx].shape
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
def constraints(system: System, q, t):
    """Φ(q, t) of the kept rows (joints, motions, then Euler-parameter normalization)."""
    topo, P = system.topo, system.params
    bk, mk = kinematics(system, q)
    cpl = (P["coupler_ratio"], P["coupler_offset"]) if "coupler_ratio" in P else None
    return constraint_values(topo.ct, P.get("screw_lead", jnp.zeros(0)), mk.r, mk.R, bk.p[:-1], t, cpl, P)


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
    Fm = Tm = None
    blocks = []  # the groups' MarkerLoads rows, summed per marker at once
    for g in topo.groups + topo.extensions:
        if len(g) and hasattr(g, "loads"):
            out = g.loads(P, mk, t, ctx)
            if isinstance(out, MarkerLoads):
                blocks += out.blocks
            else:
                F, T = out
                Fm, Tm = (F, T) if Fm is None else (Fm + F, Tm + T)
    if blocks:
        F, T = sum_marker_loads(nm, blocks)
        return (F, T) if Fm is None else (Fm + F, Tm + T)
    return (jnp.zeros((nm, 3)), jnp.zeros((nm, 3))) if Fm is None else (Fm, Tm)


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


def constraints_and_jacobian(system: System, q, t):
    """(Φ, Φ_q) at (q, t) from one forward-mode pass (Φ traced once, not again for its value)."""

    def both(qq):
        phi = constraints(system, qq, t)
        return phi, phi

    Pq, phi = jax.jacfwd(both, has_aux=True)(q)
    return phi, Pq


def initial_coordinates(model: Model):
    q, v = [], []
    for part in model.parts:
        p = p_from_matrix(part.orientation)
        pd = 0.5 * G_of_p(np.asarray(p, float)).T @ part.angular_velocity
        q.append(np.concatenate([part.position, p]))
        v.append(np.concatenate([part.velocity, pd]))
    n_eta = sum(p.n_eta for p in model.parts if getattr(p, "is_flexible", False))
    return np.concatenate(q + [np.zeros(n_eta)]), np.concatenate(v + [np.zeros(n_eta)])


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


@cached_jit
def _jit_constraints_and_jacobian(system: System, q, t):
    return constraints_and_jacobian(system, q, t)


def kinematic_energy_terms(system: System, q, v, t=0.0, z=None):
    """(kinetic, potential) energy [J]."""
    return kinetic_energy(system, q, v), potential_energy(system, q, t, z)
