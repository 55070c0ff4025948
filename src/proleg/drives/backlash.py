"""Rotational compliance with backlash: the Scout II hip unit, Model II (seed 003, §4.2).

Seed 003 lumps gear backlash and belt stretch into one rotational spring-damper between the
driven gear and the leg (Fig. 10; Table 5: belt spring 7.0 N m/deg = 401 N m/rad, belt damper
4.0(e-?) N m s/deg, garbled; ≈ 8° combined backlash + stretch at full torque). These laws add
the dead band explicitly.

Convention (Adams I/J): θ = θ_I − θ_J is the twist of marker I (leg side) relative to marker J
(driven-gear side) about their common axis, θ̇ its rate; the returned torque acts on I, the
reaction −τ on J.

Hard law, total free play 2b (``half_gap`` = b)::

    |θ| ≤ b:   τ = 0
    |θ| > b:   τ = −k (θ − sign(θ) b) − c θ̇

The damping acts **only in contact** (|θ| > b): in the gap the two sides are free, so nothing
transmits torque, not even a viscous one. Consequences: the torque jumps by −c θ̇ at the instant
of contact (when θ̇ ≠ 0), and on separation the damper can briefly pull (τ of the "wrong" sign
while the spring is almost relaxed). Use :func:`backlash_torque_smooth` for a law an implicit
integrator handles better.
"""

from __future__ import annotations

import jax.numpy as jnp

from ..fn import step

__all__ = ["backlash_torque", "backlash_torque_smooth", "deadband", "deadband_smooth"]


def deadband(theta, half_gap):
    """Hard dead-band deflection δ = sign(θ) max(|θ| − b, 0) [rad]."""
    return jnp.sign(theta) * jnp.maximum(jnp.abs(theta) - half_gap, 0.0)


def backlash_torque(theta, theta_dot, stiffness, damping, half_gap):
    """Torque on I of a rotational spring-damper with a dead band of total width 2b.

    ``τ = −k (θ − sign(θ) b) − c θ̇`` for |θ| > b, and 0 for |θ| ≤ b (see module docstring).

    Parameters
    ----------
    theta : array_like [rad]            twist θ = θ_I − θ_J
    theta_dot : array_like [rad/s]      θ̇
    stiffness : array_like [N m/rad]    k (Scout II belt: 7.0 N m/deg = 401.07 N m/rad)
    damping : array_like [N m s/rad]    c, acts only in contact
    half_gap : array_like [rad]         b ≥ 0, half the total free play

    Returns
    -------
    Array [N m], torque on I.
    """
    contact = jnp.abs(theta) > half_gap
    tau = -stiffness * (theta - jnp.sign(theta) * half_gap) - damping * theta_dot
    return jnp.where(contact, tau, 0.0)


def deadband_smooth(theta, half_gap, width):
    """Smoothed dead-band deflection δ(θ) and contact gate s(θ) (both in [rad] resp. [-]).

    The contact gate is a cubic STEP of |θ| from 0 at b − w/2 to 1 at b + w/2; the deflection
    is its integral, ``δ = sign(θ) ∫_{b−w/2}^{|θ|} s``. By the symmetry of STEP about its
    midpoint, δ equals the hard δ = sign(θ)(|θ| − b) exactly for |θ| ≥ b + w/2 and 0 for
    |θ| ≤ b − w/2; in between δ = sign(θ) w (Δ³ − Δ⁴/2), Δ = (|θ| − b + w/2)/w. δ is C2, s is C1.

    Requires 0 < w ≤ 2b (otherwise there is no free zone left).
    """
    a = jnp.abs(theta)
    lo = half_gap - 0.5 * width
    d = jnp.clip((a - lo) / width, 0.0, 1.0)
    gate = step(a, lo, 0.0, half_gap + 0.5 * width, 1.0)
    inner = width * d**3 * (1.0 - 0.5 * d)
    mag = jnp.where(d >= 1.0, a - half_gap, inner)
    return jnp.sign(theta) * mag, gate


def backlash_torque_smooth(theta, theta_dot, stiffness, damping, half_gap, width):
    """Smooth backlash: ``τ = −k δ(θ) − c s(θ) θ̇`` with δ, s of :func:`deadband_smooth`.

    Identical to :func:`backlash_torque` outside the transition bands
    b − w/2 < |θ| < b + w/2; there the spring engages with a C2 deflection and the damper with a
    C1 gate, so the torque is continuous (no jump at contact) and differentiable.
    As with the hard law, damping acts only in contact.

    Parameters
    ----------
    theta, theta_dot, stiffness, damping, half_gap : as :func:`backlash_torque`
    width : array_like [rad]   regularisation width w, 0 < w ≤ 2b.
        Choosing values: a few percent of b (e.g. b/20); a smaller w is closer to the hard law
        but stiffer for the integrator (the contact stiffness rises from 0 to k over w).
    """
    delta, gate = deadband_smooth(theta, half_gap, width)
    return -stiffness * delta - damping * gate * theta_dot
