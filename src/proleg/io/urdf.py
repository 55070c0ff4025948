"""URDF → :class:`proleg.Model` (``load_urdf``), with the link/joint bookkeeping the viewer and
the Pinocchio cross-check need.

Parser: ``yourdfpy`` (maintained, pure Python on lxml, reads every URDF element including
``<dynamics>``, ``<mimic>`` and ``<safety_controller>``, and loads meshes lazily through trimesh
only when asked, so importing a model touches no mesh file). Meshes are not loaded here: their
paths are resolved and checked, and the viewer reads them.

Mapping (Adams merges rigid parts the same way, seed 001):

* links joined by ``fixed`` joints are merged into one part (mass, COM and inertia combined);
  the part is named after the top link of the group, its axes are that link's axes;
* a named marker sits at every link frame (marker name = link name), so ``result.marker('lf_foot')``
  is the URDF frame;
* ``revolute``/``continuous`` → :class:`Revolute`, ``prismatic`` → :class:`Prismatic`,
  ``planar`` → :class:`Planar`, ``floating`` → no joint (a free part); the joint markers are
  placed so that ``result.joint(name).angle`` / ``.translation`` read back the URDF joint
  position with the URDF's sign and zero (marker J: the joint frame on the parent at q = 0,
  marker I: the same frame on the child, both with z along the URDF axis);
* ``<limit lower upper>`` on revolute joints → a :class:`RotationalBacklash` dead band as the
  joint stop (zero torque inside the range, ``stop_stiffness`` outside); ``<dynamics damping>``
  → a :class:`RotationalSpringDamper`; ``<dynamics friction>`` → a smoothed Coulomb torque
  ``−F tanh(ω/ω_f)`` (a :class:`JointActuator`, approximated: reported);
* the root link is a free part (``floating_base=True``) or welded to ground;
* foot links (``feet=``; on a floating base by default every link with a ``<collision><sphere>``,
  or, where no link has one, the lowest collision meshes of the leaf parts; on a welded base
  none) get a :class:`SphereContact` with the ground plane at the sphere centre; a foot whose
  collision is a mesh gets a sphere fitted to the mesh's lowest region (:mod:`.urdf_feet`);
  feet have friction by default (μ = 0.8, :data:`FOOT_CONTACT`; ``load_urdf``'s docstring);
* messy mass properties are repaired as MuJoCo's compiler can (:mod:`.urdf_inertia`: massless
  subtrees welded, massless links that carry links given a small mass, non-physical inertias
  bounded and balanced), each repair noted; ``strict=True`` raises instead;
* a floating base is placed so that its lowest foot sphere touches the ground plane z = 0 at
  the initial joint positions (``base_height=`` or ``base_position=`` to place it yourself): a
  URDF's root frame is usually the trunk centre, and at (0, 0, 0) the feet would start deep in
  the ground (HyQ: 0.8 m, a 712 kN contact force at t = 0);
* every ``<visual>`` is kept (:class:`Visual`) for :func:`proleg.report.animate`.

Everything dropped or approximated is listed in ``model.urdf.notes`` and warned once
(:class:`UrdfWarning`); nothing is dropped silently.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import ModelError
from ..model._validate import inertia_problem as _check_inertia
from .urdf_feet import mesh_feet, mesh_sphere
from .urdf_inertia import BOUND_MASS_FRACTION, massless_links, repair_inertia, sphere_moment
from .urdf_parse import REQUIRED, SUPPORTED, _parse, _resolve_mesh  # noqa: F401 (re-exported)

# Foot contact defaults on top of SphereContact's (load_urdf's docstring says how they were chosen;
# bench/urdf_friction.py measured them)
FOOT_CONTACT = {"mu_static": 0.8, "mu_dynamic": 0.8, "v_stiction": 0.01, "v_friction": 0.05}


class UrdfWarning(UserWarning):
    """Something in a URDF file was dropped or approximated on import (the message says what)."""


@dataclass
class Visual:
    """A visual shape of a part, for the viewer.

    ``X_PV`` (4, 4): pose of the shape in the part frame (origin at the part's COM, part axes)
    [m]. ``kind``: ``"mesh"`` (``filename`` absolute, ``scale`` (3,)), ``"box"`` (``size``
    (3,) [m]), ``"cylinder"`` (``size`` = (radius, length) [m], axis z), ``"sphere"``
    (``size`` = (radius,) [m]). ``part`` is the part name or ``"ground"``.
    """

    part: str
    link: str
    kind: str
    X_PV: np.ndarray
    filename: str | None = None
    scale: np.ndarray = field(default_factory=lambda: np.ones(3))
    size: tuple = ()
    color: tuple | None = None


@dataclass
class UrdfInfo:
    """What ``load_urdf`` built, attached to the model as ``model.urdf``."""

    path: str
    robot: str
    link_part: dict  # link name → part name (or "ground")
    link_frame: dict  # link name → (4, 4) link frame in the part frame (COM origin, part axes)
    joints: list  # moving URDF joints in model order: (name, kind, axis (3,), lower, upper)
    base: str | None  # the free base part, or None when welded
    visuals: list
    notes: list
    feet: list  # link names with a ground contact
    tree: list = field(default_factory=list)  # (link, parent link, joint, type, origin (4, 4), axis (3,)) in tree order; root first with parent None
    base_pose: np.ndarray = field(default_factory=lambda: np.eye(4))  # root link frame in ground at the modelled pose
    initial_positions: dict = field(default_factory=dict)  # joint name → initial position [rad|m] (the modelled pose)

    def joint_names(self):
        return [j[0] for j in self.joints]


# ---------------------------------------------------------------------------------------------
# small rigid-transform helpers (numpy)
# ---------------------------------------------------------------------------------------------
def _rot_axis(axis, angle):
    a = np.asarray(axis, float)
    a = a / np.linalg.norm(a)
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


def _X(R=None, p=None):
    X = np.eye(4)
    if R is not None:
        X[:3, :3] = R
    if p is not None:
        X[:3, 3] = p
    return X


def _joint_motion(kind, axis, q):
    if kind in ("revolute", "continuous"):
        return _X(_rot_axis(axis, q))
    if kind == "prismatic":
        return _X(p=np.asarray(axis, float) / np.linalg.norm(axis) * q)
    return np.eye(4)


def _frame_z(axis):
    from ..spatial.rotation import frame_from_axis

    return frame_from_axis(np.asarray(axis, float))


def _link_inertial(link):
    """(mass, com (3,), inertia (3, 3) about the COM) in the link frame."""
    ine = link.inertial
    if ine is None or ine.mass is None:
        return 0.0, np.zeros(3), np.zeros((3, 3))
    X = np.eye(4) if ine.origin is None else np.asarray(ine.origin, float)
    J = np.zeros((3, 3)) if ine.inertia is None else np.asarray(ine.inertia, float)
    R = X[:3, :3]
    return float(ine.mass), X[:3, 3].copy(), R @ J @ R.T




# ---------------------------------------------------------------------------------------------
# load_urdf
# ---------------------------------------------------------------------------------------------
def load_urdf(
    path,
    *,
    floating_base: bool = True,
    feet=None,
    foot_radius: float = 0.0,
    contact: dict | None = None,
    joint_stops: bool = True,
    stop_stiffness: float = 1e4,
    stop_damping: float = 10.0,
    stop_width: float = 0.01,
    joint_damping: bool = True,
    joint_friction: bool = True,
    friction_velocity: float = 0.01,
    initial_positions: dict | None = None,
    initial_velocities: dict | None = None,
    base_velocity=None,
    strict: bool = False,
    base_position=None,
    base_height: float | None = None,
    base_orientation=None,
    gravity=(0.0, 0.0, -9.81),
    package_dirs=None,
    name: str | None = None,
):
    """Build a :class:`proleg.Model` from a URDF file (see the module docstring for the mapping).

    Parameters
    ----------
    path : str or Path, the .urdf file
    floating_base : bool, default True; the root link is a free part (False: welded to ground)
    feet : None, ``"spheres"``, list of link names, or dict link → radius [m]. ``"spheres"``:
        every link with a ``<collision><sphere>`` (radius and centre from it). None (default):
        ``"spheres"`` on a floating base, no contacts on a welded one (a fixed-base arm or leg
        on a test bench has no floor; ask for ``feet="spheres"`` to give it one). ``()`` for no
        contacts. A named link without a sphere gets ``foot_radius`` at its frame origin.
    contact : dict, keyword arguments of :class:`proleg.SphereContact` (stiffness, damping,
        mu_static, ...) for every foot, on top of :data:`FOOT_CONTACT`: **feet have friction by
        default**, μ_static = μ_dynamic = 0.8 (rubber-soled feet on concrete or wood; a robot stands
        on slopes up to 38°), with the stiction and transition velocities v_stiction = 0.01 m/s and
        v_friction = 0.05 m/s. Choosing values: below v_stiction the friction coefficient rises
        from 0 with slope 1.5 μ / v_stiction, so a stuck foot is a stiff tangential damper
        (μ F_n / v_stiction) whose stick–slip changes the step control must resolve, and it creeps
        at about v_stiction · tan θ / (1.5 μ) on a slope θ (1.5 mm/s at 10°).
        bench/urdf_friction.py (bench/results/urdf_friction.md) measured steps against the
        answer: a planar leg dropped on 1 kHz servos took 8,225 steps at SphereContact's own
        1e-3 / 1e-2 m/s and 1,178 at 0.01 / 0.05 m/s (the servo sampling's floor is ~1,000),
        its slide moving 0.7 mm of 11 mm; 0.01 / 0.05 is the knee of that curve (the contacts
        guide has the table).
        Pass ``contact={"mu_static": 0, "mu_dynamic": 0}`` for frictionless feet.
    joint_stops : bool; revolute ``<limit>`` → :class:`RotationalBacklash` with
        ``stop_stiffness`` [N m/rad], ``stop_damping`` [N m s/rad] and a smoothing ``stop_width``
        [rad] (choosing values: the stop's penetration under a torque τ is τ/k; 1e4 N m/rad
        gives 0.015 rad at HyQ's 150 N m)
    joint_damping, joint_friction : bool; ``<dynamics damping friction>`` as a viscous torque
        [N m s/rad] and a Coulomb torque smoothed over ``friction_velocity`` [rad/s]
    initial_positions : dict joint name → position [rad or m], URDF sign and zero (default 0)
    initial_velocities : dict joint name → rate [rad/s or m/s], URDF sign (default 0)
    base_velocity : (6,) [m/s ×3, rad/s ×3], optional; the floating base's initial twist (v, ω)
        of the root-link frame origin, in root-link axes (Pinocchio's free-flyer convention). The
        rates can also be set after loading: :func:`proleg.io.set_initial_velocity`
    strict : bool, default False. False: messy mass properties are repaired as MuJoCo's compiler
        can and each repair is noted and warned (massless subtrees welded at their initial
        positions, massless links carrying links given a small mass, non-physical inertias
        bounded and balanced: :mod:`proleg.io.urdf_inertia`), so a URDF that Pinocchio builds
        loads. True: such links raise :class:`ModelError`.
    base_position : (3,) [m], root-link frame origin in ground. Default None: x = y = 0 and, on
        a floating base with contacts, the height at which the lowest foot sphere touches the
        ground plane z = 0 (zero gap) at ``initial_positions``; 0 without contacts or when welded
    base_height : float [m], optional; the root-link origin's z, overriding the automatic
        placement (and ``base_position``'s z)
    base_orientation : (3, 3) rotation or unit quaternion (scalar first), root-link axes → ground
    gravity : (3,) [m/s²]
    package_dirs : list of folders searched for ``package://`` mesh paths (besides the URDF's
        own parent folders)

    Returns
    -------
    Model, with ``model.urdf`` (:class:`UrdfInfo`): link → part map, link frames, visuals, the
    notes on what was dropped or approximated.
    """
    from ..model._validate import finite_array, finite_scalar, rotation
    from ..model.contacts import SphereContact
    from ..model.control import JointActuator
    from ..model.forces import RotationalBacklash, RotationalSpringDamper
    from ..model.joints import Planar, Prismatic, Revolute
    from ..model.model import Model

    path = Path(path)
    robot = _parse(path)
    where = f"URDF file {path}"
    notes: list[str] = []

    links = {lk.name: lk for lk in robot.links}
    if len(links) != len(robot.links):
        dup = sorted({lk.name for lk in robot.links if sum(x.name == lk.name for x in robot.links) > 1})
        raise ModelError(f"{where}: link names {dup} are defined more than once.")
    children: dict[str, list] = {n: [] for n in links}
    parent_joint: dict[str, object] = {}
    for j in robot.joints:
        for role, ln in (("parent", j.parent), ("child", j.child)):
            if ln not in links:
                raise ModelError(f"{where}: joint '{j.name}' names {role} link '{ln}', which is not defined. Known links: {sorted(links)}")
        if j.child in parent_joint:
            raise ModelError(
                f"{where}: link '{j.child}' is the child of two joints ('{parent_joint[j.child].name}' and '{j.name}'); "
                "URDF describes trees only (close a loop with a proleg joint after import)."
            )
        parent_joint[j.child] = j
        children[j.parent].append(j)
    roots = [n for n in links if n not in parent_joint]
    if len(roots) != 1:
        raise ModelError(f"{where}: expected one root link (a link that is no joint's child), found {roots}.")
    root = roots[0]

    # joint positions
    q0 = {}
    movable = {j.name: j for j in robot.joints if j.type in ("revolute", "continuous", "prismatic")}
    for k, val in (initial_positions or {}).items():
        if k not in movable:
            raise ModelError(f"initial_positions: '{k}' is not a revolute, continuous or prismatic joint of {path}. Known: {sorted(movable)}")
        q0[k] = float(val)
        lim = movable[k].limit
        if movable[k].type != "continuous" and lim is not None and lim.lower is not None and lim.upper is not None:
            if not (lim.lower - 1e-12 <= q0[k] <= lim.upper + 1e-12):
                warnings.warn(
                    f"initial_positions['{k}'] = {q0[k]:.6g} is outside its URDF limits [{lim.lower:.6g}, {lim.upper:.6g}].",
                    UrdfWarning,
                    stacklevel=2,
                )

    # world frames of the links at the initial configuration (tree order)
    R0 = np.eye(3) if base_orientation is None else rotation("load_urdf base_orientation", base_orientation)
    p0 = np.zeros(3) if base_position is None else finite_array("load_urdf base_position", base_position, (3,)).copy()
    if base_height is not None:
        p0[2] = finite_scalar("load_urdf base_height", base_height, unit="m")
    X_W = {root: _X(R0, p0)}
    order = []
    stack = [root]
    while stack:  # depth first, in the file's order
        ln = stack.pop()
        order.append(ln)
        for j in children[ln]:
            O = np.eye(4) if j.origin is None else np.asarray(j.origin, float)
            X_W[j.child] = X_W[ln] @ O @ _joint_motion(j.type, _axis(j), q0.get(j.name, 0.0))
        stack.extend(j.child for j in reversed(children[ln]))

    # groups of links welded by fixed joints (and, unless strict, massless subtrees welded at
    # their initial positions: urdf_inertia); a group is named after its top link
    link_mass = {ln: _link_inertial(links[ln])[0] for ln in order}
    for ln, m in link_mass.items():
        if not (np.isfinite(m) and m >= 0):
            raise ModelError(f"{where}: link '{ln}' has mass {m} kg. Give a finite <mass value=...> ≥ 0 [kg].")
        if m > 0 and not np.all(np.isfinite(_link_inertial(links[ln])[2])):
            raise ModelError(f"{where}: link '{ln}' has a non-finite <inertia> or <inertial><origin>. Give finite values [kg m², m].")
    welded: set = set()
    group = _groups(order, parent_joint, welded, root, floating_base)
    bounded: list = []
    if not strict:
        welded, bounded = massless_links(order, group, parent_joint, link_mass, floating_base)
        if welded:
            group = _groups(order, parent_joint, welded, root, floating_base)
            names = [parent_joint[ln].name for ln in order if ln in parent_joint and parent_joint[ln].name in welded]
            notes.append(
                f"massless links welded to their parents at the initial joint positions (they carry no mass; joints {names} dropped)"
            )

    # feet → contacts
    if feet is None and not floating_base:
        feet_d = {}
    elif feet is None or (isinstance(feet, str) and feet == "spheres"):
        feet_d = {}
        for ln in order:
            for c in links[ln].collisions or []:
                if c.geometry is not None and c.geometry.sphere is not None:
                    feet_d[ln] = None
        if feet is None and not feet_d:
            feet_d = mesh_feet(order, links, group, parent_joint, welded, X_W, path, package_dirs, notes)
    elif isinstance(feet, dict):
        feet_d = dict(feet)
    elif isinstance(feet, str):
        raise ModelError(f"load_urdf feet={feet!r}: expected None, 'spheres', a list of link names or a dict link → radius [m].")
    else:
        feet_d = {f: None for f in feet}
    spheres = {}  # foot link → (sphere centre (3,) in the link frame [m], radius [m])
    for ln, r in feet_d.items():
        if ln not in links:
            raise ModelError(f"load_urdf feet: no link named '{ln}' in {path}. Known links: {sorted(links)}")
        center, radius, found = np.zeros(3), foot_radius, False
        for c in links[ln].collisions or []:
            if c.geometry is not None and c.geometry.sphere is not None:
                center = (np.eye(4) if c.origin is None else np.asarray(c.origin, float))[:3, 3]
                radius, found = float(c.geometry.sphere.radius), True
                break
        if not found and r is None:
            fit = mesh_sphere(links[ln], X_W[ln], path, package_dirs)
            if fit is not None:
                center, radius, flat = fit
                notes.append(
                    f"foot '{ln}': collision mesh → contact sphere r = {radius * 1e3:.1f} mm fitted to its lowest region"
                    + (" (the foot is flat: one sphere under its centre is a rough model; give feet={link: radius} or add contacts)" if flat else "")
                )
        if r is not None:
            radius = float(r)
        if not (np.isfinite(radius) and radius >= 0 and np.all(np.isfinite(center))):
            raise ModelError(
                f"{where}: foot link '{ln}' has a contact sphere of radius {radius} m at {center.tolist()} m; "
                "the radius must be a finite number >= 0 and the centre finite. Fix the link's "
                "<collision><sphere radius=...>/<origin>, or pass feet= without this link."
            )
        spheres[ln] = (center, radius)

    # a floating base on the ground: lowest sphere bottom at z = 0 (the ground plane of SphereContact)
    if floating_base and base_position is None and base_height is None and spheres:
        bottom = min((X_W[ln] @ _X(p=c))[2, 3] - r for ln, (c, r) in spheres.items())
        for ln in X_W:
            X_W[ln] = X_W[ln].copy()
            X_W[ln][2, 3] -= bottom

    # per-group mass properties in the top link's axes
    model = Model(name or robot.name or path.stem, gravity=gravity)
    tops = [g for g in dict.fromkeys(group[ln] for ln in order) if g != "ground"]
    gm = {g: sum(link_mass[ln] for ln in order if group[ln] == g) for g in tops}
    if bounded and not any(m > 0 for m in gm.values()):
        bounded = []  # no link has mass: nothing to scale a bound to (the error below names the link)
    m_bound = BOUND_MASS_FRACTION * min((m for m in gm.values() if m > 0), default=0.0)
    body_X = {}  # group → world pose of the part frame (COM, top-link axes)
    for g in tops:
        members = [ln for ln in order if group[ln] == g]
        Xg_inv = np.linalg.inv(X_W[g])
        ms, cs, Js = [], [], []
        for ln in members:
            m, c, J = _link_inertial(links[ln])
            X = Xg_inv @ X_W[ln]
            ms.append(m)
            cs.append(X[:3, :3] @ c + X[:3, 3])
            Js.append(X[:3, :3] @ J @ X[:3, :3].T)
            if m > 0 and len(members) > 1 and (bad := _check_inertia(J)) is not None:
                notes.append(f"link '{ln}': inertia {bad}; merged into part '{g}' whose total inertia is used")
        M = float(sum(ms))
        if M <= 0 and g in bounded:
            ms, cs, Js = [m_bound], [np.zeros(3)], [sphere_moment(m_bound) * np.eye(3)]
            M = m_bound
            notes.append(
                f"link '{g}' has no mass but carries links: given {m_bound:.3g} kg (1/{1 / BOUND_MASS_FRACTION:.0f} of the lightest "
                f"part) and a {sphere_moment(m_bound):.3g} kg m² sphere inertia at its frame origin"
            )
        if M <= 0:
            what = f"link '{g}'" if len(members) == 1 else f"links {members} (merged by fixed joints{' or welded as massless' if welded else ''})"
            raise ModelError(
                f"{where}: {what} has zero mass (no <inertial> or mass 0) but moves (joint "
                f"'{parent_joint[g].name if g in parent_joint else 'floating base'}'); proleg parts need mass > 0. "
                "Give the link an <inertial> block, or weld it to a massive link with a fixed joint"
                + (" (strict=True; without it such links are given a small mass or welded, with a warning)." if strict else ".")
            )
        com = sum(m * c for m, c in zip(ms, cs)) / M
        Jt = np.zeros((3, 3))
        for m, c, J in zip(ms, cs, Js):
            d = c - com
            Jt += J + m * (d @ d * np.eye(3) - np.outer(d, d))
        if (bad := _check_inertia(Jt)) is not None:
            who = f"link '{g}'" if len(members) == 1 else f"the merged links {members}"
            if strict:
                raise ModelError(
                    f"{where}: {who} inertia {bad}. Give a physical inertia tensor about the COM "
                    "(every principal moment > 0, each at most the sum of the other two), or load with strict=False to repair it."
                )
            Jt, what = repair_inertia(M, Jt)
            notes.append(f"{who} ({M:.4g} kg): inertia repaired, {what}")
        Xb = X_W[g] @ _X(p=com)
        body_X[g] = Xb
        model.add_part(g, M, Jt, Xb[:3, 3], Xb[:3, :3])

    def part_of(ln):
        return model.ground if group[ln] == "ground" else model.part(group[ln])

    def in_part(ln, X_link_F=np.eye(4)):
        """Pose of a frame (given in link ``ln``) in ln's part frame."""
        Xp = np.eye(4) if group[ln] == "ground" else body_X[group[ln]]
        return np.linalg.inv(Xp) @ X_W[ln] @ X_link_F

    # markers at link frames
    link_frame = {}
    for ln in order:
        model.add_marker(part_of(ln), ln, X_W[ln][:3, 3], X_W[ln][:3, :3])
        link_frame[ln] = in_part(ln)

    # joints
    info_joints, effort_limited = [], []
    for ln in order[1:]:
        j = parent_joint[ln]
        if j.type == "fixed" or j.name in welded:
            continue
        if j.type == "floating":
            notes.append(f"joint '{j.name}' (floating): link '{j.child}' is a free part, no joint")
            continue
        axis = _axis(j)
        O = np.eye(4) if j.origin is None else np.asarray(j.origin, float)
        F = _frame_z(axis)
        X_J = X_W[j.parent] @ O @ _X(F)  # joint frame on the parent, at q = 0
        X_I = X_W[j.child] @ _X(F)  # same frame on the child
        mi = model.add_marker(part_of(j.child), f"{j.name}.I", X_I[:3, 3], X_I[:3, :3])
        mj = model.add_marker(part_of(j.parent), f"{j.name}.J", X_J[:3, 3], X_J[:3, :3])
        if part_of(j.child) is part_of(j.parent):  # pragma: no cover - fixed groups only
            raise ModelError(f"{where}: joint '{j.name}' connects a part to itself.")
        cls = {"revolute": Revolute, "continuous": Revolute, "prismatic": Prismatic, "planar": Planar}[j.type]
        joint = model.add_joint(cls(j.name, mi, mj))
        lim = j.limit
        lo = hi = None
        if j.type in ("revolute", "prismatic") and lim is not None and lim.lower is not None and lim.upper is not None:
            lo, hi = float(lim.lower), float(lim.upper)
        info_joints.append((j.name, j.type, np.asarray(axis, float) / np.linalg.norm(axis), lo, hi))
        if lo is not None and joint_stops:
            if j.type == "revolute" and hi > lo:
                model.add_force(
                    RotationalBacklash(
                        f"{j.name}.stop", joint=joint, stiffness=stop_stiffness, damping=stop_damping,
                        half_gap=0.5 * (hi - lo), free_angle=0.5 * (hi + lo), width=min(stop_width, hi - lo),
                    )
                )
            else:
                notes.append(f"joint '{j.name}' ({j.type}): position limits [{lo}, {hi}] not modelled (no stop element for this type)")
        if lim is not None and lim.effort:
            effort_limited.append(j.name)
        dyn = j.dynamics
        damp = float(dyn.damping or 0.0) if dyn is not None else 0.0
        fric = float(dyn.friction or 0.0) if dyn is not None else 0.0
        rot = j.type in ("revolute", "continuous")
        if damp > 0 and joint_damping:
            if rot:
                model.add_force(RotationalSpringDamper(f"{j.name}.damping", joint=joint, damping=damp))
            else:
                notes.append(f"joint '{j.name}' ({j.type}): damping {damp:g} dropped (viscous damping is modelled on rotational joints only)")
        if fric > 0 and joint_friction:
            if rot:
                import jax.numpy as jnp

                model.add_actuator(
                    JointActuator(
                        f"{j.name}.friction", joint,
                        effort=(lambda t, s, _j=j.name, _f=fric: -_f * jnp.tanh(s.joint_rate(_j) / friction_velocity)),
                    )
                )
                notes.append(f"joint '{j.name}': Coulomb friction {fric:g} N m approximated as −F tanh(ω / {friction_velocity:g} rad/s)")
            else:
                notes.append(f"joint '{j.name}' ({j.type}): Coulomb friction {fric:g} dropped")
        if j.mimic is not None:
            notes.append(f"joint '{j.name}': <mimic joint='{j.mimic.joint}'> dropped (the joint moves freely)")
    if effort_limited:
        notes.append(f"<limit effort velocity> of {len(effort_limited)} joints not enforced (give them to the actuators): {effort_limited}")
    if not floating_base:
        notes.append(f"root link '{root}' welded to ground (floating_base=False); its links' mass is not simulated")

    foot_list = []
    for ln, (center, radius) in spheres.items():
        if group[ln] == "ground":
            continue
        Xc = X_W[ln] @ _X(p=center)
        mk = model.add_marker(part_of(ln), f"{ln}.contact", Xc[:3, 3])
        try:
            model.add_contact(SphereContact(f"{ln}.contact", mk, radius=radius, **{**FOOT_CONTACT, **(contact or {})}))
        except ModelError as exc:  # a bad <sphere radius>: name the file and the link
            raise ModelError(f"{where}: link '{ln}' <collision><sphere>: {exc}") from None
        foot_list.append(ln)
    ncoll = sum(
        1 for ln in order for c in (links[ln].collisions or []) if not (ln in foot_list and c.geometry is not None and c.geometry.sphere is not None)
    )
    if ncoll:
        if foot_list:
            notes.append(f"{ncoll} collision shapes other than the foot spheres are not modelled (ground contact at the feet only)")
        else:
            notes.append(f"{ncoll} collision shapes are not modelled: no ground contacts"
                         + (" (a welded base gets none unless asked: feet='spheres' or a list of links)" if not floating_base and feet is None else ""))

    # visuals
    visuals = []
    for ln in order:
        for v in links[ln].visuals or []:
            Xv = in_part(ln, np.eye(4) if v.origin is None else np.asarray(v.origin, float))
            g = v.geometry
            color = None
            if v.material is not None and v.material.color is not None:
                color = tuple(float(x) for x in v.material.color.rgba)
            pname = group[ln]
            if g is None:
                continue
            if g.mesh is not None:
                f = _resolve_mesh(g.mesh.filename, path, package_dirs)
                if not f.is_file():
                    msg = f"{where}: visual mesh '{g.mesh.filename}' of link '{ln}' not found (looked for {f}); the viewer draws a simple shape instead"
                    warnings.warn(msg, UrdfWarning, stacklevel=2)
                    notes.append(msg)
                    continue
                sc = np.ones(3) if g.mesh.scale is None else np.broadcast_to(np.asarray(g.mesh.scale, float), (3,)).copy()
                visuals.append(Visual(pname, ln, "mesh", Xv, str(f), sc, (), color))
            elif g.box is not None:
                visuals.append(Visual(pname, ln, "box", Xv, size=tuple(np.asarray(g.box.size, float)), color=color))
            elif g.cylinder is not None:
                visuals.append(Visual(pname, ln, "cylinder", Xv, size=(float(g.cylinder.radius), float(g.cylinder.length)), color=color))
            elif g.sphere is not None:
                visuals.append(Visual(pname, ln, "sphere", Xv, size=(float(g.sphere.radius),), color=color))

    info = UrdfInfo(
        path=str(path), robot=robot.name, link_part={ln: group[ln] for ln in order}, link_frame=link_frame,
        joints=info_joints, base=root if floating_base else None, visuals=visuals, notes=notes, feet=foot_list,
        tree=[(root, None, None, None, np.eye(4), np.zeros(3))]
        + [_tree_row(ln, parent_joint[ln], welded, q0) for ln in order[1:]],
        base_pose=X_W[root],
        initial_positions={jn: q0.get(jn, 0.0) for jn, *_ in info_joints},
    )
    model.urdf = info
    if initial_velocities or base_velocity is not None:
        from .urdf_kin import set_initial_velocity

        set_initial_velocity(model, joint_rates=initial_velocities, base_velocity=base_velocity)
    quiet = [n for n in notes if "not found" not in n]
    if quiet:
        warnings.warn(f"{where}: imported with approximations:\n  - " + "\n  - ".join(quiet), UrdfWarning, stacklevel=2)
    return model


def _tree_row(ln, j, welded, q0):
    """(link, parent, joint, type, origin (4, 4), axis (3,)); a welded joint is 'fixed' at its initial position."""
    O = np.eye(4) if j.origin is None else np.asarray(j.origin, float)
    if j.name in welded:
        return (ln, j.parent, j.name, "fixed", O @ _joint_motion(j.type, _axis(j), q0.get(j.name, 0.0)), _axis(j))
    return (ln, j.parent, j.name, j.type, O, _axis(j))


def _groups(order, parent_joint, welded, root, floating_base):
    """link → top link of its group of links joined by fixed (or ``welded``) joints; 'ground' for
    the root's group when the base is welded."""
    group = {}
    for ln in order:
        j = parent_joint.get(ln)
        group[ln] = group[j.parent] if (j is not None and (j.type == "fixed" or j.name in welded)) else ln
    if not floating_base:
        for ln in order:
            if group[ln] == root:
                group[ln] = "ground"
    return group


def _axis(j):
    a = np.array([1.0, 0.0, 0.0]) if j.axis is None else np.asarray(j.axis, float)
    if j.type in ("revolute", "continuous", "prismatic", "planar") and np.linalg.norm(a) < 1e-12:
        raise ModelError(f"URDF joint '{j.name}' has a zero <axis>; give a direction, e.g. xyz=\"0 0 1\".")
    return a / np.linalg.norm(a) if np.linalg.norm(a) > 0 else a
