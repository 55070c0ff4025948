"""HyQ torso on a soft support: beam-frame FE model with heavy lumped masses (seed 001 Problem 3).

Model choice: the torso frame is a welded aluminium frame of thin-walled tubes, ~1 m x 0.5 m
(seed 001 §I; MODEL_DATA §1). 3D Timoshenko beams (:class:`proleg.fem.BeamModel`) represent
such a frame's global modes (bending, torsion of the frame) with a few hundred DOFs, where
solid tetrahedra of thin walls would need ~1e5 DOFs and shells are not in proleg.fem; beams
miss local panel and joint flexibility (a stiffening bias of a few per cent). The heavy
components (electric motor, hydraulic pump, oil tank) are rigid bodies (mass and inertia of a
box) on elastic mounts (6-DOF springs at frame nodes), and the frame rests on four soft pads
(the hammer test's foam, seed 001 Fig. 14). The lowest modes are then the whole torso bouncing
on the foam (~2 Hz), the heavy masses moving on their mounts (~30-40 Hz) and, higher, the
frame's own modes, as in seed 001 Table 2 and Fig. 15.

Values are not printed in seed 001: the masses, mount and pad stiffnesses and the tube section
are chosen (documented in :data:`TORSO_DEFAULTS`); every one is a parameter. Tuned to Table 2
(:func:`table2_comparison`, bench/torso_table2_tuning.py), within stated ranges:

- ``pad_stiffness`` 1150 N/m per pad (range 300..10 000 N/m: soft foam blocks ~100 x 100 x 50 mm,
  E ~ 2..50 kPa), shear half of it: the torso (35.4 kg) bounces at 1.80 Hz (Table 2: 1.8 / 2 Hz);
- ``mount_stiffness`` 1.1e5 N/m per rubber mount (range 2e4..1e6 N/m, isolators for 5..20 kg
  machines): the heavy masses' vertical modes at 32.7 and 39.2 Hz (Table 2: 32 / 30, 40 / 37 Hz);
- tube 40 x 3 mm, masses motor 12 kg, pump 8 kg, tank 10 kg (HyQ ~80 kg, legs ~26 kg).

Measured against Table 2's numerical column: +0.3 / +2.3 / -2.0 % for the first three rows; the three
lowest frame modes (81.8, 86.7, 161.9 Hz) are -32 / -39 / +7 % off 120 / 143 / 152 Hz. A
Nelder-Mead fit of eight parameters inside the ranges (the bench script) brings no robust gain:
its best point (cost 0.08 against 0.41 here) sits where the frame/mount classification of
two coupled modes flips, and rounding its values moves the frame rows by 25 %. The beam frame with
masses on 12 mounts does not hold three frame modes in 120..152 Hz; the paper's tetrahedral model
of the real frame (geometry not printed) does.

Are the paired frame rows the right kinds? (checked by hand, not a bench script):
the bare frame (heavy masses set to 10 g) has its first elastic modes at 140.2 and 146.0 Hz, then
276 Hz -- inside Table 2's frame rows (120 / 143 / 152 Hz numerical). With the 30 kg of heavy
masses on their mounts, the modes the strain-energy classifier calls "frame" fall to 81.8 and
86.7 Hz: they are coupled frame + heavy-mass modes, not the frame's own. A stiffer section moves
them the wrong way for a frame mode (50 x 4 mm tube: 54 / 69 / 71 Hz, -55 to -52 %; 60 x 4 mm:
51 / 64 / 66 Hz) and a frame with 3 cross members instead of 5 gives 67 / 89 / 95 Hz: the rows are
governed by how the masses couple to the frame (mount positions and their rotational stiffness,
50 N m/rad here), which seed 001 does not describe. No 2-3-parameter calibration within physical
ranges has been found; what to try next: mounts at the frame's
nodal lines, a stiffer mount rotation (a rubber mount of this size: ~1e2-1e3 N m/rad), then pair
the Table 2 frame rows with the modes of largest frame-strain share above the mount modes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from ..errors import ModelError

TORSO_DEFAULTS = dict(
    length=1.0, width=0.5, n_cross=5,  # [m], [m], cross members including the two ends
    tube_outer=0.04, tube_wall=0.003,  # square aluminium tube [m]
    material="al6061-t6", element_length=0.05,
    motor_mass=12.0, pump_mass=8.0, tank_mass=10.0,  # [kg]
    motor_x=-0.25, pump_x=0.25, tank_x=0.0,  # [m] along the frame
    mount_stiffness=1.1e5, mount_rot_stiffness=50.0,  # per mount [N/m], [N m/rad]
    pad_stiffness=1150.0, pad_shear_stiffness=575.0,  # per foam pad [N/m]
    damping=(0.05, 0.03, 0.01),  # modal damping: support, mounts, frame [-] (synthetic test)
)
TABLE2 = pd.DataFrame({"numerical [Hz]": [1.8, 32, 40, 120, 143, 152],
                       "experimental [Hz]": [2, 30, 37, 112, 145, 155]})  # seed 001 Table 2


@dataclass
class TorsoModal:
    """Modes of the torso: ``frequencies`` [Hz] (n,), mass-normalised ``shapes`` (ndof, n),
    ``effective_mass`` DataFrame (x, y, z [kg], rx, ry, rz [kg m^2] per mode), ``kind`` per mode
    ("support", "mounts", "frame" by strain-energy share), the ``model`` (LumpedModel) and
    ``frame`` (BeamModel)."""

    frequencies: np.ndarray
    shapes: np.ndarray
    effective_mass: pd.DataFrame
    kind: list
    model: object
    frame: object
    params: dict


def _frame(p):
    from ..fem import BeamModel, Section

    L, W = p["length"], p["width"]
    b, t = p["tube_outer"], p["tube_wall"]
    if not (0 < 2 * t < b):
        raise ModelError(f"torso tube_wall = {t!r} m must be positive and below tube_outer/2 = {b / 2:g} m.")
    bi = b - 2 * t
    I = (b**4 - bi**4) / 12
    J = 2 * t * (b - t) ** 4 / (2 * (b - t))  # Bredt: 4 A_m^2 t / s, A_m = (b-t)^2, s = 4 (b-t)
    sec = Section(b * b - bi * bi, I, I, J, 0.44, "square tube")
    nx = int(round(L / p["element_length"]))
    ny = int(round(W / p["element_length"]))
    xs = np.linspace(-L / 2, L / 2, nx + 1)
    ys = np.linspace(-W / 2, W / 2, ny + 1)
    nodes, index = [], {}

    def node(x, y):
        key = (round(x, 9), round(y, 9))
        if key not in index:
            index[key] = len(nodes)
            nodes.append((x, y, 0.0))
        return index[key]

    elems = []
    for y in (-W / 2, W / 2):
        for a, b_ in zip(xs[:-1], xs[1:], strict=True):
            elems.append((node(a, y), node(b_, y)))
    xc = np.linspace(-L / 2, L / 2, int(p["n_cross"]))
    for x in xc:
        for a, b_ in zip(ys[:-1], ys[1:], strict=True):
            if not any(np.isclose(x, xs)):
                raise ModelError(f"torso n_cross = {p['n_cross']!r} must put cross members on beam nodes (every "
                                 f"element_length = {p['element_length']:g} m); with the defaults use 2, 3, 5, 6, 11 or 21.")
            elems.append((node(x, a), node(x, b_)))
    return BeamModel(np.array(nodes), np.array(elems), sec, p["material"], theory="timoshenko",
                     orientation=(0.0, 0.0, 1.0))


def torso_model(**params):
    """Build the torso :class:`proleg.fem.LumpedModel` (frame + components + pads); returns
    (model, frame, params)."""
    from ..fem import LumpedModel

    unknown = set(params) - set(TORSO_DEFAULTS)
    if unknown:
        raise ModelError(f"torso_modal: unknown parameter(s) {sorted(unknown)}; valid: {sorted(TORSO_DEFAULTS)}.")
    p = {**TORSO_DEFAULTS, **params}
    for k in ("length", "width", "tube_outer", "tube_wall", "motor_mass", "pump_mass", "tank_mass",
              "mount_stiffness", "pad_stiffness", "pad_shear_stiffness", "element_length"):
        if not (np.isfinite(p[k]) and p[k] > 0):
            raise ModelError(f"torso_modal {k} = {p[k]!r} must be positive (SI units).")
    frame = _frame(p)
    m = LumpedModel(frame.K, frame.M, frame.node_coordinates, frame.node_dof_table)
    W = p["width"]
    comps = [("motor", p["motor_mass"], p["motor_x"], (0.20, 0.15, 0.15)),
             ("pump", p["pump_mass"], p["pump_x"], (0.18, 0.15, 0.12)),
             ("tank", p["tank_mass"], p["tank_x"], (0.25, 0.30, 0.15))]
    k, kr = p["mount_stiffness"], p["mount_rot_stiffness"]
    for name, mass, x, (a, b, c) in comps:
        if abs(x) > p["length"] / 2:
            raise ModelError(f"torso_modal {name}_x = {x!r} m lies outside the frame (|x| <= {p['length'] / 2:g} m).")
        center = np.array([x, 0.0, c / 2 + 0.03])
        J = mass / 12 * np.array([b * b + c * c, a * a + c * c, a * a + b * b])
        m.add_body(name, mass, center, J)
        for y in (-W / 2, W / 2):  # two mounts on each side rail, at x +- a/2
            for dx in (-a / 2, a / 2):
                nd = frame.node_at([round((x + dx) / p["element_length"]) * p["element_length"], y, 0.0], tol=1e-6)
                m.add_spring(name, nd, (k, k, k, kr, kr, kr), point=frame.node_coordinates[nd], name=f"{name} mount")
    for x in (-p["length"] / 2, p["length"] / 2):
        for y in (-W / 2, W / 2):
            nd = frame.node_at([x, y, 0.0], tol=1e-6)
            ks = p["pad_shear_stiffness"]
            m.add_spring(nd, "ground", (ks, ks, p["pad_stiffness"], 0, 0, 0), name="foam pad")
    return m, frame, p


def torso_modal(n_modes: int = 30, **params) -> TorsoModal:
    """Natural frequencies [Hz], shapes and effective modal masses of the torso on its soft
    support (parameters: :data:`TORSO_DEFAULTS`)."""
    model, frame, p = torso_model(**params)
    w, phi = model.modes(n_modes)
    f = w / (2 * np.pi)
    mass_total = float(frame.mass + sum(b["mass"] for b in model.bodies.values()))
    # centre of mass for the rigid-body vectors
    com = (frame.mass * frame.node_coordinates.mean(0)
           + sum(b["mass"] * b["center"] for b in model.bodies.values())) / mass_total
    R = model.rigid_body_vectors(com)
    gamma = phi.T @ (model.M @ R)  # participation factors (n, 6)
    eff = pd.DataFrame(gamma**2, columns=["x [kg]", "y [kg]", "z [kg]", "rx [kg m^2]", "ry [kg m^2]", "rz [kg m^2]"])
    eff.insert(0, "frequency [Hz]", f)
    # classify by where the kinetic energy sits: frame vs heavy bodies, and by the foam's strain energy
    nb = frame.ndof
    ke_frame = np.einsum("ij,ij->j", phi[:nb], frame.M @ phi[:nb])
    kind = []
    for j in range(phi.shape[1]):
        if w[j] < 2 * np.pi * 10:
            kind.append("support (rigid torso on foam)")
        elif ke_frame[j] > 0.5:
            kind.append("frame")
        else:
            kind.append("heavy masses on mounts")
    eff["kind"] = kind
    eff.attrs["total_mass"] = mass_total
    return TorsoModal(f, phi, eff, kind, model, frame, p)


def table2_modes(r: TorsoModal) -> np.ndarray:
    """Indices (6,) of the FE modes that play the rows of seed 001 Table 2, in the table's order.

    Row 1 (1.8 Hz numerical, 2 Hz measured): the torso bouncing on the foam, the support mode with
    the largest vertical effective mass. Rows 2-3 (32 / 30 and 40 / 37 Hz): the two modes above
    10 Hz with the largest vertical kinetic energy of the heavy masses (motor, pump, tank moving
    up and down on their mounts: what a vertical hammer hit excites). Rows 4-6 (120 / 112,
    143 / 145, 152 / 155 Hz): the three lowest frame modes. The pairing is ours: seed 001 prints
    the frequencies and Fig. 15's four shapes, not which mode is which.
    """
    f = r.frequencies
    support = [j for j, k in enumerate(r.kind) if k.startswith("support")]
    bounce = max(support, key=lambda j: r.effective_mass["z [kg]"].iloc[j])
    ke_z = sum(b["mass"] * r.shapes[b["dofs"][2]] ** 2 for b in r.model.bodies.values())
    heavy = [j for j in np.argsort(-ke_z) if f[j] > 10.0][:2]
    frame = [j for j, k in enumerate(r.kind) if k == "frame"][:3]
    if len(heavy) < 2 or len(frame) < 3:
        raise ModelError(f"torso: fewer than 2 heavy-mass and 3 frame modes among the {f.size} computed; "
                         "pass a larger n_modes.")
    return np.array([bounce, *sorted(heavy), *frame])


def table2_comparison(r: TorsoModal) -> pd.DataFrame:
    """The FE modes of :func:`table2_modes` next to seed 001 Table 2 (its numerical and its
    experimental column) with the differences [%] (FE / paper - 1)."""
    idx = table2_modes(r)
    out = TABLE2.rename(columns={"numerical [Hz]": "paper numerical [Hz]", "experimental [Hz]": "paper experimental [Hz]"})
    out.insert(0, "FE mode", idx + 1)
    out.insert(1, "kind", [r.kind[j] for j in idx])
    out.insert(2, "FE [Hz]", r.frequencies[idx])
    out["vs numerical [%]"] = 100 * (out["FE [Hz]"] / out["paper numerical [Hz]"] - 1)
    out["vs experimental [%]"] = 100 * (out["FE [Hz]"] / out["paper experimental [Hz]"] - 1)
    return out
