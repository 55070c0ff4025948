"""Hydraulic joint drives as sampled elements: chamber pressures, spool and the pressure force loop.

:func:`hydraulic_servo` builds one :class:`proleg.DiscreteController` that owns n valve-controlled
cylinders (:mod:`proleg.drives.hydraulics`), each mounted on a joint through its lever geometry
(piston position x(θ) and transmission dx/dθ), and runs, at every sample of ``period``:

1. the hydraulics over the last interval: the spool under the held valve command and the two
   chamber pressures while the piston moved from x(θ_{n−1}) to x(θ_n) (the mechanism's actual
   motion; ``substeps`` implicit steps, :func:`proleg.drives.hydraulics.integrate_chambers`);
2. the outer joint-level law (PD / impedance, or any ``reference(t, state)``) at its own rate
   ``outer_period`` (a multiple of ``period``), held in between: the torque reference τ_ref;
3. HyQ's inner force loop on the measured pressures (Boaventura et al., "Dynamic torque control
   of a hydraulic quadruped robot", ICRA 2012: a force loop on the load pressure with velocity
   compensation): F_ref = τ_ref / (dx/dθ), F = p_A A_A − p_B A_B and the valve command

       u = k_F (F_ref − F) / F_max + k_v sign(ẋ) u_ss(ẋ, F_ref),    clipped to [−1, 1]

   (F_max = p_s A_A; ẋ = dx/dθ · θ̇ from the joint encoder rate). The velocity compensation
   u_ss is the opening that passes the flow the motion needs *at the demanded load*: the steady
   orifice law of the valve and the asymmetric cylinder inverted,
   :func:`proleg.drives.hydraulics.required_opening` (``compensation="load"``, the default).
   ``compensation="half_supply"`` is the linearised form u_ss = A |ẋ| / (K_v √(p_s/2)) (A = A_A
   extending, A_B retracting: the flow at a half-supply drop); it is exact only where the load
   pressure is p_s/2, so a piston that moves under load (a stance leg sweeping back) leaves the
   proportional loop a steady force error (k_F/F_max)⁻¹ × the opening mismatch: 10-15 N m at
   HyQ's HFE in a 1 m/s trot, measured (issue 33), which the load form removes. F_ref is first clipped to
   the cylinder's static capacity [−(p_s − p_t) A_B, (p_s − p_t) A_A]: the loop never asks for
   more than the supply can hold (the relief valves and the cavitation floor of
   :mod:`proleg.drives.hydraulics` bound what a load can still impose).

The rod force F(p_n) is held until the next sample, applied to the joint as the torque
F · dx/dθ(θ_n) through an actuator the controller drives (a :class:`proleg.JointActuator` on the
joint; for a prismatic piston the force itself). This is a staggered (co-simulation) coupling:
the mechanism is integrated by the error-controlled implicit integrator under a held force, the
oil by the element's own implicit sub-steps under the mechanism's motion; mass is conserved
exactly, and the coupling is stable while the oil-column mode ω_h = √(k_h (dx/dθ)²/I) satisfies
ω_h T < 2 (symplectic-Euler bound of the held force; HyQ's knee: k_h ≈ 8e6 N/m, I ≈ 0.03 kg m²,
ω_h ≈ 680 rad/s at 1 kHz → 0.68).

Seal friction and end-of-stroke stops are continuous joint forces the builders add (they act
within a sample and would chatter if held).

State (``result.controller(name).state``; :func:`hydraulic_outputs` names the columns).
"""

from __future__ import annotations

import dataclasses

import jax.numpy as jnp
import numpy as np

from ..drives import hydraulics as H
from ..errors import ModelError
from ..model.control import DiscreteController

#: Names of the z blocks (each n wide) of a hydraulic servo, in order.
FIELDS = (
    "pressure_a", "pressure_b", "valve_position", "valve_rate", "piston_position", "valve_command", "torque_reference",
    "energy_drawn", "energy_valve_loss", "energy_leakage", "energy_port", "work_oil_on_piston", "work_on_joint",
    "mass_flow_a", "mass_flow_b", "flow_a", "flow_b", "supply_flow", "hydraulic_power", "valve_loss_power", "force",
    "joint_coordinate", "measured_force", "oil_a", "oil_b", "energy_relief", "relief_flow",
)
_I = {k: i for i, k in enumerate(FIELDS)}


def _translation_rate(state, joint):
    """d/dt of the joint translation along z_J [m/s] (marker J's rotation neglected: the piston
    test rigs slide on ground)."""
    i, j = state._joint_markers(joint)
    return jnp.dot(state._mk.R[j][:, 2], state._mk.v[i] - state._mk.v[j])


def pd_reference(joints, setpoint, kp, kd, feedforward=None):
    """Joint PD / impedance law for :func:`hydraulic_servo`: τ_ref = τ_ff + kp (θ_d − θ) + kd (θ̇_d − θ̇).

    ``setpoint``: (n,) array [rad] or a function t → (θ_d, θ̇_d); ``feedforward`` t, state → (n,) [N m].
    """
    kp, kd = jnp.asarray(kp, jnp.float64), jnp.asarray(kd, jnp.float64)

    def law(t, state, th, thd):
        if callable(setpoint):
            sp, spd = setpoint(t)
        else:
            sp, spd = jnp.asarray(setpoint, jnp.float64), 0.0
        tau = kp * (sp - th) + kd * (spd - thd)
        if feedforward is not None:
            tau = tau + feedforward(t, state)
        return tau

    return law


def hydraulic_servo(
    name, joints, actuators, piston, *, cylinder=None, valve=None, supply=None, reference=None,
    period=1e-3, outer_period=None, substeps=8, force_gain=0.4, velocity_gain=1.0, translation=False,
    initial_force=None, x0=None, valve_command=None, relief=None, compensation="load", variables=None,
):
    """One sampled controller owning the cylinders of ``joints`` (module docstring).

    Parameters
    ----------
    name : str
    joints : list of n joint names (Revolute: coordinate θ [rad]; with ``translation=True`` a
        Prismatic/Cylindrical joint whose translation is the piston coordinate)
    actuators : list of n actuator names receiving the held torque (or force)
    piston : function θ (n,) → (x (n,) [m], dx/dθ (n,) [m/rad or -]): the lever geometry
    cylinder, valve, supply, relief : :class:`~proleg.drives.hydraulics.Cylinder`, ``ServoValve``,
        ``Supply``, ``ReliefValve`` (defaults: HyQ's actuator class, see their docstrings; the
        cylinder carries the cavitation floor, the relief valves guard each chamber)
    reference : function (t, state, θ, θ̇) → τ_ref (n,) [N m or N], the outer joint law
        (:func:`pd_reference`); None: zero torque
    period : float [s], the inner force loop and valve command (HyQ: 1 kHz)
    outer_period : float [s], the outer law's sample period (a multiple of ``period``; default ``period``)
    substeps : int, implicit oil sub-steps per period (8: h = 125 µs for 1 kHz, below the 640 µs
        spool time constant)
    force_gain : float [-], k_F (default 0.4). Choosing values: the blocked-cylinder loop crosses
        over at ω_c = k_F β K_v (A_A √(p_s − p_A)/V_A + A_B √p_B/V_B)/F_max ≈ k_F · 1000 rad/s
        for the defaults at mid stroke; with the 1 ms sample and the 0.64 ms spool lag, k_F = 1
        overshoots a force step by ~40 %, 0.4 (≈ 65 Hz) stays within 15 %.
    velocity_gain : float [-], k_v (default 1: the full flow compensation; 0 disables it)
    compensation : "load" (default) or "half_supply": the velocity compensation law (module docstring)
    initial_force : (n,) [N], rod forces at t = 0 (sets the initial pressures, default 0)
    x0 : (n,) initial joint coordinates (default: read at the first sample)
    valve_command : function t → (n,) spool command in [−1, 1], replacing the force loop (open
        loop: valve tests)
    variables : dict, optional, {"supply_pressure": name, "valve_flow": name}: read the supply
        pressure p_s [Pa] and the valve's rated flow Q_N [m³/s] from the model's design variables
        ``name`` (``model.add_variable``; ``state.variable``) in place of ``supply.pressure`` and
        ``valve.rated_flow``, so that variants (a larger supply, a larger valve) share one
        compiled simulation (``system.with_params``, a vmapped study). The initial pressures
        still come from ``supply``.
    """
    cyl = cylinder or H.Cylinder()
    val = valve or H.ServoValve()
    sup = supply or H.Supply()
    rel = relief or H.ReliefValve()
    if compensation not in ("load", "half_supply"):
        raise ModelError(f"hydraulic_servo '{name}': compensation must be 'load' or 'half_supply', got {compensation!r}.")
    if not rel.cracking_ratio > 1.0:
        raise ModelError(f"hydraulic_servo '{name}': relief cracking_ratio {rel.cracking_ratio} must exceed 1 (the relief setting is "
                         "above the supply pressure, else it bleeds the supply in normal operation); pass ReliefValve(cracking_ratio=1.1).")
    if not cyl.cavitation_pressure < sup.pressure:
        raise ModelError(f"hydraulic_servo '{name}': cylinder cavitation_pressure {cyl.cavitation_pressure} Pa must be below the supply "
                         f"{sup.pressure} Pa (gauge; default 0).")
    joints, actuators = list(joints), list(actuators)
    n = len(joints)
    if n == 0 or len(actuators) != n:
        raise ModelError(f"hydraulic_servo '{name}': give one actuator per joint; got {n} joints and {len(actuators)} actuators.")
    if not period > 0:
        raise ModelError(f"hydraulic_servo '{name}': period must be positive [s], got {period}.")
    outer = period if outer_period is None else float(outer_period)
    ratio = outer / period
    if abs(ratio - round(ratio)) > 1e-9 or ratio < 1:
        raise ModelError(f"hydraulic_servo '{name}': outer_period {outer} s must be a whole multiple of period {period} s.")
    if not (0 < sup.tank < sup.pressure or sup.tank == 0.0 and sup.pressure > 0):
        raise ModelError(f"hydraulic_servo '{name}': supply pressure {sup.pressure} Pa must exceed the tank pressure {sup.tank} Pa.")
    aa, ab = cyl.area_a, cyl.area_b
    ps = sup.pressure
    f_max = ps * aa
    f_max_ext, f_max_ret = (ps - sup.tank) * aa, (ps - sup.tank) * ab
    # initial pressures: the rod force F0 with p_A at mid supply (the null valve holds any pair)
    f0 = np.zeros(n) if initial_force is None else np.broadcast_to(np.asarray(initial_force, float), (n,))
    pa0 = np.clip(0.5 * ps + 0.5 * f0 / aa, 0.05 * ps, 0.95 * ps)
    pb0 = (pa0 * aa - f0) / ab
    z0 = np.zeros((len(FIELDS), n))
    z0[_I["pressure_a"]], z0[_I["pressure_b"]] = pa0, pb0
    z0[_I["oil_a"]], z0[_I["oil_b"]] = np.asarray(H.oil_state(cyl, pa0)), np.asarray(H.oil_state(cyl, pb0))
    if x0 is not None:
        xs, _ = piston(jnp.asarray(np.broadcast_to(np.asarray(x0, float), (n,))))
        z0[_I["piston_position"]] = np.asarray(xs)
        z0[_I["joint_coordinate"]] = np.asarray(x0, float)
    z0[_I["force"]] = f0

    def coords(state):
        if translation:
            th = jnp.stack([state.joint_translation(j) for j in joints])
            return th, jnp.stack([_translation_rate(state, j) for j in joints])
        return jnp.stack([state.joint_angle(j) for j in joints]), jnp.stack([state.joint_rate(j) for j in joints])

    live = dict(variables or {})
    unknown = set(live) - {"supply_pressure", "valve_flow"}
    if unknown:
        raise ModelError(f"hydraulic_servo '{name}': variables takes 'supply_pressure' and 'valve_flow', got {sorted(unknown)}.")

    def parts(state):
        """(valve, supply, F_max, F_ext, F_ret): the build-time ones, or those of the variables."""
        if not live:
            return val, sup, f_max, f_max_ext, f_max_ret
        s_, v_ = sup, val
        if "supply_pressure" in live:
            s_ = dataclasses.replace(sup, pressure=state.variable(live["supply_pressure"]))
        if "valve_flow" in live:
            v_ = dataclasses.replace(val, rated_flow=state.variable(live["valve_flow"]))
        return v_, s_, s_.pressure * aa, (s_.pressure - s_.tank) * aa, (s_.pressure - s_.tank) * ab

    def update(t, state, z):
        val, sup, f_max, f_max_ext, f_max_ret = parts(state)
        ps, kv = sup.pressure, val.flow_gain
        Z = jnp.reshape(z, (len(FIELDS), n))
        g = lambda k: Z[_I[k]]  # noqa: E731
        th, thd = coords(state)
        x, dxdth = piston(th)
        first = t < 0.5 * period
        x_prev = jnp.where(first, x, g("piston_position"))
        th_prev = jnp.where(first, th, g("joint_coordinate"))
        ya, yb, xv, vv, acc = H.integrate_chambers(cyl, val, sup, g("oil_a"), g("oil_b"), g("valve_position"), g("valve_rate"),
                                                   g("valve_command"), x_prev, x, period, substeps, relief=rel)
        pa, pb = acc["pa"], acc["pb"]
        F = H.cylinder_force(cyl, pa, pb)
        tick = first | (jnp.abs(t / outer - jnp.round(t / outer)) < 1e-7)
        tau_ref = g("torque_reference")
        if reference is not None:
            tau_ref = jnp.where(tick, jnp.asarray(reference(t, state, th, thd), jnp.float64) * jnp.ones(n), tau_ref)
        # the loop never demands more than the supply can hold: F within [−(p_s − p_t) A_B, (p_s − p_t) A_A]
        # (one chamber at supply, the other at tank: the actuator's static force capacity)
        f_ref = jnp.clip(tau_ref / dxdth, -f_max_ret, f_max_ext)
        xdot = dxdth * thd
        if compensation == "load":
            u_ss = jnp.sign(xdot) * jnp.minimum(H.required_opening(cyl, val, sup, xdot, f_ref), 1.0)
        else:
            u_ss = jnp.where(xdot > 0, aa, ab) * xdot / (kv * jnp.sqrt(0.5 * ps))
        u = force_gain * (f_ref - F) / f_max + velocity_gain * u_ss
        if valve_command is not None:
            u = jnp.asarray(valve_command(t), jnp.float64) * jnp.ones(n)
        u = jnp.clip(u, -1.0, 1.0)
        # held force: the oil force predicted at mid-interval (the piston going on at its present
        # rate, the spool moving under u): a zero-order hold of F(t_n) would lag T/2 and feed
        # the oil-column mode energy (negative damping ≈ ω_h T/4); the midpoint hold is neutral
        xdot_now = dxdth * thd
        *_, acc_m = H.integrate_chambers(cyl, val, sup, ya, yb, xv, vv, u, x, x + 0.5 * period * xdot_now, 0.5 * period,
                                         max(1, substeps // 2), relief=rel)
        F_hold = H.cylinder_force(cyl, acc_m["pa"], acc_m["pb"])
        # work of the held output (F_{n−1} dx/dθ(θ_{n−1})) over the joint's travel
        w_joint = g("work_on_joint") + g("force") * piston(th_prev)[1] * (th - th_prev)
        new = {
            "pressure_a": pa, "pressure_b": pb, "valve_position": xv, "valve_rate": vv, "piston_position": x,
            "valve_command": u, "torque_reference": tau_ref,
            "energy_drawn": g("energy_drawn") + acc["drawn"], "energy_valve_loss": g("energy_valve_loss") + acc["loss"],
            "energy_leakage": g("energy_leakage") + acc["leak"], "energy_port": g("energy_port") + acc["port"],
            "work_oil_on_piston": g("work_oil_on_piston") + acc["piston"], "work_on_joint": w_joint,
            "mass_flow_a": g("mass_flow_a") + acc["mass_a"], "mass_flow_b": g("mass_flow_b") + acc["mass_b"],
            "flow_a": acc["qa"], "flow_b": acc["qb"], "supply_flow": acc["qs"],
            "hydraulic_power": acc["drawn"] / period, "valve_loss_power": acc["loss"] / period, "force": F_hold, "measured_force": F,
            "joint_coordinate": th, "oil_a": ya, "oil_b": yb, "energy_relief": g("energy_relief") + acc["relief"],
            "relief_flow": acc["qra"] + acc["qrb"],
        }
        z_new = jnp.concatenate([new[k] * jnp.ones(n) for k in FIELDS])
        return z_new, {a: F_hold[k] * dxdth[k] for k, a in enumerate(actuators)}

    ctrl = DiscreteController(name, update, z0.ravel(), actuators, period=period)
    ctrl.hydraulic = dict(cylinder=cyl, valve=val, supply=sup, relief=rel, joints=joints, n=n, piston=piston, translation=translation,
                          variables=live)
    return ctrl


def hydraulic_outputs(result, name) -> dict:
    """The servo's hydraulic outputs at the output times: a dict of (nt, n) arrays, one per
    :data:`FIELDS` entry, plus ``compression_energy`` [J] (Σ V Φ(y)/β per cylinder,
    :func:`proleg.drives.hydraulics.compression_energy`),
    ``torque`` [N m] (the held output) and the element's ``cylinder``, ``valve``, ``supply`` (with
    the result's values of the servo's ``variables``)."""
    ctrl = None
    for g in result.system.topo.extensions:
        if g.kind == "controller" and name in g.names:
            ctrl = g.elements[g.names.index(name)]
    if ctrl is None or not hasattr(ctrl, "hydraulic"):
        raise ModelError(f"No hydraulic servo named '{name}' in the result.")
    info = ctrl.hydraulic
    n = info["n"]
    st = np.asarray(result.controller(name)["state"])
    z = st[:, : len(FIELDS) * n].reshape(len(st), len(FIELDS), n)
    out = {k: z[:, i] for i, k in enumerate(FIELDS)}
    out["torque"] = st[:, len(FIELDS) * n :]
    cyl = info["cylinder"]
    out["compression_energy"] = np.asarray(H.compression_energy(cyl, out["piston_position"], out["oil_a"], out["oil_b"]))
    val, sup = info["valve"], info["supply"]
    live = info.get("variables") or {}
    if "supply_pressure" in live:  # the variant's values (hydraulic_servo(variables=...))
        sup = dataclasses.replace(sup, pressure=float(result.system.params[f"variable_{live['supply_pressure']}"]))
    if "valve_flow" in live:
        val = dataclasses.replace(val, rated_flow=float(result.system.params[f"variable_{live['valve_flow']}"]))
    out.update(cylinder=cyl, valve=val, supply=sup, relief=info.get("relief"))
    return out
