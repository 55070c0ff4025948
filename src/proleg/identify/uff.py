"""Universal File Format (UFF/UNV) in and out, by pyuff: the format hammer-test data and FE modes
are exchanged in between test rigs, FE post-processors and EMA packages.

- :func:`read_uff`: measured functions (dataset 58): FRFs (function type 4) or time records
  (function type 1), with channel names, response/reference nodes and directions and units.
- :func:`write_frf_uff`: FRFs or time records as dataset 58, binary double precision (58b), so a
  round trip is exact.
- :func:`write_modes_uff`: geometry (dataset 15 nodes, dataset 82 trace lines) and mode shapes
  (dataset 55, normal modes, 3 or 6 values per node). Datasets 15 and 55 are ASCII with the
  format's E13.5 fields: they carry 6 significant digits.

Spec data types used (UFF dataset 58, record 8): 0 unknown, 1 general, 12 acceleration, 13
excitation force; abscissa 17 time, 18 frequency.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import DataError

_FUNC = {1: "time", 4: "frf"}
_DIRS = {1: "+x", 2: "+y", 3: "+z", 4: "+rx", 5: "+ry", 6: "+rz", -1: "-x", -2: "-y", -3: "-z", 0: "scalar"}


@dataclass
class UFFFunctions:
    """Measured functions of one kind read from a UFF file (dataset 58).

    kind : "frf" (x = frequency [Hz], data complex) or "time" (x = time [s], data real)
    x : (n,)                       abscissa
    data : (n, n_ch)               one column per function, in file order
    channels : list[str]           channel names (the response entity name and node/direction)
    units : list[str]              the ordinate's unit label per channel
    x_unit : str                   the abscissa's unit label
    rsp_node, rsp_dir, ref_node, ref_dir : (n_ch,) int   UFF node numbers and directions
    quantity : list[str]           "acceleration", "force", ... from the ordinate spec data type
    """

    kind: str
    x: np.ndarray
    data: np.ndarray
    channels: list
    units: list
    x_unit: str
    rsp_node: np.ndarray
    rsp_dir: np.ndarray
    ref_node: np.ndarray
    ref_dir: np.ndarray
    quantity: list = field(default_factory=list)

    def force_and_accelerations(self):
        """For time records: (time, force, accelerations (n, n_acc), acceleration channel names).
        The force is the one channel whose ordinate is an excitation force (spec data type 13)."""
        if self.kind != "time":
            raise DataError("UFF: these functions are FRFs, not time records; use modal_from_frf(x, data).")
        fi = [i for i, q in enumerate(self.quantity) if q == "force"]
        ai = [i for i, q in enumerate(self.quantity) if q != "force"]
        if len(fi) != 1 or not ai:
            raise DataError(f"UFF: a hammer record needs exactly one force channel (dataset 58 ordinate spec data "
                            f"type 13) and at least one response; found quantities {self.quantity}.")
        return self.x, self.data[:, fi[0]].real, self.data[:, ai].real, [self.channels[i] for i in ai]


_QUANTITY = {12: "acceleration", 13: "force", 11: "velocity", 8: "displacement", 1: "general", 0: "unknown"}


def read_uff(path, kind: str | None = None) -> UFFFunctions:
    """Read the dataset-58 functions of ``path``: FRFs or time records (``kind`` picks one when the
    file holds both). All functions of the kind must share the abscissa."""
    import pyuff

    path = Path(path)
    if not path.is_file():
        raise DataError(f"{path}: no such UFF file.")
    try:
        sets = pyuff.UFF(str(path)).read_sets()
    except Exception as e:  # noqa: BLE001 - pyuff raises bare Exceptions on malformed files
        raise DataError(f"{path}: not a readable UFF file ({type(e).__name__}: {e}).") from e
    sets = [sets] if isinstance(sets, dict) else list(sets)
    f58 = [s for s in sets if s.get("type") == 58]
    if not f58:
        types = sorted({s.get("type") for s in sets})
        raise DataError(f"{path}: no dataset 58 (measured functions) in the file (datasets {types}); "
                        "export FRFs or time records as UFF 58.")
    kinds = {_FUNC.get(int(s.get("func_type", 0)), "other") for s in f58}
    if kind is None:
        kind = "frf" if "frf" in kinds else "time" if "time" in kinds else None
    sel = [s for s in f58 if _FUNC.get(int(s.get("func_type", 0))) == kind]
    if not sel:
        raise DataError(f"{path}: no dataset 58 of kind {kind!r} (function types present: {sorted(kinds)}); "
                        "hammer data are FRFs (type 4) or time responses (type 1).")
    x = np.asarray(sel[0]["x"], float)
    for s in sel[1:]:
        if np.asarray(s["x"]).shape != x.shape or not np.allclose(s["x"], x, rtol=1e-9, atol=0):
            raise DataError(f"{path}: function '{s.get('id1', '')}' has another abscissa than the first; resample "
                            "all channels onto one axis.")
    data = np.column_stack([np.asarray(s["data"]) for s in sel])
    names = [str(s.get("id1", "")).strip() or f"{s.get('rsp_ent_name', 'ch')}:{s.get('rsp_node')}{_DIRS.get(int(s.get('rsp_dir', 0)), '')}"
             for s in sel]
    units = [str(s.get("ordinate_axis_units_lab", "")).strip() for s in sel]
    quantity = [_QUANTITY.get(int(s.get("ordinate_spec_data_type", 0)), "other") for s in sel]
    return UFFFunctions(kind, x, data, names, units, str(sel[0].get("abscissa_axis_units_lab", "")).strip(),
                        np.array([int(s.get("rsp_node", 0)) for s in sel]), np.array([int(s.get("rsp_dir", 0)) for s in sel]),
                        np.array([int(s.get("ref_node", 0)) for s in sel]), np.array([int(s.get("ref_dir", 0)) for s in sel]),
                        quantity)


def write_frf_uff(path, x, data, channels, *, kind: str = "frf", units=None, quantity=None, rsp_node=None,
                  rsp_dir=3, ref_node=1, ref_dir=3, x_unit: str | None = None) -> Path:
    """Write functions as dataset 58b (binary, double): ``x`` (n,) [Hz or s], ``data`` (n, n_ch),
    ``channels`` names (n_ch,). ``kind`` "frf" (complex accelerances, units "m/s^2/N" by default)
    or "time" (real records; ``quantity`` per channel "acceleration" or "force")."""
    import pyuff

    x = np.asarray(x, float)
    data = np.asarray(data)
    data = data[:, None] if data.ndim == 1 else data
    if data.shape[0] != x.size or data.shape[1] != len(channels):
        raise DataError(f"write_frf_uff: data has shape {data.shape}; expected ({x.size}, {len(channels)}) "
                        "(one column per channel name).")
    n = data.shape[1]
    quantity = quantity or ["acceleration"] * n
    units = units or [("m/s^2/N" if kind == "frf" else ("N" if q == "force" else "m/s^2")) for q in quantity]
    rsp_node = np.arange(1, n + 1) if rsp_node is None else np.broadcast_to(rsp_node, (n,))
    rsp_dir = np.broadcast_to(rsp_dir, (n,))
    spec = {v: k for k, v in _QUANTITY.items()}
    path = Path(path)
    if path.exists():
        path.unlink()
    sets = []
    for i in range(n):
        sets.append({"type": 58, "binary": 1, "func_type": 4 if kind == "frf" else 1, "id1": str(channels[i]),
                     "rsp_ent_name": "proleg", "rsp_node": int(rsp_node[i]), "rsp_dir": int(rsp_dir[i]),
                     "ref_ent_name": "proleg", "ref_node": int(ref_node), "ref_dir": int(ref_dir),
                     "abscissa_spacing": 1, "abscissa_spec_data_type": 18 if kind == "frf" else 17,
                     "abscissa_axis_units_lab": x_unit or ("Hz" if kind == "frf" else "s"),
                     "ordinate_spec_data_type": spec.get(quantity[i], 1), "ordinate_axis_units_lab": units[i],
                     "orddenom_spec_data_type": 13 if kind == "frf" else 0,
                     "data": data[:, i] if kind == "frf" else data[:, i].real, "x": x})
    pyuff.UFF(str(path)).write_sets(sets, mode="add")
    return path


@dataclass
class UFFModes:
    """Geometry and modes read back by :func:`read_modes_uff`: node numbers, coordinates (n, 3) [m],
    trace lines (list of node-number arrays), frequencies [Hz], damping [-], shapes (n, 6 or 3, m)."""

    nodes: np.ndarray
    coordinates: np.ndarray
    lines: list
    frequencies: np.ndarray
    damping: np.ndarray
    shapes: np.ndarray


def write_modes_uff(path, node_numbers, coordinates, lines, frequencies, shapes, *, damping=None,
                    name: str = "proleg FE modes") -> Path:
    """Geometry and normal modes for an EMA package: dataset 15 (nodes, ``coordinates`` (n, 3) [m]),
    dataset 82 (one trace line per entry of ``lines``, each a sequence of node numbers; 0 lifts
    the pen), dataset 55 (``shapes`` (n, 3 or 6, m) per node, ``frequencies`` (m,) [Hz],
    ``damping`` (m,) viscous ratios)."""
    import pyuff

    nn = np.asarray(node_numbers, int)
    X = np.asarray(coordinates, float)
    S = np.asarray(shapes, float)
    fr = np.asarray(frequencies, float)
    if X.shape != (nn.size, 3) or S.ndim != 3 or S.shape[0] != nn.size or S.shape[1] not in (3, 6) or S.shape[2] != fr.size:
        raise DataError(f"write_modes_uff: coordinates {X.shape}, shapes {S.shape}, frequencies {fr.shape}; expected "
                        f"({nn.size}, 3), ({nn.size}, 3 or 6, m), (m,).")
    zeta = np.zeros(fr.size) if damping is None else np.asarray(damping, float)
    path = Path(path)
    if path.exists():
        path.unlink()
    sets = [{"type": 15, "node_nums": nn, "def_cs": np.zeros(nn.size, int), "disp_cs": np.zeros(nn.size, int),
             "color": np.ones(nn.size, int), "x": X[:, 0], "y": X[:, 1], "z": X[:, 2]}]
    for k, ln in enumerate(lines):
        ln = np.asarray(ln, int)
        sets.append({"type": 82, "trace_num": k + 1, "n_nodes": ln.size, "color": 1, "id": f"trace {k + 1}",
                     "nodes": ln})
    for j in range(fr.size):
        d = {"type": 55, "id1": name, "id2": f"mode {j + 1}", "id3": "", "id4": "", "id5": "", "model_type": 1,
             "analysis_type": 2, "load_case": 1, "data_ch": 3 if S.shape[1] == 6 else 2, "spec_data_type": 8, "data_type": 2,
             "n_data_per_node": S.shape[1], "mode_n": j + 1, "freq": float(fr[j]), "modal_m": 1.0,
             "modal_damp_vis": float(zeta[j]), "modal_damp_his": 0.0, "node_nums": nn}
        for c in range(S.shape[1]):
            d[f"r{c + 1}"] = S[:, c, j]
        sets.append(d)
    pyuff.UFF(str(path)).write_sets(sets, mode="add")
    return path


def read_modes_uff(path) -> UFFModes:
    """Read datasets 15, 82 and 55 (normal modes) written by :func:`write_modes_uff` or an FE
    post-processor."""
    import pyuff

    sets = pyuff.UFF(str(path)).read_sets()
    sets = [sets] if isinstance(sets, dict) else list(sets)
    s15 = [s for s in sets if s.get("type") == 15]
    s55 = [s for s in sets if s.get("type") == 55]
    if not s15 or not s55:
        raise DataError(f"{path}: needs dataset 15 (nodes) and dataset 55 (mode shapes).")
    nodes = np.concatenate([np.asarray(s["node_nums"], int) for s in s15])
    X = np.column_stack([np.concatenate([np.asarray(s[c], float) for s in s15]) for c in "xyz"])
    lines = [np.asarray(s["nodes"], int) for s in sets if s.get("type") == 82]
    ndpn = int(s55[0].get("n_data_per_node", 3))
    shapes = np.stack([np.column_stack([np.asarray(s[f"r{c + 1}"], float) for c in range(ndpn)]) for s in s55], axis=-1)
    order = np.argsort(np.asarray(s55[0]["node_nums"], int))
    pos = np.searchsorted(np.asarray(s55[0]["node_nums"], int)[order], nodes)
    shapes = shapes[order][pos]
    return UFFModes(nodes, X, lines, np.array([float(s["freq"]) for s in s55]),
                    np.array([float(s.get("modal_damp_vis", 0.0)) for s in s55]), shapes)
