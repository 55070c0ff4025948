"""Input checks shared by the model elements (plain numpy; raise ModelError with element names)."""

from __future__ import annotations

import numpy as np

from ..errors import ModelError


def finite_array(what: str, value, shape=None, *, hint: str = "") -> np.ndarray:
    """Return ``value`` as a float array; raise ModelError naming ``what`` if it is not finite or of wrong shape."""
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ModelError(f"{what} must be numeric, got {value!r}. {hint}".strip()) from exc
    if shape is not None:
        shapes = shape if isinstance(shape, list) else [shape]
        if arr.shape not in [tuple(s) for s in shapes]:
            exp = " or ".join(str(tuple(s)) for s in shapes)
            raise ModelError(f"{what} has shape {arr.shape}; expected {exp}. {hint}".strip())
    if not np.all(np.isfinite(arr)):
        raise ModelError(f"{what} contains NaN or inf: {arr.tolist()}. Give finite values.")
    return arr


def finite_scalar(what: str, value, *, positive=False, nonnegative=False, unit: str = "") -> float:
    arr = finite_array(what, value)
    if arr.shape != ():
        raise ModelError(f"{what} must be a scalar{(' [' + unit + ']') if unit else ''}, got shape {arr.shape}.")
    v = float(arr)
    if positive and not v > 0:
        raise ModelError(f"{what} must be positive{(' [' + unit + ']') if unit else ''}, got {v}.")
    if nonnegative and v < 0:
        raise ModelError(f"{what} must be non-negative{(' [' + unit + ']') if unit else ''}, got {v}.")
    return v


def unit_vector(what: str, value) -> np.ndarray:
    v = finite_array(what, value, (3,))
    n = np.linalg.norm(v)
    if n < 1e-12:
        raise ModelError(f"{what} has zero length; give a non-zero direction vector, e.g. (0, 0, 1).")
    return v / n


def rotation(what: str, value) -> np.ndarray:
    """A rotation matrix from a 3x3 matrix or a unit quaternion (scalar first)."""
    arr = finite_array(what, value, [(3, 3), (4,)], hint="Give a 3x3 rotation matrix or a unit quaternion (e0, e1, e2, e3).")
    if arr.shape == (4,):
        n = np.linalg.norm(arr)
        if abs(n - 1.0) > 1e-6:
            raise ModelError(f"{what} quaternion has norm {n:.6g}; expected a unit quaternion (scalar first).")
        from ..spatial.rotation import A_of_p

        return np.asarray(A_of_p(np.asarray(arr / n)))
    if not np.allclose(arr.T @ arr, np.eye(3), atol=1e-8) or np.linalg.det(arr) < 0:
        raise ModelError(f"{what} is not a proper rotation matrix (RᵀR = I, det R = +1).")
    return arr


def inertia_tensor(name: str, value) -> np.ndarray:
    """Inertia about the COM in part axes from 3 principal values or a 3x3 tensor; checks symmetry, PD, triangle."""
    arr = finite_array(
        f"Part '{name}' inertia", value, [(3,), (3, 3)], hint="Give (Ixx, Iyy, Izz) [kg m^2] or a 3x3 tensor."
    )
    J = np.diag(arr) if arr.shape == (3,) else arr
    if not np.allclose(J, J.T, rtol=1e-9, atol=1e-12 * max(1.0, np.abs(J).max())):
        raise ModelError(f"Part '{name}' inertia is not symmetric: {J.tolist()}. Give a symmetric tensor (Ixy = Iyx, ...).")
    w = np.linalg.eigvalsh(J)
    if w.min() <= 0:
        raise ModelError(
            f"Part '{name}' inertia is not positive definite (principal moments {w.tolist()} kg m^2). "
            "Every principal moment must be > 0."
        )
    tol = 1e-9 * w.max()
    if w[0] + w[1] < w[2] - tol:
        raise ModelError(
            f"Part '{name}' inertia violates the triangle inequality: principal moments {w.tolist()} kg m^2 "
            "(each must be at most the sum of the other two). Check the values and their axes."
        )
    return J


def inertia_problem(J) -> str | None:
    """None if ``J`` (3x3) is a valid inertia tensor, else a description of what is wrong (for
    callers that word their own error: URDF links, sweep variants)."""
    J = np.asarray(J, float)
    if not np.all(np.isfinite(J)):
        return f"has non-finite entries ({J.tolist()} kg m^2)"
    w = np.linalg.eigvalsh(0.5 * (J + J.T))
    if w.min() <= 0:
        return f"is not positive definite (principal moments {np.round(w, 12).tolist()} kg m^2)"
    if w[0] + w[1] < w[2] * (1 - 1e-9):
        return f"violates the triangle inequality (principal moments {np.round(w, 12).tolist()} kg m^2)"
    return None
