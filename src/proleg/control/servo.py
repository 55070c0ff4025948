"""Stability of sampled PID servos (zero-order hold) on the joint they drive.

A PID sampled every T with zero-order hold, on a joint whose effective inertia is I (the
inverse of ∂θ̈/∂u, the joint's acceleration per unit command with every other joint free), is
a discrete loop: with a = kp·T²/I and b = kd·T/I (derivative on the measured rate), the closed
loop θ_{k+1} = θ_k + T θ̇_k + T²/(2I) u_k, θ̇_{k+1} = θ̇_k + T/I u_k, u_k = −kp θ_k − kd θ̇_k has
the characteristic polynomial z² − (2 − a/2 − b) z + (1 − b + a/2), and the Jury criterion
gives stability exactly when

    a/2 < b < 2,   i.e.   kp·T/2 < kd < 2·I/T.

Above the upper bound the servo rings at half the sample rate with a growing amplitude: the
command flips sign every sample, and an error-controlled integrator has to follow a motion that
changes direction every millisecond, with hundreds of steps per sample. Below the lower bound
(pure P control of an undamped joint) it grows slowly. The check uses the inertia at the
initial state, with the other joints free (the smallest inertia the servo can see, so it is
conservative), and ignores the integral term and joint friction. PIDs driving hydraulic
actuators with a valve lag are skipped (a different discrete model).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from ..assembly.extensions import ControllerGroup, joint_coordinate
from ..assembly.system import System, constraint_jacobian, generalized_forces, kinematics
from ..solvers.initial import mass_matrix
from ..compile_cache import jit


def _pids(system: System):
    """(controller group, its PIDs) of ``system``; (None, []) without PIDs."""
    for g in system.topo.extensions:
        if isinstance(g, ControllerGroup):
            pids = [e for e in g.elements if e.kind == "pid"]
            if pids:
                return g, pids
    return None, []


def _checked(g, pids):
    """PIDs this check covers: not those driving an actuator with a valve lag."""
    return [getattr(g.actuators.get(e.actuator_ref), "valve_time_constant", None) is None for e in pids]


@jit
def _command_gains(system: System, q, v, t, z):
    """∂θ̈_k/∂cmd_k for every PID k: the joint acceleration per unit actuator command."""
    g, pids = _pids(system)
    idx = np.array([g.out_index[e.actuator_ref] for e in pids])
    M = mass_matrix(system, q)
    Pq = constraint_jacobian(system, q, t)
    dQ = jax.jacfwd(lambda zz: generalized_forces(system, q, v, t, zz))(z)[:, idx]
    nq, nc = M.shape[0], Pq.shape[0]
    S = jnp.block([[M, Pq.T], [Pq, jnp.zeros((nc, nc))]])
    dqdd = jnp.linalg.solve(S, jnp.concatenate([dQ, jnp.zeros((nc, len(pids)))]))[:nq]
    def rate(vv):
        th, th_d, _, _ = joint_coordinate(g.pid_oh_i, g.pid_oh_j, g.pid_rot, kinematics(system, q, vv)[1])
        return th_d, th

    J, th = jax.jacfwd(rate, has_aux=True)(v)  # θ̇ is linear in v: θ̈ changes by J·Δq̈
    return jnp.sum(J * dqdd.T, 1), th


def servo_stability(system: System, q=None, v=None, t=0.0, z=None) -> list[dict]:
    """The sampled-loop stability of each PID at the state (q, v) (default: the consistent initial
    state): effective inertia, the discrete-loop numbers a = kp·T²/I and b = kd·T/I, the stable
    range of kd, and ``stable`` (a/2 < b < 2; module docstring). Units: the joint's own (N m,
    rad, kg m² for a rotation; N, m, kg for a translation)."""
    g, pids = _pids(system)
    if not any(_checked(g, pids)):
        return []
    if q is None or v is None or z is None:
        from ..solvers.initial import consistent_state, initial_z

        z = initial_z(system) if z is None else z
        q0, v0, _, _, z = consistent_state(system, q, v, t, z)
        q, v = q0, v0
    gains, th = _command_gains(system, jnp.asarray(q), jnp.asarray(v), jnp.asarray(t, jnp.float64), jnp.asarray(z))
    gains, th = np.asarray(gains), np.asarray(th)
    P = system.params
    out = []
    for k, (e, ok) in enumerate(zip(pids, _checked(g, pids))):
        if not ok:
            continue
        la = 1.0
        if e.lever_arm is not None:
            la = float(e.lever_arm(th[k])) if callable(e.lever_arm) else float(P["controller_lever_arm"][k])
        gain = gains[k] / la  # joint acceleration per unit PID output u
        if not gain > 0:
            continue  # the command does not move the joint (or pushes it backwards): not this check's case
        inertia = 1.0 / gain
        kp, kd, T = float(P["controller_kp"][k]), float(P["controller_kd"][k]), e.period
        a, b = kp * T * T / inertia, kd * T / inertia
        rot = e.dof == "rotation"
        out.append({
            "controller": e.name, "joint": e.joint.name, "period [s]": T, "kp": kp, "kd": kd,
            "effective inertia": float(inertia), "unit": "kg m^2" if rot else "kg",
            "a = kp T^2/I": float(a), "b = kd T/I": float(b),
            "kd min": kp * T / 2.0, "kd max": float(2.0 * inertia / T),
            "stable": bool(a / 2.0 < b < 2.0),
        })
    return out


def servo_warnings(rows) -> list[str]:
    """One sentence per unstable servo in ``rows`` (from :func:`servo_stability`), with the fix."""
    msgs = []
    for r in rows:
        if r["stable"]:
            continue
        T, I = r["period [s]"], r["effective inertia"]
        du = "N m s/rad" if r["unit"] == "kg m^2" else "N s/m"
        head = (
            f"PID '{r['controller']}' on joint '{r['joint']}' is unstable as sampled (every {T * 1e3:.3g} ms, zero-order "
            f"hold): effective inertia {I:.3g} {r['unit']} at the start"
        )
        if r["b = kd T/I"] >= 2.0:
            msgs.append(
                f"{head}, kd·T/I = {r['b = kd T/I']:.2f} >= 2, so the command flips sign every sample and the motion "
                f"rings at half the sample rate (the integrator then needs many tiny steps). Lower kd below "
                f"{r['kd max']:.3g} {du} (kd = {r['kd']:.3g}), or sample faster than every {2.0 * I / r['kd'] * 1e3:.3g} ms."
            )
        else:
            msgs.append(
                f"{head}, kd = {r['kd']:.3g} {du} is below kp·T/2 = {r['kd min']:.3g}: the held command lags and the "
                f"servo oscillates with a slowly growing amplitude. Raise kd above {r['kd min']:.3g} {du}, or add joint damping."
            )
    return msgs
