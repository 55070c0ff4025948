"""HyQ trots: the whole robot from its URDF, with hydraulic cylinders or ideal torque sources.

>>> import proleg as pl
>>> run = pl.robots.hyq_trot(speed=1.0, t_end=8.0, actuators="hydraulic")
>>> run.metrics["forward_speed"], run.metrics["cost_of_transport"]

The model is :func:`proleg.robots.hyq` (13 parts, 12 revolute joints with the URDF's limits as
stops, four foot spheres with friction μ 0.9/0.7) without its PD servos. The trot law
(:mod:`proleg.control.gait`: diagonal pairs, duty factor, step height, Raibert foot placement,
virtual-model stance) computes the 12 joint torques every ``law_period`` (500 Hz), held.

``actuators="torque"``: ideal torque sources apply them (clipped at the URDF's 150 N m effort).

``actuators="hydraulic"``: seed 001: "the hip and knee hydraulically actuated flexion/extension
and the hip electrically actuated abduction/adduction". The four HAA joints stay ideal torque
sources (electric); the eight HFE and KFE joints each get a valve-controlled cylinder
(:mod:`proleg.drives.hydraulics`, 16 mm bore / 10 mm rod / 80 mm stroke, Moog E024-class valve,
16 MPa supply) mounted through the cylinder triangles of MODEL_DATA §1
(:mod:`proleg.robots.hyq_data`): with θ = s q (s = −1 front legs, +1 hind: the front legs are
the mirror image, URDF HFE −50…70°, KFE −140…−20°), the piston position is
x = c(θ) − c_min + margin and the transmission dx/dq = s dc/dθ (±lever arm). The triangles
travel 78.0 mm over the joint ranges, inside the 80 mm stroke with 1 mm at each end: the URDF's
joint stops are the cylinders' end-of-stroke stops. The trot law's torque is the reference of
HyQ's pressure force loop (:func:`proleg.control.hydraulic.hydraulic_servo`, 1 kHz); the seal
friction (20 N + 200 N s/m) acts as a continuous joint friction reflected through the lever arm
at mid-stroke (0.045 m).

The valves are sized from the gait's flow demand (:data:`TROT_VALVE_FLOW`, 5.5 l/min at 7 MPa;
:func:`flow_demand`), their spools matched to the cylinder area ratio; each chamber has a relief valve (1.1 p_s) and the oil a cavitation floor
(:mod:`proleg.drives.hydraulics`). History (issue 33): with the 2.5 l/min valve and neither
relief nor cavitation, a 3 s hydraulic trot was flow-limited in swing, lost the gait at ~2.2 s
and reached 27 MPa and −16 MPa.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import jax.numpy as jnp
import numpy as np

from ..control.gait import Trot, nominal_offsets, quadruped_torques
from ..errors import ModelError
from . import hyq_data as D
from .hyq import FOOT_RADIUS, LEGS

JOINT_KINDS = ("haa", "hfe", "kfe")
#: [m³/s] rated flow (at the 7 MPa catalogue drop) of the trot's servo valves: sized from the gait's
#: flow demand (:func:`flow_demand` on the torque-source trot at 1.0 m/s, 4 s, second half): the
#: hind KFE pistons need a peak opening of 2.2 of the 2.5 l/min E024-class default (99th
#: percentile 1.56; front KFE 1.04, HFE ≤ 0.96), so a 2.5 × 2.2 = 5.5 l/min valve passes the
#: trot's peak flow. With the 2.5 l/min valve the hydraulic trot is flow-limited in swing (the
#: velocity feed-forward alone asks for openings up to 1.2) and lost the gait at ~2.2 s
#: (issue 33 report). A design consequence, not a fit: kept a parameter (``valve=``).
TROT_VALVE_FLOW = 5.5e-3 / 60.0
RATING = 140.0  # [N m] seed 001: "The maximum joint torque for both the hydraulic actuators is about 140Nm"
FALL_HEIGHT = 0.35  # [m] trunk below this: fallen (issue 33)


def _joints():
    return {leg: [f"{leg}_{k}_joint" for k in JOINT_KINDS] for leg in LEGS}


def _geometry():
    """(c_min, margin) per joint kind for the cylinder triangles over the URDF ranges."""
    th1 = np.deg2rad(np.linspace(*D.HFE_RANGE_DEG, 241))
    th2 = np.deg2rad(np.linspace(*D.KFE_RANGE_DEG, 241))
    c1, c2 = np.asarray(D.hip_cylinder_length(th1)), np.asarray(D.knee_cylinder_length(th2))
    return {"hfe": (c1.min(), c1.max() - c1.min()), "kfe": (c2.min(), c2.max() - c2.min())}


def piston_kinematics(names, stroke):
    """θ (n,) URDF joint angles → (x (n,), dx/dq (n,)) for the HFE/KFE joints ``names``."""
    geo = _geometry()
    sign = np.array([-1.0 if n[1] == "f" else 1.0 for n in names])
    kind = [n.split("_")[1] for n in names]
    cmin = np.array([geo[k][0] for k in kind])
    margin = np.array([(stroke - geo[k][1]) / 2 for k in kind])
    if np.any(margin < 0):
        raise ModelError(f"hyq_trot: a cylinder stroke of {stroke} m is shorter than the joint travel {max(g[1] for g in geo.values()):.4f} m.")
    hip = np.array([k == "hfe" for k in kind])

    def piston(q):
        th = jnp.asarray(sign) * q
        c = jnp.where(hip, D.hip_cylinder_length(th), D.knee_cylinder_length(th))
        dc = jnp.where(hip, D.hip_signed_lever(th), D.knee_signed_lever(th))
        return c - cmin + margin, jnp.asarray(sign) * dc

    return piston


def flow_demand(run, cylinder=None, valve=None, supply=None, t_from=None):
    """The valve opening the run's joint motion and torques would need on HyQ's cylinders.

    For each HFE/KFE joint of a trot ``run`` (typically the torque-source one: the gait without
    actuator limits) the piston speed ẋ = dx/dq q̇ and rod force F = τ/(dx/dq) at each output
    time give the steady spool opening :func:`proleg.drives.hydraulics.required_opening`; above
    1 the valve cannot pass the flow (flow-limited), inf: the force is beyond the supply.

    Returns a dict: ``names`` (8,), ``t`` (nt,), ``opening`` (nt, 8) [-], ``peak`` (8,) and
    ``p99`` (8,) over t ≥ ``t_from`` (default: the second half), and ``flow_limited_fraction``
    (8,): the share of time above 1.
    """
    from ..drives import hydraulics as H

    cyl, val, sup = cylinder or H.Cylinder(), valve or H.ServoValve(), supply or H.Supply()
    res = run.result
    names = [j for j in (f"{leg}_{k}_joint" for leg in LEGS for k in ("hfe", "kfe"))]
    t = np.asarray(res.t)
    q = np.stack([np.asarray(res.joint(n).angle) for n in names], 1)
    tau = np.stack([np.asarray(res.actuator(f"{n}.drive")["effort"]) for n in names], 1)
    x, dx = map(np.asarray, piston_kinematics(names, cyl.stroke)(jnp.asarray(q)))
    xdot = np.gradient(x, t, axis=0)
    u = np.asarray(H.required_opening(cyl, val, sup, xdot, tau / dx))
    late = t >= (t[-1] / 2 if t_from is None else t_from)
    return {"names": names, "t": t, "opening": u, "peak": u[late].max(0), "p99": np.percentile(u[late], 99, axis=0),
            "flow_limited_fraction": (u[late] > 1).mean(0)}


@dataclass
class TrotRun:
    """A trot: the simulation ``result``, the ``metrics`` and the settings it ran with."""

    result: object
    metrics: dict
    actuators: str
    gait: Trot
    wall_s: float = 0.0
    extra: dict = field(default_factory=dict)


def hyq_trot_model(speed=1.0, actuators="hydraulic", *, gait: Trot | None = None, law_period=2e-3, cylinder=None, valve=None, supply=None,
                   servo_period=1e-3, drop=0.003, force_gain=0.4):
    """The HyQ model with the trot law and the chosen actuators (module docstring)."""
    from ..control.hydraulic import hydraulic_servo
    from ..drives import hydraulics as H
    from ..model.control import DiscreteController, JointActuator
    from ..model.couplers import JointFriction
    from .hyq import hyq, stance_positions

    if actuators not in ("hydraulic", "torque"):
        raise ModelError(f"hyq_trot: actuators must be 'hydraulic' or 'torque', got {actuators!r}.")
    gait = gait or Trot(speed=speed)
    model = hyq(drop=drop, servos=False)
    joints = _joints()
    feet = {leg: f"{leg}_foot.contact" for leg in LEGS}
    mass = sum(p.mass for p in model.parts)
    nominal = {k: jnp.asarray(v) for k, v in nominal_offsets(model, LEGS, joints, feet).items()}
    z_d = float(model.part("base_link").position[2]) - drop
    all_joints = [j for leg in LEGS for j in joints[leg]]
    for jn in all_joints:
        model.add_actuator(JointActuator(f"{jn}.drive", jn))

    # The gait's numbers, the mass, the trunk height and the feet's nominal offsets are design
    # variables (``trot_speed``, ``trot_period``, ...; ``system.with_params``), and the law closes
    # over names only: a trot at another speed or with other gains is the same structure and
    # reuses the compiled run (issue 42), and a study can sweep them.
    gait_keys = tuple(f.name for f in dataclasses.fields(gait) if getattr(gait, f.name) is not None)
    for k in gait_keys:
        model.add_variable(f"trot_{k}", float(getattr(gait, k)), "", f"trot gait: {k} (proleg.control.gait.Trot)")
    model.add_variable("trot_mass", mass, "kg", "total mass the trot law carries")
    model.add_variable("trot_height", z_d, "m", "trunk height the trot law holds (unless the gait sets one)")
    for leg in LEGS:
        for i, ax in enumerate("xy"):
            model.add_variable(f"trot_nominal_{leg}_{ax}", float(nominal[leg][i]), "m", f"{leg} foot's nominal {ax} offset from its hip")
    gait_type = type(gait)

    def law(t, state):
        g = gait_type(**{k: state.variable(f"trot_{k}") for k in gait_keys})
        nom = {leg: jnp.stack([state.variable(f"trot_nominal_{leg}_x"), state.variable(f"trot_nominal_{leg}_y")]) for leg in LEGS}
        tau, _ = quadruped_torques(g, t, state, legs=LEGS, joints=joints, feet=feet, base="base_link", mass=state.variable("trot_mass"),
                                   nominal=nom, foot_height=FOOT_RADIUS, z_d=state.variable("trot_height"))
        return tau

    if actuators == "torque":
        direct = all_joints
    else:
        direct = [j for j in all_joints if "_haa_" in j]
    lim = 150.0  # URDF effort limit

    def update(t, state, z):
        tau = law(t, state)
        return z, {f"{j}.drive": jnp.clip(tau[j], -lim, lim) for j in direct}

    model.add_controller(DiscreteController("trot", update, [0.0], [f"{j}.drive" for j in direct], period=law_period))
    hyd = None
    if actuators == "hydraulic":
        cyl = cylinder or H.Cylinder()
        names = [j for j in all_joints if "_haa_" not in j]
        piston = piston_kinematics(names, cyl.stroke)
        q0 = stance_positions()
        x0 = np.array([q0[n] for n in names])

        def reference(t, state, th, thd):
            tau = law(t, state)
            return jnp.stack([tau[n] for n in names])

        # the spool matched to the cylinder's area ratio: a symmetric one intensifies the
        # meter-out chamber past the supply under the stance knees' overrunning loads (measured:
        # 16.85 MPa at the front KFE on 16 MPa; ServoValve.port_ratio)
        valve = valve or H.ServoValve(rated_flow=TROT_VALVE_FLOW, port_ratio=cyl.area_b / cyl.area_a)
        hyd = hydraulic_servo("cylinders", names, [f"{n}.drive" for n in names], piston, cylinder=cyl, valve=valve, supply=supply,
                              reference=reference, period=servo_period, outer_period=law_period, x0=x0, force_gain=force_gain)
        model.add_controller(hyd)
        lever = D.HIP_B  # mid-stroke lever arm ≈ b = 0.045 m (the triangles' maximum)
        for n in names:
            model.add_force(JointFriction(f"{n}.seal", n, friction=cyl.friction * lever, damping=cyl.viscous * lever**2, slip_rate=0.01))
    model.trot = dict(gait=gait, joints=joints, feet=feet, mass=mass, z_d=z_d, actuators=actuators, hydraulic=hyd, direct=direct)
    return model


def hyq_trot(speed: float = 1.0, t_end: float = 8.0, actuators: str = "hydraulic", *, gait: Trot | None = None, dt_output=5e-3,
             progress=False, integrator=None, **kw) -> TrotRun:
    """Simulate the trot (module docstring) and compute its metrics (:func:`trot_metrics`)."""
    import time

    from ..analyses.simulate import simulate
    from ..assembly.assemble import assemble
    from ..solvers.galpha import GeneralizedAlpha

    model = hyq_trot_model(speed, actuators, gait=gait, **kw)
    integ = integrator or GeneralizedAlpha(jacobian_reuse=True)
    t0 = time.perf_counter()
    res = simulate(assemble(model), t_end=t_end, dt_output=dt_output, integrator=integ, progress=progress)
    wall = time.perf_counter() - t0
    run = TrotRun(res, {}, actuators, model.trot["gait"], wall)
    run.metrics = trot_metrics(run)
    return run


def trot_metrics(run: TrotRun) -> dict:
    """forward_speed (mean over the last half) [m/s], base_height_min [m], fell, max_joint_torque
    [N m], cost_of_transport (hydraulic: energy drawn; torque: positive joint work, per m g d),
    supply_pressure, max_chamber_pressure, min_chamber_pressure, relief_setting [Pa],
    hydraulic_energy, mechanical_energy (positive joint work), valve_loss, relief_loss,
    energy_residual (drawn − valve − relief − leakage − Δ oil compression − cylinder work on the
    joints) [J], stats."""
    res = run.result
    model = res.system.topo.model
    info = model.trot
    t = np.asarray(res.t)
    x = np.asarray(res.part("base_link").position)
    half = t >= t[-1] / 2
    i0 = np.argmax(half)
    speed = float((x[-1, 0] - x[i0, 0]) / (t[-1] - t[i0]))
    zmin = float(x[:, 2].min())
    tau, power = [], []
    for leg in LEGS:
        for jn in info["joints"][leg]:
            a = res.actuator(f"{jn}.drive")
            eff, rate = np.asarray(a["effort"]), np.asarray(a["rate"])
            tau.append(eff)
            power.append(eff * rate)
    tau, power = np.stack(tau, 1), np.stack(power, 1)
    dt = np.diff(t)
    pos_work = float(np.sum(0.5 * (np.maximum(power[1:], 0) + np.maximum(power[:-1], 0)) * dt[:, None]))
    weight = info["mass"] * 9.81
    dist = max(float(x[-1, 0] - x[0, 0]), 1e-9)
    m = {
        "forward_speed": speed, "commanded_speed": float(info["gait"].speed), "base_height_min": zmin,
        "fell": bool(zmin < FALL_HEIGHT), "max_joint_torque": float(np.abs(tau).max()),
        "mechanical_energy": pos_work, "distance": dist, "steps": int(res.stats["steps"]), "wall_s": run.wall_s,
    }
    hyd = info["hydraulic"]
    if hyd is not None:
        from ..control.hydraulic import hydraulic_outputs

        out = hydraulic_outputs(res, "cylinders")
        pa, pb = out["pressure_a"], out["pressure_b"]
        drawn = float(out["energy_drawn"][-1].sum())
        valve = float(out["energy_valve_loss"][-1].sum())
        leak = float(out["energy_leakage"][-1].sum())
        relief = float(out["energy_relief"][-1].sum())
        d_comp = float(out["compression_energy"][-1].sum() - out["compression_energy"][0].sum())
        w_joint = float(out["work_on_joint"][-1].sum())
        w_oil = float(out["work_oil_on_piston"][-1].sum())
        m.update(
            supply_pressure=float(out["supply"].pressure), max_chamber_pressure=float(max(pa.max(), pb.max())),
            min_chamber_pressure=float(min(pa.min(), pb.min())), hydraulic_energy=drawn, valve_loss=valve, leakage_loss=leak, relief_loss=relief,
            relief_setting=float(out["relief"].cracking(out["supply"])), peak_relief_flow=float(out["relief_flow"].sum(1).max()),
            compression_energy_change=d_comp, oil_work_on_pistons=w_oil, cylinder_work_on_joints=w_joint,
            energy_residual=drawn - valve - relief - leak - d_comp - w_joint, cost_of_transport=drawn / (weight * dist),
            mechanical_cost_of_transport=pos_work / (weight * dist),
            peak_supply_flow=float(out["supply_flow"].sum(1).max()), mean_supply_flow=float(np.mean(out["supply_flow"].sum(1))),
        )
    else:
        m["cost_of_transport"] = pos_work / (weight * dist)
        m["mechanical_cost_of_transport"] = m["cost_of_transport"]
    return m
