"""Linearisation about an equilibrium in independent coordinates, and modal analysis."""

from __future__ import annotations

from dataclasses import dataclass

import jax
import jax.numpy as jnp
import numpy as np

from ..assembly.system import System, constraint_jacobian, constraints, generalized_forces
from ..solvers.initial import mass_matrix
from .checks import check_linearize
from .placement import placed
from ..compile_cache import jit


@dataclass
class Modes:
    """Modal data, sorted by undamped frequency.

    frequencies : (m,) [Hz] undamped natural frequencies
    damped_frequencies : (m,) [Hz] imaginary part of the eigenvalue / 2π
    damping_ratios : (m,) [-]
    shapes : (nq, m) mode shapes in absolute coordinates (max |component| = 1)
    """

    frequencies: np.ndarray
    damped_frequencies: np.ndarray
    damping_ratios: np.ndarray
    shapes: np.ndarray

    def table(self):
        import pandas as pd

        return pd.DataFrame(
            {"mode": np.arange(1, len(self.frequencies) + 1), "f [Hz]": self.frequencies, "f_d [Hz]": self.damped_frequencies, "zeta [-]": self.damping_ratios}
        )


@dataclass
class LinearModel:
    """M ÿ + C ẏ + K y = 0 in independent coordinates y, with q − q0 ≈ N y.

    N : (nq, n) orthonormal basis of the constraint tangent space at q0 (null space of Φ_q).
    """

    M: np.ndarray
    C: np.ndarray
    K: np.ndarray
    N: np.ndarray
    q0: np.ndarray

    @property
    def state_matrix(self):
        n = self.M.shape[0]
        Minv = np.linalg.inv(self.M)
        return np.block([[np.zeros((n, n)), np.eye(n)], [-Minv @ self.K, -Minv @ self.C]])

    def modes(self) -> Modes:
        import scipy.linalg  # here, not at import proleg (0.6 s)

        w2, phi = scipy.linalg.eig(self.K, self.M)
        w2 = np.real(w2)
        order = np.argsort(w2)
        w2, phi = w2[order], np.real(phi[:, order])
        fn = np.sqrt(np.clip(w2, 0, None)) / (2 * np.pi)
        # Damped: eigenvalues of the first-order system, one per conjugate pair / real root.
        s = np.linalg.eigvals(self.state_matrix)
        wn = np.abs(s)
        zeta = np.where(wn > 0, -np.real(s) / np.where(wn > 0, wn, 1), 1.0)
        # Match each undamped mode to the eigenvalue with the closest |s| (upper half plane first).
        fd, zz = [], []
        used = np.zeros(len(s), bool)
        for f in fn:
            cand = np.where(~used & (np.imag(s) >= 0))[0]
            if len(cand) == 0:
                cand = np.where(~used)[0]
            k = cand[np.argmin(np.abs(wn[cand] - 2 * np.pi * f))]
            used[k] = True
            fd.append(abs(np.imag(s[k])) / (2 * np.pi))
            zz.append(zeta[k])
        shapes = self.N @ phi
        shapes = shapes / np.max(np.abs(shapes), axis=0, keepdims=True)
        return Modes(fn, np.array(fd), np.array(zz), shapes)


@jit
def _linear_pieces(system, q0, lam, t, z0):
    from ..solvers.driver import sample_controllers

    def f(q, v):
        _, vjp = jax.vjp(lambda qq: constraints(system, qq, t), q)
        z = sample_controllers(system, t, q, v, z0, True)
        return vjp(lam)[0] - generalized_forces(system, q, v, t, z)

    v0 = jnp.zeros_like(q0)
    K = jax.jacfwd(f, 0)(q0, v0)
    C = jax.jacfwd(f, 1)(q0, v0)
    M = mass_matrix(system, q0)
    Pq = constraint_jacobian(system, q0, t)
    return K, C, M, Pq


@placed
def linearize(system: System, state=None, t: float = 0.0) -> LinearModel:
    """Linear model about ``state`` (an :class:`Equilibrium`, or q with zero velocity).

    Controllers enter with their static law (sampled continuously at the state).

    K includes the geometric stiffness of the constraint reactions, (Φ_qᵀλ)_q.

    ``device``: where it runs; by default the CPU even where JAX's default device is a GPU
    (analyses/placement.py).
    """
    from .equilibrium import Equilibrium, solve_equilibrium

    check_linearize(system, state, t)
    if state is None:
        state = solve_equilibrium(system, t=t)
    if isinstance(state, Equilibrium):
        q0, lam, t = jnp.asarray(state.q), jnp.asarray(state.lam), state.t
    else:
        q0 = jnp.asarray(state)
        from ..solvers.initial import kkt_accelerations

        _, lam = kkt_accelerations(system, q0, jnp.zeros_like(q0), t)
    t = jnp.asarray(t, jnp.float64)
    v0 = jnp.zeros_like(q0)

    def f(q, v):
        _, vjp = jax.vjp(lambda qq: constraints(system, qq, t), q)
        from ..solvers.driver import sample_controllers
        from .simulate import initial_z

        z = sample_controllers(system, t, q, v, initial_z(system), True)
        return vjp(lam)[0] - generalized_forces(system, q, v, t, z)

    K = np.asarray(jax.jacfwd(f, 0)(q0, v0))
    C = np.asarray(jax.jacfwd(f, 1)(q0, v0))
    M = np.asarray(mass_matrix(system, q0))
    Pq = np.asarray(constraint_jacobian(system, q0, t))
    _, s, Vt = np.linalg.svd(Pq)
    rank = int(np.sum(s > 1e-10 * s[0]))
    N = Vt[rank:].T
    return LinearModel(N.T @ M @ N, N.T @ C @ N, N.T @ K @ N, N, np.asarray(q0))
