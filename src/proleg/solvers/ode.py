"""High-order integrators for the joint-coordinate equations of motion (Diffrax).

In joint coordinates a tree without closed loops has no constraint but the normalization row
of each floating base, so its equations of motion are an ODE,

    ẋ = u,   M(x) u̇ = Q(x, u, t) − Φ_xᵀλ,   Φ_x u̇ = γ    (floating bases: pᵀp̈ = −ṗᵀṗ)

A closed loop (or a motion, a coupler) adds its rows to Φ: the same equations are then the
index-1 form of the DAE, whose position and velocity constraints drift by the integration
error (optionally held by Baumgarte's stabilization); the generalized-α/HHT path keeps them
exactly.

and the dissipated energy and input work are integrated with it (ẇ = powers). Diffrax's
explicit Tsit5 / Dopri5 (order 5, for non-stiff models) and its L-stable ESDIRK Kvaerno5
(order 5, for stiff bushings and contact) integrate y = (x, u, w) with a PID step-size
controller whose error norm covers positions AND velocities: rtol and atol apply to every
component (RMS norm of e_i / (atol + rtol |y_i|)).

Choosing values
---------------
``rtol`` = 1e-8 and ``atol`` = 1e-9 (defaults): on the undamped double pendulum the energy
error stays below 1e-6 of the largest kinetic energy over 10 s, and the IFToMM A01 pendulum
within 1e-3 m over 100 s (bench/accuracy.py). The local error of an order-5 pair falls as
h⁵, so the global error follows rtol: 1.2 decades per decade of rtol on Andrews' squeezer
between 1e-5 and 1e-9 (Tsit5; bench/README.md).
``pcoeff``/``icoeff`` = 0.0/1.0 is Diffrax's integral controller; (0.3, 0.4) is the
smoother PI setting Hairer recommends for stiff problems (Kvaerno5's default here).
"""

from __future__ import annotations

from dataclasses import dataclass

import jax
import jax.numpy as jnp


@dataclass(frozen=True)
class AbstractODEIntegrator:
    """An adaptive Diffrax solver for the joint-coordinate ODE (``simulate(integrator=...)``).

    Parameters
    ----------
    rtol, atol : relative and absolute local error tolerance on every state component
        (joint coordinates [rad or m], their rates [rad/s or m/s], energies [J])
    pcoeff, icoeff : PID controller coefficients (Diffrax ``PIDController``)
    max_steps : int, step limit of one run (SolverError beyond)
    stabilization : float [1/s], default 0 — Baumgarte rate s for closed loops: the
        acceleration-level constraint Φ̈ = 0 becomes Φ̈ + 2s Φ̇ + s² Φ = 0 (0: the plain index-1
        form, whose drift stays at the integration error over short runs, such as Andrews'
        squeezer's 0.03 s; simulate warns when |Φ| exceeds 1e-6)
    """

    rtol: float = 1e-8
    atol: float = 1e-9
    pcoeff: float = 0.0
    icoeff: float = 1.0
    max_steps: int = 1_000_000
    stabilization: float = 0.0
    order = 5
    ode = True  # simulate() dispatches on this (analyses/ode.py)

    def __post_init__(self):
        for name in ("rtol", "atol"):
            v = getattr(self, name)
            if not (v > 0):
                raise ValueError(f"{type(self).__name__} {name} must be > 0, got {v}.")

    def solver(self, fixed=False):
        raise NotImplementedError

    def controller(self, tol, dt_max=None, fixed=False):
        """Diffrax step-size controller; ``tol`` = (rtol, atol), arrays (traced: no recompile per tolerance)."""
        import diffrax

        if fixed:
            return diffrax.ConstantStepSize()
        return diffrax.PIDController(rtol=tol[0], atol=tol[1], pcoeff=self.pcoeff, icoeff=self.icoeff, dtmax=dt_max)

    @property
    def static(self):
        """The integrator with its tolerances replaced by 1: the hashable, compile-time part."""
        import dataclasses

        return dataclasses.replace(self, rtol=1.0, atol=1.0)

    @property
    def tol(self):
        return jnp.asarray(self.rtol, jnp.float64), jnp.asarray(self.atol, jnp.float64)


@dataclass(frozen=True)
class Tsit5(AbstractODEIntegrator):
    """Tsitouras' 5(4) explicit Runge–Kutta pair (Diffrax ``Tsit5``), for non-stiff models."""

    def solver(self, fixed=False):
        import diffrax

        return diffrax.Tsit5()


@dataclass(frozen=True)
class Dopri5(AbstractODEIntegrator):
    """Dormand–Prince 5(4) explicit Runge–Kutta pair (Diffrax ``Dopri5``; Exudyn's DOPRI5)."""

    def solver(self, fixed=False):
        import diffrax

        return diffrax.Dopri5()


@dataclass(frozen=True)
class Kvaerno5(AbstractODEIntegrator):
    """Kværnø's L-stable ESDIRK 5(4) (Diffrax ``Kvaerno5``), for stiff bushings and contact."""

    pcoeff: float = 0.3
    icoeff: float = 0.4

    def solver(self, fixed=False):
        """With fixed steps the Newton tolerances cannot come from the step controller: full Newton
        to 1e-11 (the chord iteration's divergence test trips on round-off at such tolerances)."""
        import diffrax

        if fixed:
            import optimistix

            return diffrax.Kvaerno5(root_finder=optimistix.Newton(rtol=1e-11, atol=1e-13), root_find_max_steps=40)
        return diffrax.Kvaerno5()


def accelerations(dyn, x, u, t, z, stabilization=0.0, MQ=None):
    """u̇ of the joint-coordinate ODE: M u̇ + Φ_xᵀλ = Q, Φ_x u̇ = γ (− 2s Φ̇ − s²Φ) (KKT); (nq,).
    Without constraints by Cholesky (M is symmetric positive definite): 1 µs against 7.5 µs for
    the LU of jnp.linalg.solve on the 8-link chain (bench/README.md, accuracy section)."""
    from .initial import gamma_rhs

    M, Q = (dyn.mass_matrix(x), dyn.generalized_forces(x, u, t, z)) if MQ is None else MQ
    if dyn.nc == 0:
        return jax.scipy.linalg.cho_solve(jax.scipy.linalg.cho_factor(M), Q)
    Pq = jax.jacfwd(lambda y: dyn.constraints(y, t))(x)
    nc = Pq.shape[0]
    S = jnp.block([[M, Pq.T], [Pq, jnp.zeros((nc, nc), x.dtype)]])
    g = gamma_rhs(dyn, x, u, t)
    if stabilization:
        phi, phid = jax.jvp(lambda s: dyn.constraints(x + s * u, t + s), (jnp.zeros((), x.dtype),), (jnp.ones((), x.dtype),))
        g = g - 2.0 * stabilization * phid - stabilization**2 * phi
    return jnp.linalg.solve(S, jnp.concatenate([Q, g]))[: x.shape[0]]


def vector_field(t, y, args):
    """Diffrax vector field of y = (x, u, w): (u, u̇, [dissipated, input] power)."""
    dyn, z, stabilization = args
    x, u, _ = y
    M, Q, pw = dyn.dynamics(x, u, t, z)  # one pass of kinematics (assembly/joint_coordinates.py)
    return u, accelerations(dyn, x, u, t, z, stabilization, (M, Q)), pw


def solve(integrator, dyn, y0, z, t0, t1, tol, ts=None, dt0=None, dt_max=None, fixed=False):
    """Integrate y0 from t0 to t1 with ``z`` held, tolerances ``tol`` = (rtol, atol); ``fixed``: constant
    steps dt0. The states at ``ts`` (or at t1). Returns (ys, accepted steps, rejected steps, ok)."""
    import diffrax

    saveat = diffrax.SaveAt(ts=ts) if ts is not None else diffrax.SaveAt(t1=True)
    sol = diffrax.diffeqsolve(
        diffrax.ODETerm(vector_field), integrator.solver(fixed), t0, t1, dt0, y0,
        args=(dyn, z, integrator.stabilization), saveat=saveat, stepsize_controller=integrator.controller(tol, dt_max, fixed),
        max_steps=integrator.max_steps, throw=False, adjoint=diffrax.ForwardMode(),
    )
    return sol.ys, sol.stats["num_accepted_steps"], sol.stats["num_rejected_steps"], sol.result == diffrax.RESULTS.successful
