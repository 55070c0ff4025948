"""Joint space ↔ proleg's absolute coordinates for a model imported from URDF.

proleg integrates absolute coordinates (COM position and Euler parameters per part, an index-3
DAE); robotics tools (Pinocchio, controllers, URDF) speak joint space: a floating base pose
and velocity plus one coordinate per joint. :func:`joint_space_state` maps a joint-space state,
in Pinocchio's free-flyer convention, to the consistent absolute (q, v, q̈), and
:func:`joint_space_jacobian` gives J = ∂v/∂ν, so that the joint-space mass matrix is Jᵀ M J.
:func:`set_initial_velocity` (also ``load_urdf(initial_velocities=..., base_velocity=...)``)
gives a loaded model initial joint rates and a base twist through the same map.

Conventions (Pinocchio's ``JointModelFreeFlyer``): base pose = root-link frame origin in ground
and its orientation (unit quaternion, **scalar first** here); base velocity ν_b = (v, ω) of the
root-link frame origin in root-link axes (v = Rᵀ ṗ); base acceleration = d ν_b / dt. Joint
coordinates in ``model.urdf.joints`` order, URDF sign and zero.

How: a curve through the state, x(t) = exp(ν t + a t²/2) applied to the base and
q_j + v_j t + a_j t²/2 to the joints, is pushed through the forward kinematics (JAX) and
differentiated twice at t = 0 (nested ``jvp``). The base exponential is used to second order
(quaternion (1 − |φ|²/8, φ/2), translation ν + φ × ν / 2), exact for the first two derivatives.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from ..errors import ModelError


def _qmul(a, b):
    a0, av = a[0], a[1:]
    b0, bv = b[0], b[1:]
    return jnp.concatenate([jnp.array([a0 * b0 - av @ bv]), a0 * bv + b0 * av + jnp.cross(av, bv)])


def _A(p):
    from ..spatial.rotation import A_of_p

    return A_of_p(p)


def _info(model):
    info = getattr(model, "urdf", None)
    if info is None:
        raise ModelError(f"Model '{model.name}' was not imported with proleg.io.load_urdf (it has no .urdf information).")
    for ln, _, jn, typ, _, _ in info.tree[1:]:
        if typ not in ("revolute", "continuous", "prismatic", "fixed"):
            raise ModelError(f"joint '{jn}' ({typ}): the joint-space map supports revolute, continuous, prismatic and fixed joints.")
    return info


def forward_kinematics(model, base_position, base_quaternion, qj):
    """Absolute coordinates q (nq,) of ``model``'s parts from a base pose and joint coordinates (JAX)."""
    from ..spatial.rotation import p_from_matrix

    info = _info(model)
    jidx = {name: k for k, name in enumerate(info.joint_names())}
    pos, quat = {}, {}
    root = info.tree[0][0]
    if info.base is None:
        pos[root] = jnp.asarray(info.base_pose[:3, 3])
        quat[root] = jnp.asarray(p_from_matrix(info.base_pose[:3, :3]))
    else:
        pos[root], quat[root] = base_position, base_quaternion
    for ln, parent, jn, typ, O, axis in info.tree[1:]:
        pj = pos[parent] + _A(quat[parent]) @ jnp.asarray(O[:3, 3])
        qjnt = _qmul(quat[parent], jnp.asarray(p_from_matrix(O[:3, :3])))
        if typ in ("revolute", "continuous"):
            th = qj[jidx[jn]]
            quat[ln] = _qmul(qjnt, jnp.concatenate([jnp.cos(th / 2)[None], jnp.sin(th / 2) * jnp.asarray(axis)]))
            pos[ln] = pj
        elif typ == "prismatic":
            quat[ln] = qjnt
            pos[ln] = pj + _A(qjnt) @ (jnp.asarray(axis) * qj[jidx[jn]])
        else:
            quat[ln], pos[ln] = qjnt, pj
    out = []
    for part in model.parts:
        g = part.name
        com = -np.asarray(info.link_frame[g])[:3, 3]
        out.append(jnp.concatenate([pos[g] + _A(quat[g]) @ jnp.asarray(com), quat[g]]))
    return jnp.concatenate(out)


def _curve(model, base_position, base_quaternion, qj, nu, vj, ab, aj):
    def q_of_t(t):
        phi = nu[3:] * t + ab[3:] * t**2 / 2
        lin = nu[:3] * t + ab[:3] * t**2 / 2
        dq = jnp.concatenate([jnp.array([1.0 - phi @ phi / 8]), phi / 2])
        bq = _qmul(base_quaternion, dq)
        bp = base_position + _A(base_quaternion) @ (lin + 0.5 * jnp.cross(phi, lin))
        return forward_kinematics(model, bp, bq, qj + vj * t + aj * t**2 / 2)

    return q_of_t


def joint_space_state(model, qj, vj=None, aj=None, *, base_position=None, base_quaternion=None, base_velocity=None, base_acceleration=None):
    """Absolute (q, v, q̈) of a joint-space state (see the module docstring for conventions).

    Parameters
    ----------
    qj, vj, aj : (nj,) joint positions [rad|m], rates, accelerations in ``model.urdf.joints`` order
    base_position : (3,) [m]; base_quaternion : (4,) scalar first (default: the modelled pose)
    base_velocity, base_acceleration : (6,) [m/s, rad/s] and their time derivative, root-link axes

    Returns
    -------
    q, v, qdd : jax arrays (nq,)
    """
    from ..spatial.rotation import p_from_matrix

    info = _info(model)
    nj = len(info.joints)
    qj = jnp.asarray(qj, float)
    vj = jnp.zeros(nj) if vj is None else jnp.asarray(vj, float)
    aj = jnp.zeros(nj) if aj is None else jnp.asarray(aj, float)
    bp = jnp.asarray(info.base_pose[:3, 3] if base_position is None else base_position, float)
    bq = jnp.asarray(p_from_matrix(info.base_pose[:3, :3]) if base_quaternion is None else base_quaternion, float)
    nu = jnp.zeros(6) if base_velocity is None or info.base is None else jnp.asarray(base_velocity, float)
    ab = jnp.zeros(6) if base_acceleration is None or info.base is None else jnp.asarray(base_acceleration, float)
    f = _curve(model, bp, bq, qj, nu, vj, ab, aj)
    df = lambda t: jax.jvp(f, (t,), (jnp.ones(()),))[1]
    q, v = jax.jvp(f, (jnp.zeros(()),), (jnp.ones(()),))
    qdd = jax.jvp(df, (jnp.zeros(()),), (jnp.ones(()),))[1]
    return q, v, qdd


def joint_space_jacobian(model, qj, *, base_position=None, base_quaternion=None):
    """J = ∂v/∂ν (nq, 6 + nj) (floating base) or (nq, nj) (welded): absolute velocities from the
    joint-space velocity ν = (base twist in root-link axes, joint rates)."""
    info = _info(model)
    nj = len(info.joints)
    nb = 6 if info.base is not None else 0

    def v_of(nu):
        base = nu[:nb] if nb else None
        return joint_space_state(model, qj, nu[nb:], base_position=base_position, base_quaternion=base_quaternion, base_velocity=base)[1]

    return jax.jacfwd(v_of)(jnp.zeros(nb + nj))


def set_initial_velocity(model, joint_rates=None, base_velocity=None):
    """Give a URDF model (from :func:`proleg.io.load_urdf`) initial joint rates and a base twist.

    Writes the consistent velocity of every part (``part.velocity``, ``part.angular_velocity``)
    at the modelled pose, so ``simulate`` starts from them; joints not named keep rate 0.

    Parameters
    ----------
    model : Model from ``load_urdf`` (positions are the modelled pose; set them with
        ``load_urdf(initial_positions=...)``)
    joint_rates : dict joint name → rate [rad/s or m/s], URDF sign
    base_velocity : (6,) [m/s ×3, rad/s ×3], the floating base's twist (v, ω): velocity of the
        root-link frame origin and angular velocity, both in root-link axes (Pinocchio's
        free-flyer convention; at the default base orientation the root-link axes are the
        ground axes). Ignored (must be None or zero) on a welded base.

    Returns
    -------
    model (changed in place)
    """
    from ..model._validate import finite_array, finite_scalar
    from ..spatial.rotation import G_of_p

    info = _info(model)
    names = info.joint_names()
    vj = np.zeros(len(names))
    for k, val in (joint_rates or {}).items():
        if k not in names:
            raise ModelError(
                f"initial joint rates: '{k}' is not a moving joint of model '{model.name}'. Known: {names}"
            )
        vj[names.index(k)] = finite_scalar(f"joint rate '{k}'", val, unit="rad/s or m/s")
    nu = None
    if base_velocity is not None:
        nu = finite_array("base_velocity (v, ω) [m/s, rad/s]", base_velocity, (6,))
        if info.base is None and np.any(nu != 0):
            raise ModelError(
                f"base_velocity: model '{model.name}' has a welded base (load_urdf(floating_base=False)); "
                "it cannot move. Load it with a floating base, or leave base_velocity out."
            )
    qj = np.array([info.initial_positions.get(n, 0.0) for n in names])
    _, v, _ = joint_space_state(model, qj, vj, base_velocity=nu)
    v = np.asarray(v)
    q = np.asarray(forward_kinematics(model, jnp.asarray(info.base_pose[:3, 3]), jnp.asarray(_p_of(info.base_pose)), jnp.asarray(qj)))
    for k, part in enumerate(model.parts):
        pdot = v[7 * k + 3 : 7 * k + 7]
        p = q[7 * k + 3 : 7 * k + 7]
        part.velocity = v[7 * k : 7 * k + 3].copy()
        part.angular_velocity = 2.0 * np.asarray(G_of_p(p)) @ pdot
    return model


def _p_of(X):
    from ..spatial.rotation import p_from_matrix

    return p_from_matrix(X[:3, :3])
