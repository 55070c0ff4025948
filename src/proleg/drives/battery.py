"""A battery shared by several DC motor drives (seed 003, §4.1, Eq. 9 with the total current).

Scout II runs its four hip motors from one pack: the terminal voltage sags with the *total*
current, ``V_s = V_nom − R_s Σ_k i_s,k`` (Eq. 9), and every drive's saturation (Eqs. 10–14)
depends on V_s. Each amplifier is a lossless PWM converter, so drive k draws
``i_s,k = P_el,k / V_s`` from the battery, with ``P_el,k = V_t,k i_k`` its motor terminal power
(:func:`proleg.drives.dcmotor.delivered_torque`). The terminal voltage is therefore the root of

    g(V) = V − V_nom + R_s Σ_k P_el,k(V) / V = 0,

where P_el,k(V) is drive k's power with its current clipped by the amplifier peak and by the
voltage limit at supply V. For a given set of regimes it is a quadratic: a drive in current
mode draws a fixed P = (R_a i + K_ω ω_m) i; a drive saturated at +V (ideal conductor, Fig. 8
right) has i = (V − K_ω ω_m)/R_a and P = V i, one saturated at −V has i = (−V − K_ω ω_m)/R_a
and P = −V i. With A = Σ_sat 1/R_a, B = Σ_+ K_ω ω_m/R_a − Σ_− K_ω ω_m/R_a and C = Σ_current P:

    (1 + R_s A) V² − (V_nom + R_s B) V + R_s C = 0,   V = its larger root.

The regimes are found by fixed-point iteration from V = V_nom (a few passes; each drive's
regime changes at most once as V moves towards its root), so everything is closed-form,
differentiable where the regimes are fixed, and costs a few dozen flops per drive (a
bisection loop inside every force evaluation cost more than the rest of the step).

With one drive this is the closed form of :func:`delivered_torque` with ``battery=True``
(tests/test_battery.py checks both).
"""

from __future__ import annotations


import jax.numpy as jnp

from .dcmotor import DCMotorDrive, _current

__all__ = ["shared_supply", "FIXED_POINT_PASSES"]

FIXED_POINT_PASSES = 4


def _quadratic_root(drives, i_cmd, motor_speed, V_nom, R_s, V):
    A = B = C = 0.0
    for k, d in enumerate(drives):
        e = d.K_omega * motor_speed[k]
        i_c = jnp.clip(i_cmd[k], -d.i_max, d.i_max)
        hi = i_c > (V - e) / d.R_a
        lo = i_c < (-V - e) / d.R_a
        sat = hi | lo
        A = A + jnp.where(sat, 1.0 / d.R_a, 0.0)
        B = B + jnp.where(hi, e / d.R_a, jnp.where(lo, -e / d.R_a, 0.0))
        C = C + jnp.where(sat, 0.0, (d.R_a * i_c + e) * i_c)
    a = 1.0 + R_s * A
    b = V_nom + R_s * B
    disc = b * b - 4.0 * a * R_s * C
    ok = disc > 0.0
    return jnp.where(ok, (b + jnp.sqrt(jnp.where(ok, disc, 1.0))) / (2.0 * a), 0.5 * b / a)


def shared_supply(drives: list[DCMotorDrive], tau_cmd, leg_speed, V_nom, R_s):
    """Terminal voltage [V] of a battery (V_nom behind R_s) feeding ``drives``.

    Parameters
    ----------
    drives : list of DCMotorDrive (static structure, array fields)
    tau_cmd : (n,) array [N m]       commanded leg torques, one per drive
    leg_speed : (n,) array [rad/s]   leg speeds φ̇ (motor speed / β)
    V_nom : float [V]                open-circuit voltage (seed 003: 37.17 V)
    R_s : float [Ω]                  series resistance (seed 003: 0.13 Ω)

    Returns
    -------
    V_s : Array [V], the common supply voltage; evaluate each drive with
    ``delivered_torque(drive, τ, φ̇, V=V_s)``.
    """


    tau_cmd, leg_speed = jnp.asarray(tau_cmd, jnp.float64), jnp.asarray(leg_speed, jnp.float64)
    i_cmd = jnp.stack([_current(d, tau_cmd[k], leg_speed[k]) for k, d in enumerate(drives)])
    w_m = jnp.stack([d.beta * leg_speed[k] for k, d in enumerate(drives)])
    V = jnp.asarray(V_nom, jnp.float64)
    for _ in range(FIXED_POINT_PASSES):
        V = _quadratic_root(drives, i_cmd, w_m, V_nom, R_s, V)
    return V
