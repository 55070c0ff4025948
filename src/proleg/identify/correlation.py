"""Correlation of mode sets: MAC, auto-MAC and the FE-versus-test pairing (seed 001 Table 2's layout).

MAC_ij = |a_i^H b_j|^2 / ((a_i^H a_i)(b_j^H b_j)) (Allemang & Brown, IMAC 1982). With a mass
matrix ``M`` the same formula on M-weighted products, |a_i^H M b_j|^2 / ((a_i^H M a_i)(b_j^H M b_j)),
which makes vectors that mix translations and rotations comparable (units cancel through M).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from ..errors import DataError


def _cols(x, name):
    x = np.asarray(x)
    x = x[:, None] if x.ndim == 1 else x
    if x.ndim != 2:
        raise DataError(f"mac: '{name}' has shape {x.shape}; expected (n_dof,) or (n_dof, n_modes).")
    return x


def mac(a, b, M=None) -> np.ndarray:
    """Modal assurance criterion matrix (p, q) between the columns of ``a`` (n, p) and ``b`` (n, q);
    with ``M`` (n, n) the mass-weighted MAC. Values in [0, 1]; 1 for parallel vectors."""
    a, b = _cols(a, "a"), _cols(b, "b")
    if a.shape[0] != b.shape[0]:
        raise DataError(f"mac: the shapes have {a.shape[0]} and {b.shape[0]} DOFs; they must be given at the same "
                        "DOFs (select the FE DOFs of the measured points first).")
    Mb = b if M is None else np.asarray(M @ b)  # M may be a scipy sparse matrix
    Ma = a if M is None else np.asarray(M @ a)
    num = np.abs(a.conj().T @ Mb) ** 2
    den = np.outer(np.real(np.sum(a.conj() * Ma, 0)), np.real(np.sum(b.conj() * Mb, 0)))
    return num / np.where(den > 0, den, np.inf)


def auto_mac(a, M=None) -> np.ndarray:
    """Auto-MAC (p, p) of the columns of ``a``: off-diagonal terms near 1 mean the measured points
    cannot tell two modes apart (too few or badly placed sensors)."""
    return mac(a, a, M)


def comparison_table(f_num, shapes_num, f_exp, shapes_exp, max_ratio: float = 1.3) -> tuple[pd.DataFrame, np.ndarray]:
    """Pair each experimental mode with the numerical mode of highest MAC among those within a
    frequency ratio ``max_ratio`` (ties to the nearest frequency) and print in the layout of seed
    001 Table 2: numerical [Hz], experimental [Hz], difference [%] = |num - exp| / exp, plus the
    MAC. Returns (table, MAC matrix num x exp)."""
    M = mac(shapes_num, shapes_exp)
    rows = []
    for j, fe in enumerate(f_exp):
        lr = np.abs(np.log(np.asarray(f_num) / fe))  # candidates within a frequency ratio of max_ratio
        score = np.where(lr <= np.log(max_ratio), M[:, j], -1.0) - 1e-3 * lr
        i = int(np.argmax(score))
        rows.append({"numerical [Hz]": f_num[i], "experimental [Hz]": fe,
                     "difference [%]": 100 * abs(f_num[i] - fe) / fe, "MAC": M[i, j], "FE mode": i + 1})
    return pd.DataFrame(rows), M
