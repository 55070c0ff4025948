"""HyQ jumps: a vertical jump of the whole robot on its hydraulic cylinders (issue 33, item 4).

>>> import proleg as pl
>>> run = pl.robots.hyq_jump()                 # the co-designed push (JUMP_DESIGN)
>>> run.metrics["height"], run.metrics["limit"]

The model is :func:`proleg.robots.hyq_trot.hyq_trot_model`'s: :func:`proleg.robots.hyq` from its URDF
(13 parts, URDF joint stops, foot spheres with friction), here built crouched
(:data:`CROUCH`), with the eight HFE/KFE joints on valve-controlled cylinders with chamber
pressures under HyQ's 1 kHz pressure force loop and the HAA joints electric (torque sources),
exactly as the trot (:mod:`proleg.robots.hyq_trot`: 16 mm bore, matched-spool servo valves of
:data:`~proleg.robots.hyq_trot.TROT_VALVE_FLOW`, relief valves and a cavitation floor; 16 MPa).

The jump law (:class:`JumpLaw`, 500 Hz like the trot's, its torques the references of the
force loops), by phase:

1. crouch (t < ``t_start``): all four feet stand, a virtual model holds the trunk at the
   crouched height z_c (the trot's stance law: the trunk wrench shared by least norm among the
   feet, τ = −Jᵀ f);
2. push (``t_start`` ≤ t < ``t_start`` + T): the same virtual model tracks the motion law
   z_d(s) = z_c + Δz (2 s³ − s⁴), s = (t − t_start)/T, with its acceleration fed forward
   (F_z = m (g + z̈_d) + m (ω² (z_d − z) + 2ζω (ż_d − ż))): the acceleration 12 s (1 − s) Δz/T²
   rises from zero (a step would make the force loops overshoot the rating: they overshoot a
   force step by up to 15 %, :func:`proleg.control.hydraulic.hydraulic_servo`), peaks at 3Δz/T²
   mid-push and falls to zero at the leg's extension Δz, where the trunk has the speed 2Δz/T
   (lift-off);
3. flight and landing: a joint PD (300 N m/rad, 30 N m s/rad, hyq-stand's) to the standing
   pose :data:`~proleg.robots.hyq.STANCE`.

Every torque is clipped at the joint torque rating (``jump_torque_limit``, default 140 N m:
seed 001 "The maximum joint torque for both the hydraulic actuators is about 140Nm").

Design variables (``model.add_variable``; a study changes them without recompiling): the motion
law's push duration ``jump_t_push`` T [s] and rise ``jump_rise`` Δz [m] (what
:func:`proleg.papers.hyq_jump.optimise_jump` designs), the torque rating ``jump_torque_limit``
[N m], and the supply ``hyq_supply_pressure`` [Pa] and valve ``hyq_valve_flow`` [m³/s] (read by
the force loop, :func:`proleg.control.hydraulic.hydraulic_servo` ``variables=``) so that the
limit test raises a limit by ``system.with_params``.

What limits the jump (:func:`jump_limits`), over the push until lift-off, per hydraulic joint and
output sample:

* **torque**: the law's torque reference at the rating (|τ_ref| ≥ 0.99 τ_max);
* **pressure**: the fed chamber near the supply (p ≥ 0.9 p_s) and the other near the tank or
  the cavitation floor (≤ 0.1 p_s): the whole supply pressure is across the piston, its force
  capacity (p_s A_A extending, ≈ 3.2 kN: 145 N m on the 45 mm maximum lever arm, less elsewhere)
  is spent;
* **flow**: the spool at its stop (|x_v| ≥ 0.98) without that: the valve passes all it can
  across a large drop and the piston still lags the law (valve saturation).

A hydraulic joint at the rating whose cylinder is saturated counts as pressure or flow, not
torque. Each limit's share is the fraction of the push's samples in which any joint is at it;
``limit`` names every limit with a share above :data:`LIMIT_SHARE`, largest first ("none": the
motion law, not the hardware). The height is the trunk COM's apex above its standing height (the model with
the standing pose on the ground).

Result (issue 33 run, ``bench/results/hyq_jump.md``): the designed push (:data:`JUMP_DESIGN`)
lifts off at 2.12 m/s and reaches 0.339 m (the same law on ideal torque sources 0.380 m),
limited by pressure and flow: raised 30 % alone, the supply adds 3.2 cm, the valve's flow
4.8 cm, the torque rating nothing. Seed 001 (Introduction; also seed 000, Fig. 2 caption): HyQ
"jumping up to 0.5m" (how the height is
measured is not stated); compared, not tuned to.

Known (issue 33 run): right after lift-off the unloaded legs' force loops ring, the chamber
pressures swinging between the cavitation floor and the relief setting for ~0.15 s
(``max_chamber_pressure`` 17.9 MPa comes from there); the push, where the limits are read, is
before it. Not analysed.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import jax.numpy as jnp
import numpy as np

from ..control.gait import foot_jacobian, stance_forces
from ..errors import ModelError
from .hyq import LEGS, STANCE
from .hyq_trot import RATING, TROT_VALVE_FLOW, _joints, piston_kinematics

#: Crouched pose (URDF joint positions of the front legs; hind mirrored) [rad]: trunk ~0.47 m.
CROUCH = {"haa": -0.1, "hfe": 1.0, "kfe": -2.0}
LIMIT_SHARE = 0.1  # a limit active in less than 10 % of the push is not named
TORQUE_AT = 0.99  # |τ_ref| ≥ 0.99 τ_max: at the rating
SPOOL_AT = 0.98  # |x_v| ≥ 0.98: the spool at its stop
PRESSURE_AT = 0.9  # fed chamber ≥ 0.9 p_s: the supply's pressure is spent (valve drop ≤ 10 %)
#: The push designed by :func:`proleg.papers.hyq_jump.optimise_jump` (12 CMA-ES trials, seed 0,
#: two generations of six; issue 33 run, bench/results/hyq_jump.md): T = 0.2488 s, Δz = 0.2978 m
#: (near the 0.30 m bound of the rise), a 0.339 m jump; rounded to 4 digits.
JUMP_DESIGN = {"jump_t_push": 0.2488, "jump_rise": 0.2978}


@dataclass(frozen=True)
class JumpLaw:
    """The jump's law (module docstring); defaults chosen, not fitted.

    Parameters
    ----------
    t_start : float [s], crouched standing before the push (the drop from 3 mm settles)
    t_push : float [s], T (design variable ``jump_t_push``)
    rise : float [m], Δz (design variable ``jump_rise``)
    omega_z, zeta_z : the virtual model's vertical frequency [rad/s] and damping ratio
    kv : float [1/s], horizontal velocity gain
    k_att, d_att : attitude stiffness [N m/rad] and damping [N m s/rad] (the trot's)
    kp, kd : flight/landing joint PD [N m/rad, N m s/rad]
    mu : friction coefficient used to clip the stance forces (0.6 μ, the trot's)
    """

    t_start: float = 0.25
    t_push: float = 0.25
    rise: float = 0.18
    omega_z: float = 25.0
    zeta_z: float = 0.8
    kv: float = 4.0
    k_att: float = 1500.0
    d_att: float = 150.0
    kp: float = 300.0
    kd: float = 30.0
    mu: float = 0.7


def jump_torques(law: JumpLaw, t, state, *, joints, feet, base, mass, z_c, q_land, g=9.81):
    """Joint torques [N m] (dict joint → torque) of the jump law (module docstring), unclipped."""
    T, dz = state.variable("jump_t_push"), state.variable("jump_rise")
    s = jnp.clip((t - law.t_start) / T, 0.0, 1.0)
    pushing = (t >= law.t_start) & (t < law.t_start + T)
    on = pushing.astype(jnp.float64)
    z_d = z_c + dz * (2.0 * s**3 - s**4)
    zd_d = on * dz * (6.0 * s**2 - 4.0 * s**3) / T
    zdd_d = on * dz * (12.0 * s - 12.0 * s**2) / T**2
    r_b, v_b, R, w = state.position(base), state.velocity(base), state.orientation(base), state.angular_velocity(base)
    phi = 0.5 * jnp.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    F = mass * jnp.array([-law.kv * v_b[0], -law.kv * v_b[1],
                          g + zdd_d + law.omega_z**2 * (z_d - r_b[2]) + 2 * law.zeta_z * law.omega_z * (zd_d - v_b[2])])
    M = -law.k_att * phi - law.d_att * w
    legs = [foot_jacobian(state, feet[leg], joints[leg]) for leg in LEGS]  # (p, hip, J) per leg
    forces = stance_forces(F, M, r_b, [p for p, _, _ in legs], moment_arm=0.3, mu=law.mu)  # all four feet stand
    tau = {}
    stand = t < law.t_start + T
    for k, leg in enumerate(LEGS):
        tau_st = -legs[k][2].T @ forces[k]
        for j, jn in enumerate(joints[leg]):
            tau_air = law.kp * (q_land[jn] - state.joint_angle(jn)) - law.kd * state.joint_rate(jn)
            tau[jn] = jnp.where(stand, tau_st[j], tau_air)
    return tau


def standing_height(drop=0.0) -> float:
    """The trunk COM height [m] of HyQ in the standing pose (:data:`STANCE`) with its feet on the ground."""
    from .hyq import hyq

    return float(hyq(drop=drop, servos=False).part("base_link").position[2])


def hyq_jump_model(law: JumpLaw | None = None, actuators: str = "hydraulic", *, cylinder=None, valve=None, supply=None,
                   rating: float = RATING, law_period=2e-3, servo_period=1e-3, drop=0.003, force_gain=0.4):
    """The crouched HyQ with the jump law and the chosen actuators (module docstring)."""
    from ..control.hydraulic import hydraulic_servo
    from ..drives import hydraulics as H
    from ..model.control import DiscreteController, JointActuator
    from ..model.couplers import JointFriction
    from . import hyq_data as D
    from .hyq import hyq, stance_positions

    if actuators not in ("hydraulic", "torque"):
        raise ModelError(f"hyq_jump: actuators must be 'hydraulic' or 'torque', got {actuators!r}.")
    law = law or JumpLaw()
    if not (law.t_push > 0 and law.rise > 0):
        raise ModelError(f"hyq_jump: the push needs t_push > 0 [s] and rise > 0 [m]; got {law.t_push}, {law.rise}.")
    q_c = stance_positions(**CROUCH)
    model = hyq(drop=drop, servos=False, stance=q_c)
    model.add_variable("jump_t_push", law.t_push, "s", "HyQ jump: push duration T (hyq_jump.JumpLaw)")
    model.add_variable("jump_rise", law.rise, "m", "HyQ jump: trunk rise Δz of the push (hyq_jump.JumpLaw)")
    model.add_variable("jump_torque_limit", rating, "N m", "HyQ jump: joint torque rating (seed 001: about 140 N m)")
    joints = _joints()
    feet = {leg: f"{leg}_foot.contact" for leg in LEGS}
    mass = sum(p.mass for p in model.parts)
    z_c = float(model.part("base_link").position[2]) - drop
    q_land = {k: jnp.asarray(v) for k, v in stance_positions(**STANCE).items()}
    all_joints = [j for leg in LEGS for j in joints[leg]]
    for jn in all_joints:
        model.add_actuator(JointActuator(f"{jn}.drive", jn))

    def torques(t, state):
        tau = jump_torques(law, t, state, joints=joints, feet=feet, base="base_link", mass=mass, z_c=z_c, q_land=q_land)
        lim = state.variable("jump_torque_limit")
        return {k: jnp.clip(v, -lim, lim) for k, v in tau.items()}

    direct = all_joints if actuators == "torque" else [j for j in all_joints if "_haa_" in j]

    def update(t, state, z):
        tau = torques(t, state)
        return z, {f"{j}.drive": tau[j] for j in direct}

    model.add_controller(DiscreteController("jump", update, [0.0], [f"{j}.drive" for j in direct], period=law_period))
    hyd = None
    if actuators == "hydraulic":
        cyl = cylinder or H.Cylinder()
        sup = supply or H.Supply()
        val = valve or H.ServoValve(rated_flow=TROT_VALVE_FLOW, port_ratio=cyl.area_b / cyl.area_a)
        model.add_variable("hyq_supply_pressure", sup.pressure, "Pa", "HyQ jump: supply pressure p_s")
        model.add_variable("hyq_valve_flow", val.rated_flow, "m^3/s", "HyQ jump: servo-valve rated flow Q_N")
        names = [j for j in all_joints if "_haa_" not in j]
        piston = piston_kinematics(names, cyl.stroke)
        x0 = np.array([q_c[n] for n in names])

        def reference(t, state, th, thd):
            tau = torques(t, state)
            return jnp.stack([tau[n] for n in names])

        hyd = hydraulic_servo("cylinders", names, [f"{n}.drive" for n in names], piston, cylinder=cyl, valve=val, supply=sup,
                              reference=reference, period=servo_period, outer_period=law_period, x0=x0, force_gain=force_gain,
                              variables={"supply_pressure": "hyq_supply_pressure", "valve_flow": "hyq_valve_flow"})
        model.add_controller(hyd)
        lever = D.HIP_B  # mid-stroke lever arm (hyq_trot)
        for n in names:
            model.add_force(JointFriction(f"{n}.seal", n, friction=cyl.friction * lever, damping=cyl.viscous * lever**2, slip_rate=0.01))
    model.jump = dict(law=law, joints=joints, feet=feet, mass=mass, z_c=z_c, actuators=actuators, hydraulic=hyd, direct=direct,
                      z_stand=standing_height())
    return model


@dataclass
class JumpRun:
    """A jump: the simulation ``result``, its ``metrics`` and the ``law`` it ran with."""

    result: object
    metrics: dict
    actuators: str
    law: JumpLaw
    wall_s: float = 0.0
    extra: dict = field(default_factory=dict)


def hyq_jump(t_push: float | None = None, rise: float | None = None, actuators: str = "hydraulic", *, law: JumpLaw | None = None,
             t_after: float = 0.45, dt_output=2e-3, progress=False, integrator=None, **kw) -> JumpRun:
    """Simulate the jump (module docstring) and compute its metrics (:func:`jump_metrics`).

    ``t_push`` [s], ``rise`` [m]: the push's motion law (default: the co-designed
    :data:`JUMP_DESIGN`); ``t_after`` [s]: the
    time simulated after the push (0.45 s: past the apex of a 0.5 m jump; longer to land)."""
    import dataclasses

    from ..analyses.simulate import simulate
    from ..assembly.assemble import assemble
    from ..solvers.galpha import GeneralizedAlpha

    if law is None:
        law = dataclasses.replace(JumpLaw(), t_push=JUMP_DESIGN["jump_t_push"], rise=JUMP_DESIGN["jump_rise"])
    law = dataclasses.replace(law, **{k: v for k, v in (("t_push", t_push), ("rise", rise)) if v is not None})
    model = hyq_jump_model(law, actuators, **kw)
    integ = integrator or GeneralizedAlpha(jacobian_reuse=True)
    t0 = time.perf_counter()
    res = simulate(assemble(model), t_end=law.t_start + law.t_push + t_after, dt_output=dt_output, integrator=integ, progress=progress)
    run = JumpRun(res, {}, actuators, law, time.perf_counter() - t0)
    run.metrics = jump_metrics(res)
    return run


def jump_limits(tau_ref, xv, p_fed, p_out, supply, tau_max) -> dict:
    """What limits a push (module docstring) from its samples: ``tau_ref`` (nt, n) [N m] the law's
    torque references, its first m columns the hydraulic joints of ``xv`` (nt, m) the spool
    positions, ``p_fed`` (nt, m) [Pa] the pressure of the chamber the spool feeds from the supply
    (A for x_v ≥ 0, B else) and ``p_out`` (nt, m) that of the other (drained to tank); ``supply``
    p_s [Pa]; ``tau_max`` the rating [N m]. m may be 0 (torque sources).

    Per sample and hydraulic joint: pressure, p_fed ≥ 0.9 p_s and p_out ≤ 0.1 p_s (the whole
    supply pressure across the piston: its force capacity; p_out at the tank or the cavitation
    floor); flow, the spool at its stop (|x_v| ≥ 0.98) without the pressure condition (the valve
    passes all it can across a large drop); torque, |τ_ref| ≥ 0.99 τ_max with neither (a joint
    whose cylinder is saturated cannot use a higher rating: measured, raising the rating 30 %
    left the designed jump's height unchanged to 1 µm while its references sat at the rating in
    81 % of the push). Electric (torque-source) joints: torque only.

    Returns ``share_torque``, ``share_pressure``, ``share_flow`` (the fractions of samples in which
    any joint is at that limit) and ``limit``: the limits with a share ≥ :data:`LIMIT_SHARE`,
    largest first, joined by "+" (e.g. "pressure+flow"), or "none"."""
    tau_ref, xv, p_fed, p_out = (np.asarray(a, float) for a in (tau_ref, xv, p_fed, p_out))
    nt, m = len(tau_ref), xv.shape[1] if xv.ndim == 2 else 0
    torque = np.abs(tau_ref) >= TORQUE_AT * tau_max
    if m:
        pressure = (p_fed >= PRESSURE_AT * supply) & (p_out <= (1 - PRESSURE_AT) * supply)
        flow = (np.abs(xv) >= SPOOL_AT) & ~pressure
        torque[:, :m] &= ~(pressure | flow)
    else:
        pressure = flow = np.zeros((nt, 1), bool)
    share = {k: float(v.any(1).mean()) if nt else 0.0 for k, v in (("torque", torque), ("pressure", pressure), ("flow", flow))}
    named = [k for k in sorted(share, key=share.get, reverse=True) if share[k] >= LIMIT_SHARE]
    return {**{f"share_{k}": v for k, v in share.items()}, "limit": "+".join(named) if named else "none"}


def jump_metrics(result) -> dict:
    """height (trunk COM apex above standing) [m], apex (its height) [m], apex_time, takeoff_time
    [s], takeoff_speed [m/s], ballistic_height [m] (z at lift-off + v²/2g − standing: the check of
    the apex), max_joint_torque [N m] (push and flight up to the apex; ``max_joint_torque_all``
    the whole run, landing included), torque_limit [N m], the limit shares and ``limit``
    (:func:`jump_limits`); hydraulic: supply_pressure, valve_flow, max/min_chamber_pressure [Pa],
    peak_supply_flow [m³/s], hydraulic_energy [J] up to the apex."""
    res = result
    model = res.system.topo.model
    info = model.jump
    law = info["law"]
    P = res.system.params
    T = float(P["variable_jump_t_push"])
    tau_max = float(P["variable_jump_torque_limit"])
    t = np.asarray(res.t)
    z = np.asarray(res.part("base_link").position)[:, 2]
    vz = np.asarray(res.part("base_link").velocity)[:, 2]
    fz = np.stack([np.asarray(res.contact(f"{info['feet'][leg]}")["normal_force"]) for leg in LEGS], 1)
    t0 = law.t_start
    after = t >= t0
    air = after & (fz.max(1) < 1.0)
    k_to = int(np.argmax(air)) if air.any() else len(t) - 1
    k_ap = int(np.argmax(np.where(after, z, -np.inf)))
    z_stand = info["z_stand"]
    names = [j for leg in LEGS for j in info["joints"][leg]]
    tau = np.stack([np.asarray(res.actuator(f"{j}.drive")["effort"]) for j in names], 1)
    push = after & (t <= t[k_to])
    m = {"height": float(z[k_ap] - z_stand), "apex": float(z[k_ap]), "apex_time": float(t[k_ap]), "takeoff_time": float(t[k_to]),
         "takeoff_speed": float(vz[k_to]), "ballistic_height": float(z[k_to] + max(vz[k_to], 0.0) ** 2 / (2 * 9.81) - z_stand),
         "lifted_off": bool(air.any()), "standing_height": z_stand, "crouch_height": info["z_c"], "t_push": T,
         "rise": float(P["variable_jump_rise"]), "torque_limit": tau_max, "max_joint_torque": float(np.abs(tau[after & (t <= t[k_ap])]).max()),
         "max_joint_torque_all": float(np.abs(tau).max()),
         "steps": int(res.stats["steps"])}
    hyd = info["hydraulic"]
    if hyd is None:
        lim = jump_limits(tau[push], np.zeros((push.sum(), 0)), np.zeros((push.sum(), 0)), np.zeros((push.sum(), 0)), 1.0, tau_max)
    else:
        from ..control.hydraulic import hydraulic_outputs

        out = hydraulic_outputs(res, "cylinders")
        ps = out["supply"].pressure
        pa, pb, xv = out["pressure_a"], out["pressure_b"], out["valve_position"]
        p_fed, p_out = np.where(xv >= 0, pa, pb), np.where(xv >= 0, pb, pa)
        ref = np.concatenate([out["torque_reference"], tau[:, ["_haa_" in n for n in names]]], 1)
        lim = jump_limits(ref[push], xv[push], p_fed[push], p_out[push], ps, tau_max)
        upto = t <= t[k_ap]
        m.update(supply_pressure=ps, valve_flow=float(out["valve"].rated_flow), max_chamber_pressure=float(max(pa[upto].max(), pb[upto].max())),
                 min_chamber_pressure=float(min(pa[upto].min(), pb[upto].min())),
                 peak_supply_flow=float(out["supply_flow"][upto].sum(1).max()),
                 hydraulic_energy=float(out["energy_drawn"][k_ap].sum() - out["energy_drawn"][0].sum()),
                 spool_max=float(np.abs(xv[push]).max()) if push.any() else 0.0)
    m.update(lim)
    return m
