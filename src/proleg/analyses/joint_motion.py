"""Joint coordinates, rates and accelerations of a :class:`~proleg.analyses.result.Result`.

For a joint (or motion, or coupler) between markers I and J — the Adams convention: I relative
to J, about or along z_J — with d = r_I − r_J and ż_J = ω_J × z_J:

===========================  ================================================================
angle θ [rad]                atan2(x_I·y_J, x_I·x_J)   (zero at the modelled pose, in (−π, π])
angular_velocity θ̇ [rad/s]   z_J·(ω_I − ω_J)
angular_acceleration [rad/s²] z_J·(α_I − α_J) + (ω_J × z_J)·(ω_I − ω_J)
translation x [m]            z_J·d
velocity ẋ [m/s]             z_J·(v_I − v_J) + (ω_J × z_J)·d
acceleration ẍ [m/s²]        z_J·(a_I − a_J) + 2 (ω_J × z_J)·(v_I − v_J)
                             + (α_J × z_J + ω_J × (ω_J × z_J))·d
===========================  ================================================================

Each rate is the exact time derivative of the line above it. The parts' accelerations a and α
are those of the equations of motion at each output (the KKT solve of the post-processing,
:attr:`Result.qdd`), not differences of outputs, so a joint's acceleration is as accurate as
its rate and does not depend on the output spacing.

On a concrete result everything is NumPy from the stored q, v and the post-processing's q̈ (no
compilation here) when the markers are on rigid parts; a marker on a flexible part moves with
the modes, and its acceleration comes from forward-mode differentiation of the compiled marker
kinematics along (q̇, q̈) = (v, q̈).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from ..assembly.system import kinematics
from ..compile_cache import jit

#: the output names of :func:`joint_motion`, with their units
QUANTITIES = {
    "angle": "rad", "angular_velocity": "rad/s", "angular_acceleration": "rad/s²",
    "translation": "m", "velocity": "m/s", "acceleration": "m/s²",
}


def _xp(*xs):
    return jnp if any(isinstance(x, jax.core.Tracer) for x in xs) else np


def _marker_rates(system, q, v, qdd):
    """Marker kinematics at (q, v) and its time derivative along (q̇, v̇) = (v, q̈)."""
    return jax.jvp(lambda qq, vv: kinematics(system, qq, vv)[1], (q, v), (v, qdd))


_marker_rates_batch = jit(jax.vmap(_marker_rates, in_axes=(None, 0, 0, 0)))


def marker_histories(result, markers) -> dict:
    """{marker index: (r, R, v, ω, a, α)} in ground components, (n, 3) and R (n, 3, 3), for the
    markers with indices ``markers`` of ``result``'s model."""
    system = result.system
    topo = system.topo
    nb = topo.nbody
    markers = sorted({int(m) for m in markers})
    if not markers:
        return {}
    flexible = {k for k, p in enumerate(getattr(topo.model, "parts", []) or []) if getattr(p, "is_flexible", False)}
    if any(int(topo.marker_body[m]) in flexible for m in markers):
        mk, dmk = _marker_rates_batch(system, result.q, result.v, jnp.asarray(result.qdd))
        xp = _xp(mk.r)
        cv = (lambda x: x) if xp is jnp else np.asarray
        return {m: tuple(cv(x[:, m]) for x in (mk.r, mk.R, mk.v, mk.w, dmk.v, dmk.w)) for m in markers}
    S, C = system.params["marker_s"], system.params["marker_C"]
    xp = _xp(result.q, S, C)
    S, C = (xp.asarray(x) for x in (S, C))
    n = len(result.t)
    parts, out = {}, {}
    for m in markers:
        b = int(topo.marker_body[m])
        if b >= nb:  # ground
            z3 = xp.zeros((n, 3))
            out[m] = (xp.broadcast_to(S[m], (n, 3)), xp.broadcast_to(C[m], (n, 3, 3)), z3, z3, z3, z3)
            continue
        if b not in parts:
            parts[b] = result.part(topo.body_names[b])
        pr = parts[b]
        A = xp.asarray(pr.orientation)
        s = A @ S[m]
        w, al = xp.asarray(pr.angular_velocity), xp.asarray(pr.angular_acceleration)
        acc = xp.asarray(pr.acceleration) + xp.cross(al, s) + xp.cross(w, xp.cross(w, s))
        out[m] = (pr.position + s, A @ C[m], pr.velocity + xp.cross(w, s), w, acc, al)
    return out


def joint_motion(kin_i, kin_j) -> dict:
    """The six quantities of the module table from the histories (r, R, v, ω, a, α) of marker
    I and marker J (as :func:`marker_histories` gives them); (n,) arrays."""
    (rI, RI, vI, wI, aI, alI), (rJ, RJ, vJ, wJ, aJ, alJ) = kin_i, kin_j
    xp = _xp(rI, rJ, RI, RJ, aI, aJ)
    dot = lambda a, b: xp.sum(a * b, -1)  # noqa: E731
    zJ, xI = RJ[:, :, 2], RI[:, :, 0]
    zJd = xp.cross(wJ, zJ)  # ż_J
    zJdd = xp.cross(alJ, zJ) + xp.cross(wJ, zJd)  # z̈_J
    d, dd, ddd = rI - rJ, vI - vJ, aI - aJ
    return {
        "angle": xp.arctan2(dot(xI, RJ[:, :, 1]), dot(xI, RJ[:, :, 0])),
        "angular_velocity": dot(zJ, wI - wJ),
        "angular_acceleration": dot(zJ, alI - alJ) + dot(zJd, wI - wJ),
        "translation": dot(zJ, d),
        "velocity": dot(zJ, dd) + dot(zJd, d),
        "acceleration": dot(zJ, ddd) + 2.0 * dot(zJd, dd) + dot(zJdd, d),
    }
