"""Static equilibrium (Adams STATICS): Newton on Φ_qᵀλ − Q(q, 0, t) = 0, Φ(q, t) = 0."""

from __future__ import annotations

from dataclasses import dataclass

import jax
import jax.numpy as jnp
import numpy as np

from ..assembly.system import System, constraints, constraints_and_jacobian, generalized_forces, unconnected_parts
from ..errors import ConvergenceError, ModelError
from .checks import check_equilibrium
from .placement import placed
from ..compile_cache import jit


@dataclass
class Equilibrium:
    """A static equilibrium: coordinates ``q``, multipliers ``lam``, the final residual norms."""

    system: System
    q: np.ndarray
    lam: np.ndarray
    t: float
    force_residual: float  # max |Φ_qᵀλ − Q| [N or N m]
    constraint_residual: float  # max |Φ|
    iterations: int

    @property
    def v(self):
        return np.zeros_like(self.q)

    def result(self):
        """The equilibrium as a one-sample :class:`Result` (part poses, joint reactions, element forces)."""
        from .result import Result

        from ..solvers.driver import sample_controllers_first
        from .simulate import initial_z

        q = jnp.asarray(self.q)
        z = sample_controllers_first(self.system, self.t, q, jnp.zeros_like(q), initial_z(self.system))
        return Result(self.system, np.array([self.t]), q[None], jnp.zeros((1, self.q.size)), jnp.zeros((1, 2)), z[None], stats=None, message="equilibrium")

    def __repr__(self):
        return f"Equilibrium({self.system.topo.name!r}: {self.iterations} iterations, |F| = {self.force_residual:.2e}, |Φ| = {self.constraint_residual:.2e})"


def static_forces(system, q, t):
    """Q(q, 0, t) with sampled controllers evaluated continuously at q (their static law)."""
    from ..solvers.driver import sample_controllers
    from .simulate import initial_z

    v = jnp.zeros_like(q)
    z = sample_controllers(system, t, q, v, initial_z(system), True)
    return generalized_forces(system, q, v, t, z)


def _residual(system, x, t, nq):
    q, lam = x[:nq], x[nq:]
    phi, vjp = jax.vjp(lambda qq: constraints(system, qq, t), q)
    f = vjp(lam)[0] - static_forces(system, q, t)
    return jnp.concatenate([f, phi])


@jit
def _newton_pieces(system, x, t):
    nq = system.topo.nq
    r = _residual(system, x, t, nq)
    J = jax.jacfwd(lambda xx: _residual(system, xx, t, nq))(x)
    return r, J


@jit
def _res(system, x, t):
    return _residual(system, x, t, system.topo.nq)


def check_connected(system: System):
    """ModelError naming parts that neither a joint nor a force element connects to anything."""
    free = unconnected_parts(system.topo)
    if free:
        raise ModelError(
            f"Static equilibrium of '{system.topo.name}': part(s) {free} are connected to nothing (no joint, force "
            "element or contact), so they have no static equilibrium. Connect them or remove them."
        )


@jit
def _tangent_pieces(system, q, t):
    """Φ, Φ_q, generalized force Q(q, 0), and the stiffness ∂(Φ_qᵀλ − Q)/∂q with least-squares λ."""
    phi, Pq = constraints_and_jacobian(system, q, t)
    Q = static_forces(system, q, t)
    lam = jnp.linalg.lstsq(Pq.T, Q)[0]

    def f(qq):
        _, vjp = jax.vjp(lambda x: constraints(system, x, t), qq)
        return vjp(lam)[0] - static_forces(system, qq, t)

    return phi, Pq, Q, lam, jax.jacfwd(f)(q)


@placed
def solve_equilibrium(
    system: System, q_guess=None, t: float = 0.0, tol: float = 1e-10, max_iter: int = 200, stable: bool = True
) -> Equilibrium:
    """Static equilibrium from the modelled pose (or ``q_guess``).

    With ``stable=True`` (default) a saddle-free Newton iteration in the constraint tangent space
    (negative curvatures of the reduced stiffness flipped, steps capped) walks downhill to a
    stable equilibrium, as a physical settle would; ``stable=False`` runs plain Newton on the
    KKT equations, which converges to the nearest equilibrium, stable or not.

    Raises ModelError if the model is not statically determinate (free rigid motion: the
    stiffness restricted to the constraint tangent space is singular), naming the parts that move.

    ``device``: where it runs; by default the CPU even where JAX's default device is a GPU
    (analyses/placement.py).
    """
    from .simulate import consistent_state, initial_z

    check_equilibrium(system, q_guess, t, tol, max_iter)
    check_connected(system)
    q0, _, _, lam0, z0 = consistent_state(system, q_guess, None, t, initial_z(system))
    nq = system.topo.nq
    t = jnp.asarray(t, jnp.float64)
    scale = 1.0 + float(jnp.max(jnp.abs(system.params["body_mass"]))) * float(jnp.linalg.norm(system.params["gravity"]))
    q = q0
    it0 = 0
    if stable:
        q, it0 = _saddle_free(system, q, t, tol * scale, max_iter)
        _, _, _, lam0, _ = _tangent_pieces(system, q, t)
    x = jnp.concatenate([q, lam0])
    r, J = _newton_pieces(system, x, t)
    fr = float(jnp.max(jnp.abs(r[:nq])))
    cr = float(jnp.max(jnp.abs(r[nq:])))
    it = it0
    for it in range(it0 + 1, it0 + max_iter + 1):
        if fr < tol * scale and cr < tol and it > it0 + 1:
            break
        if not (np.all(np.isfinite(np.asarray(J))) and np.all(np.isfinite(np.asarray(r)))):
            _no_equilibrium(system, x[:nq], t, "the equations became NaN or inf", it)
        cond = np.linalg.cond(np.asarray(J))
        if np.isfinite(cond) and cond < 1e12:
            dx = jnp.linalg.solve(J, -r)
        else:  # singular at this pose (e.g. a flat spring): least-squares step
            dx = jnp.asarray(np.linalg.lstsq(np.asarray(J), -np.asarray(r), rcond=1e-12)[0])
        n0 = float(jnp.linalg.norm(r))
        alpha = 1.0
        for _ in range(30):
            x_try = x + alpha * dx
            r_try = _res(system, x_try, t)
            if bool(jnp.all(jnp.isfinite(r_try))) and float(jnp.linalg.norm(r_try)) < (1 - 1e-4 * alpha) * n0 + 1e-300:
                break
            alpha *= 0.5
        x = x_try
        r, J = _newton_pieces(system, x, t)
        fr = float(jnp.max(jnp.abs(r[:nq])))
        cr = float(jnp.max(jnp.abs(r[nq:])))
        # Stagnation at round-off (stiff bushings: |K| |q| ε exceeds tol): accept a tiny step.
        if float(jnp.max(jnp.abs(alpha * dx[:nq]))) < 1e-13 and fr < 1e-6 * scale and cr < tol:
            break
    else:
        Jn = np.asarray(J)
        singular = not np.all(np.isfinite(Jn)) or not np.linalg.cond(Jn) < 1e15
        _no_equilibrium(system, x[:nq], t, "Newton did not converge"
                        + ("; its Jacobian is singular: a motion that nothing resists" if singular else ""), it)
    cond = np.linalg.cond(np.asarray(J))
    if not np.isfinite(cond) or cond > 1e15:
        _explain_singular(system, np.asarray(J), nq)
    return Equilibrium(system, np.asarray(x[:nq]), np.asarray(x[nq:]), float(t), fr, cr, it)


@jit
def _project_step(system, q, t):
    from ..solvers.initial import _normalize_p

    phi, Pq = constraints_and_jacobian(system, q, t)
    return _normalize_p(q - jnp.linalg.lstsq(Pq, phi)[0], system.topo.nbody), jnp.max(jnp.abs(phi))


def _project(system, q, t, nb):
    """Back onto Φ(q, t) = 0 by minimum-norm Gauss-Newton steps."""
    for _ in range(20):
        q_new, res = _project_step(system, q, t)
        if float(res) < 1e-13:
            break
        q = q_new
    return q


def _saddle_free(system, q, t, ftol, max_iter, max_step=0.2):
    """Downhill Newton in the tangent space: K_r → |K_r| (eigenvalues), step norm ≤ max_step."""
    nb = system.topo.nbody
    it = 0
    for it in range(1, max_iter + 1):
        phi, Pq, Q, lam, K = (np.asarray(a) for a in _tangent_pieces(system, q, t))
        if not all(np.all(np.isfinite(a)) for a in (Pq, Q, K)):
            _no_equilibrium(system, q, t, "the equations became NaN or inf while walking downhill", it)
        _, s, Vt = np.linalg.svd(Pq)
        rank = int(np.sum(s > 1e-10 * s[0]))
        N = Vt[rank:].T
        g = -(N.T @ Q)  # gradient of the potential along the tangent directions
        if np.max(np.abs(Pq.T @ lam - Q)) < ftol:
            break
        Kr = N.T @ K @ N
        Kr = 0.5 * (Kr + Kr.T)
        w, V = np.linalg.eigh(Kr)
        wmax = max(np.max(np.abs(w)), 1e-300)
        w_mod = np.maximum(np.abs(w), 1e-8 * wmax)
        with np.errstate(over="ignore", invalid="ignore"):
            y = -V @ ((V.T @ g) / w_mod)
        nrm = np.linalg.norm(y)
        if not np.isfinite(nrm):  # no stiffness at all (free fall): step downhill along the load
            y, nrm = -g, max(np.linalg.norm(g), 1e-300)
            y, nrm = y * (max_step / nrm), max_step
        if nrm > max_step:
            y *= max_step / nrm
        q = _project(system, q + jnp.asarray(N @ y), t, nb)
        if nrm < 1e-12:
            break
    return q, it


def _explain_singular(system, J, nq):
    _, s, Vt = np.linalg.svd(J)
    null = Vt[-1, : 7 * system.topo.nbody].reshape(system.topo.nbody, 7)
    mag = np.linalg.norm(null, axis=1)
    moving = [system.topo.body_names[b] for b in np.argsort(-mag) if mag[b] > 0.1 * mag.max()]
    raise ModelError(
        f"Model '{system.topo.name}' is not statically determinate: free rigid motion involving part(s) "
        f"{moving} (no stiffness resists it). Add a joint, spring or contact that holds it, or simulate instead."
    )


def _no_equilibrium(system, q, t, why: str, iterations: int):
    """ConvergenceError naming the largest residual: the unbalanced force on a part (with the
    elements attached to it) or the violated constraint equation, at the last finite iterate."""
    topo = system.topo
    q = jnp.asarray(q)
    where, value = "unknown", float("nan")
    if bool(jnp.all(jnp.isfinite(q))):
        phi, Pq, Q, lam, _ = (np.asarray(a) for a in _tangent_pieces(system, q, t))
        f = Pq.T @ lam - Q
        nb = topo.nbody
        fb = np.abs(f[: 7 * nb].reshape(nb, 7)[:, :3])
        if np.all(np.isfinite(f)) and fb.size and fb.max() >= np.abs(phi).max(initial=0.0):
            b, k = np.unravel_index(int(np.argmax(fb)), fb.shape)
            value = float(fb[b, k])
            where = f"unbalanced force {value:.3g} N along {'xyz'[k]} on part '{topo.body_names[b]}'"
        elif np.all(np.isfinite(phi)) and phi.size:
            row = int(np.argmax(np.abs(phi)))
            value = float(abs(phi[row]))
            elem, lab = topo.ct.labels[row] if row < len(topo.ct.labels) else ("Euler parameters", "norm")
            where = f"constraint residual {value:.3g} in '{elem}' ({lab})"
    raise ConvergenceError(
        f"Static equilibrium of '{topo.name}': no equilibrium found ({why}, after {iterations} iterations); "
        f"worst residual: {where}. A part that can fall or slide without limit has none: add a spring, stop or "
        "contact, start closer (q_guess), or run a damped dynamic settle (simulate) instead."
    )
