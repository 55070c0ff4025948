"""Euler-parameter kinematics (Nikravesh 1988 naming; ../shared/notes/formulation.md §1).

``p = (e0, e1, e2, e3)`` with the scalar first. ``A(p)`` rotates body components into ground
components. ``G(p)`` acts on ground quantities and ``L(p)`` on body quantities
(Haug 1989 calls the same matrices E and G): ω = 2 G ṗ, ω' = 2 L ṗ.
"""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np


def _xp(x):
    """numpy for a NumPy array (evaluated at once, outside jit: no JAX dispatch or compile),
    else jax.numpy."""
    return np if isinstance(x, np.ndarray) else jnp


# These functions are traced many times per step (inside the Newton matrix's forward-mode
# derivatives), and the traced size is what a cold compile pays for (bench/trace_size.py): ã is
# one concatenation of its signed entries and a reshape, not rows stacked from scalars.
# Measured alternatives (chain7_absolute / bushing7 of bench/bushing_pendulum.py, interleaved
# runs, µs/step): contractions with constant 0/±1 tensors (fewest equations) multiply every
# tangent through the whole tensor: 165 → 195 and 130 → 158; G and L as one concatenation of
# 12 entries: 165 → 180 and 130 → 155; A(p) as 2eeᵀ + ... + (2e0 e)~: bushing7 130 → 138.
# The forms below run as fast as the entry-by-entry ones (167 / 127).
def skew(a):
    """Skew matrix ã with ã b = a × b; works on (..., 3)."""
    xp = _xp(a)
    a = xp.asarray(a)
    z = xp.zeros_like(a[..., :1])
    a0, a1, a2 = a[..., 0:1], a[..., 1:2], a[..., 2:3]
    return xp.concatenate([z, -a2, a1, a2, z, -a0, -a1, a0, z], -1).reshape(a.shape[:-1] + (3, 3))


def quat_mul(a, b):
    """Euler-parameter product a ⊗ b (A(a ⊗ b) = A(a) A(b)); rows (..., 4)."""
    xp = np if isinstance(a, np.ndarray) and isinstance(b, np.ndarray) else jnp  # numpy outside jit
    a0, av = a[..., :1], a[..., 1:]
    b0, bv = b[..., :1], b[..., 1:]
    return xp.concatenate([a0 * b0 - xp.sum(av * bv, -1, keepdims=True), a0 * bv + b0 * av + xp.cross(av, bv)], -1)


def A_of_p(p):
    """Rotation matrix as the homogeneous quadratic (e0² − eᵀe) I + 2 e eᵀ + 2 e0 ẽ; (..., 4) → (..., 3, 3)."""
    xp = _xp(p)
    e0 = p[..., 0]
    e = p[..., 1:]
    eye = xp.eye(3, dtype=p.dtype)
    return (
        (e0**2 - xp.sum(e * e, -1))[..., None, None] * eye
        + 2.0 * e[..., :, None] * e[..., None, :]
        + 2.0 * e0[..., None, None] * skew(e)
    )


def G_of_p(p):
    """G(p) = [−e, ẽ + e0 I] (3×4): ω = 2 G ṗ (ground components)."""
    xp = _xp(p)
    e0, e = p[..., :1], p[..., 1:]
    return xp.concatenate([-e[..., :, None], skew(e) + e0[..., None] * xp.eye(3)], -1)


def L_of_p(p):
    """L(p) = [−e, −ẽ + e0 I] (3×4): ω' = 2 L ṗ (body components)."""
    e0, e = p[..., :1], p[..., 1:]
    return jnp.concatenate([-e[..., :, None], -skew(e) + e0[..., None] * jnp.eye(3)], -1)


def p_of_A(R):
    """Euler parameters of rotation matrices (..., 3, 3) → (..., 4), e0 ≥ 0, branch-free
    (Shepperd 1978: of the four candidate formulas, the one with the largest pivot). NumPy for
    a NumPy array (no JAX dispatch), else jax.numpy (traceable)."""
    xp = _xp(R)
    R00, R11, R22 = R[..., 0, 0], R[..., 1, 1], R[..., 2, 2]
    c = xp.stack(
        [
            xp.stack([1 + R00 + R11 + R22, R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0], R[..., 1, 0] - R[..., 0, 1]], -1),
            xp.stack([R[..., 2, 1] - R[..., 1, 2], 1 + R00 - R11 - R22, R[..., 0, 1] + R[..., 1, 0], R[..., 0, 2] + R[..., 2, 0]], -1),
            xp.stack([R[..., 0, 2] - R[..., 2, 0], R[..., 0, 1] + R[..., 1, 0], 1 - R00 + R11 - R22, R[..., 1, 2] + R[..., 2, 1]], -1),
            xp.stack([R[..., 1, 0] - R[..., 0, 1], R[..., 0, 2] + R[..., 2, 0], R[..., 1, 2] + R[..., 2, 1], 1 - R00 - R11 + R22], -1),
        ],
        -2,
    )  # (..., 4, 4): row k is 4 e_k p
    k = xp.argmax(xp.stack([1 + R00 + R11 + R22, 1 + R00 - R11 - R22, 1 - R00 + R11 - R22, 1 - R00 - R11 + R22], -1), -1)
    q = xp.take_along_axis(c, k[..., None, None], -2)[..., 0, :]
    q = q / xp.linalg.norm(q, axis=-1, keepdims=True)
    return q * xp.where(q[..., :1] < 0, -1.0, 1.0)


def p_from_matrix(R) -> np.ndarray:
    """Unit quaternion (scalar first, e0 ≥ 0) of a rotation matrix given by the user (NumPy,
    outside jit): a left-handed or singular matrix is refused, one that is not orthogonal to
    1e-12 is first replaced by the nearest rotation (U Vᵀ of its SVD), then :func:`p_of_A`.
    (SciPy's ``Rotation.from_matrix`` would do the same, but importing scipy.spatial costs
    ~0.5 s of a first result.)"""
    m = np.asarray(R, dtype=float)
    if not np.linalg.det(m) > 0:
        raise ValueError(f"Non-positive determinant (left-handed or null coordinate frame) in rotation matrix {m}.")
    if not np.allclose(m @ m.T, np.eye(3), rtol=0.0, atol=1e-12):
        U, _, Vt = np.linalg.svd(m)
        m = U @ Vt
    return p_of_A(m)


def euler_zyx_deg(p):
    """Yaw-pitch-roll (Z-Y'-X'') angles in degrees from Euler parameters; (..., 4) → (..., 3)."""
    p = np.asarray(p)
    e0, e1, e2, e3 = p[..., 0], p[..., 1], p[..., 2], p[..., 3]
    yaw = np.arctan2(2 * (e0 * e3 + e1 * e2), 1 - 2 * (e2**2 + e3**2))
    pitch = np.arcsin(np.clip(2 * (e0 * e2 - e3 * e1), -1.0, 1.0))
    roll = np.arctan2(2 * (e0 * e1 + e2 * e3), 1 - 2 * (e1**2 + e2**2))
    return np.degrees(np.stack([yaw, pitch, roll], -1))


def matrix_from_rpy_deg(rpy_deg) -> np.ndarray:
    """Rotation matrix (part axes → ground) from roll, pitch, yaw [deg] (numpy).

    Convention of URDF's ``<origin rpy>`` and Adams' space-fixed "123" orientation: rotate by
    roll about ground x, then pitch about ground y, then yaw about ground z (fixed axes, X then Y
    then Z), R = R_z(yaw) R_y(pitch) R_x(roll); the same as body-fixed z-y'-x'' with yaw first.
    :func:`euler_zyx_deg` returns these angles (as yaw, pitch, roll) from a quaternion.
    """
    r, p, y = np.radians(np.asarray(rpy_deg, float))
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    Rx = np.array([[1.0, 0.0, 0.0], [0.0, cr, -sr], [0.0, sr, cr]])
    Ry = np.array([[cp, 0.0, sp], [0.0, 1.0, 0.0], [-sp, 0.0, cp]])
    Rz = np.array([[cy, -sy, 0.0], [sy, cy, 0.0], [0.0, 0.0, 1.0]])
    return Rz @ Ry @ Rx


def frame_from_axis(axis, xhint=None) -> np.ndarray:
    """Right-handed rotation matrix whose z column is ``axis`` (numpy). x follows ``xhint`` if given."""
    z = np.asarray(axis, dtype=float)
    z = z / np.linalg.norm(z)
    if xhint is None:
        # Pick the ground axis least aligned with z, so x is well defined.
        cand = np.eye(3)[np.argmin(np.abs(z))]
        # Prefer ground x when it is clearly not parallel (keeps frames readable).
        if abs(z[0]) < 0.9:
            cand = np.array([1.0, 0.0, 0.0])
    else:
        cand = np.asarray(xhint, dtype=float)
    x = cand - z * (cand @ z)
    x = x / np.linalg.norm(x)
    y = np.cross(z, x)
    return np.column_stack([x, y, z])


# Batched 3×3 / 3×4 products written as broadcast-and-sum: XLA-CPU fuses them into one loop,
# whereas einsum/matmul with a batch dimension becomes a dot kernel per call (several times
# slower at these sizes inside the Newton loop; bench/README.md).
def mv(A, x):
    """A x over leading batch axes: (..., m, n), (..., n) → (..., m)."""
    return jnp.sum(A * x[..., None, :], -1)


def mtv(A, x):
    """Aᵀ x over leading batch axes: (..., m, n), (..., m) → (..., n)."""
    return jnp.sum(A * x[..., :, None], -2)


def mm(A, B):
    """A B over leading batch axes: (..., m, k), (..., k, n) → (..., m, n)."""
    return jnp.sum(A[..., :, :, None] * B[..., None, :, :], -2)
