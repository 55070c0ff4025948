"""FLEGX countermovement jump (seed 002 §IV) and the worm-drive torques (Eqs. 16-17).

Motion law (documented choice; the paper prints neither angles nor timings)
---------------------------------------------------------------------------
Each joint angle is a sum of cubic STEP laws (seed 002 Eq. 18, :func:`proleg.fn.step`)::

    θ(t) = θ_stand + STEP(t, t_s, 0, t_s + T_squat, θ_squat − θ_stand)       squat
                   + STEP(t, t_p, 0, t_p + T_push, θ_extend − θ_squat)       push-off
                   + STEP(t, t_r, 0, t_r + T_retract, θ_land − θ_extend)     flight: legs back

with t_s = ``t_settle`` (standing still on the ground first), t_p = t_s + T_squat + ``t_hold``,
t_r = t_p + T_push + ``retract_delay``. Defaults: stand (−30°, 60°), squat (−50°, 100°),
extend (−20°, 40°), land = stand; T_squat = 0.8 s (seed 002: "squats down in few seconds";
shortened to keep runs short, the squat is quasi-static either way), T_push = 0.30 s. With the
No. 4 leg and the 250×70×3 link the CB and PRBM links jump tens of millimetres (the PRBM one
higher) and the rigid link does not take off; the figures of ``proleg run flegx-jump`` are in
docs/papers/seed-002.md. The paper: LFM 50 mm vs PRBM 60 mm (§III.A),
Table I No. 4: 104 mm / 531 MPa; its machinery jump (Fig. 4): 50 mm, 447 MPa, 32 mm.
The push is close to the leg's bounce period on the strip (≈ 0.2-0.3 s), so the flexible link
stores and returns energy: shorter pushes jump much higher on the flexible link than on the
rigid one. The scenarios do not run this default push (issue 30: no law picked by hand):
``flegx-jump`` runs the shortest push at which its PRBM leg keeps within 520 MPa and the 77 N m
wheel rating (:func:`~proleg.papers.flegx_codesign.push_at_limits`), ``flegx-study`` the
shortest at which every configuration does (:func:`~proleg.papers.flegx_study.shared_push`),
and ``flegx-machinery`` the push and extended pose found by co-design
(:func:`~proleg.papers.flegx_codesign.optimise_law`); the squat, hold and retraction timings and
the stand and squat poses stay the documented values above in all three (assumed).
The motions are imposed on the hip joint and on the knee wheel (No. 4: θ1 + θ2 through the
tendon parallelogram) or the knee joint (No. 1-3), as the paper imposes motion laws "as a
function of time" on the hip and knee; with ``gears="worm"`` on the worms (s = n r1 Δθ).

Jump metrics
------------
- ``jump_height`` [m], the paper's "jumping height" (seed 002 §IV: "the maximum jumping height
  reached"; Fig. 4: "a 50 mm jump"), taken as the **guide's rise at the apex above its standing
  height**: the highest guide (hip) position while the foot is in the air after the push
  starts, minus the guide's height standing still on the ground (at the end of ``t_settle``).
  It is what the guide's linear encoder reads, and equals the foot's clearance above the
  ground when the leg is back in its standing pose at the apex (the landing pose is the
  standing one). It needs no take-off instant, so a touch-and-go of the still-extending leg
  before the main flight, or the hops after the landing (lower), do not change it; 0 if the
  foot never leaves the ground (the one place where it jumps: a leg that leaves the ground
  for an instant at full extension scores its extension). Seed 002 does not say which height it measured; the other
  two readings are reported beside it: ``foot_clearance`` (highest point of the foot
  cylinder's lowest point above the ground during the jump's flight; smaller when the leg
  is still extended at the apex) and ``flight_rise`` (the guide's rise from the flight's
  take-off to its apex, ≈ v²/2g of the ballistic flight, larger: it counts the leg's
  extension between standing and take-off).
- ``take_off_time``, ``apex_time`` and ``landing_time`` [s]: the flight that contains that apex
  (first sample with zero foot normal force, the apex, first sample in contact again; landing
  NaN if the run ends in the air). ``flights`` counts all airborne phases after the push starts.
- ``max_stress`` [Pa]: von Mises at the clamped end of the strip, over the whole run
  (take-off and landing; ``max_stress_takeoff`` up to take-off, Table I's phase). CB: stress
  recovery of the modal body (σ_xx at the root surfaces). Rigid and PRBM: from the clamp's
  reaction, |N|/A + |M| / (W t²/6) (the beam formula for the same section).
- ``tip_displacement`` [m]: max free-end displacement transverse to the strip relative to the
  clamped end (CB: modal deformation of the tip node; PRBM: γ L sin Θ; rigid: 0); the series
  ``tip_displacement`` is signed along the strip's thickness axis u2 × y (u2 from knee to foot).
- ``peak_hip_torque``/``peak_knee_torque`` [N m]: at the joint (wheel side) and, as
  ``*_worm``, at the worm (motor side): the motor's torque of the worm dynamics
  (``gears="worm"``, :func:`worm_drive_outputs`) or the wheel torque / 9.67 (ideal); over the
  whole run (stand, squat, push, flight, landing). ``peak_hip_torque_takeoff`` and
  ``peak_knee_torque_takeoff`` [N m]: the same at the joints up to take-off (Table I's phase,
  as ``max_stress_takeoff``; the whole run if the foot never leaves the ground).
- ``motor_energy`` [J] = ∫ (|P_hip| + |P_knee|) dt of the motors' power, ``motor_work_positive``
  [J] = ∫ max(P, 0) dt (the energy drawn without regeneration), ``mesh_loss_energy`` [J] the
  worm meshes' friction loss.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field

import numpy as np

from ..errors import ModelError
from ..model.control import Motion
from ..units import deg
from ..robots import flegx_data as D
from ..robots.flegx import check_angles, flegx

__all__ = ["MotionLaw", "flegx_jump", "JumpResult", "worm_torques", "worm_friction", "jump_metrics", "jump_flight", "worm_drive_outputs"]


@dataclass(frozen=True)
class MotionLaw:
    """Countermovement jump law (module docstring); angles (θ1, θ2) [rad], times [s]."""

    stand: tuple = (-30.0 * deg, 60.0 * deg)
    squat: tuple = (-50.0 * deg, 100.0 * deg)
    extend: tuple = (-20.0 * deg, 40.0 * deg)
    land: tuple | None = None  # default: stand
    t_settle: float = 0.15
    t_squat: float = 0.8
    t_hold: float = 0.1
    t_push: float = 0.30
    retract_delay: float = 0.03
    t_retract: float = 0.15
    t_after: float = 0.6  # simulated time after the end of the push
    #: True: the push duration and the extended pose are the model's design variables
    #: ``law_t_push`` [s], ``law_extend_hip`` and ``law_extend_knee`` [rad] (initial values
    #: ``t_push`` and ``extend``), which a study sweeps or optimises without recompiling
    #: (:mod:`proleg.papers.flegx_codesign`); the flight retraction follows the push's end
    design: bool = False

    @property
    def landing_pose(self):
        return self.stand if self.land is None else self.land

    @property
    def push_start(self) -> float:
        return self.t_settle + self.t_squat + self.t_hold

    @property
    def push_end(self) -> float:
        return self.push_start + self.t_push

    @property
    def t_end(self) -> float:
        return self.push_end + self.t_after

    def _knots(self):
        ts = self.t_settle
        tp = self.push_start
        tr = self.push_end + self.retract_delay
        return ((ts, ts + self.t_squat, self.stand, self.squat), (tp, tp + self.t_push, self.squat, self.extend),
                (tr, tr + self.t_retract, self.extend, self.landing_pose))

    def angle(self, k: int, t, state=None):
        """θ_k(t) [rad] (k = 0 hip, 1 knee), JAX-traceable; with ``design`` the push's duration
        and extended pose are read from ``state.variable`` (its design variables)."""
        from ..fn import step

        if not (self.design and state is not None):
            knots = self._knots()
        else:
            t_push = state.variable("law_t_push")
            extend = (state.variable("law_extend_hip"), state.variable("law_extend_knee"))
            ts, tp = self.t_settle, self.push_start
            tr = tp + t_push + self.retract_delay
            land = self.landing_pose if self.land is not None else self.stand
            knots = ((ts, ts + self.t_squat, self.stand, self.squat), (tp, tp + t_push, self.squat, extend),
                     (tr, tr + self.t_retract, extend, land))
        out = self.stand[k]
        for a, b, p0, p1 in knots:
            out = out + step(t, a, 0.0, b, p1[k] - p0[k])
        return out

    def add_variables(self, model):
        """Register the design variables of a ``design`` law on ``model`` (once)."""
        for name, value, unit in (("law_t_push", self.t_push, "s"), ("law_extend_hip", self.extend[0], "rad"),
                                  ("law_extend_knee", self.extend[1], "rad")):
            if name not in model.variables:
                model.add_variable(name, value, unit, "FLEGX jump law (flegx_jump.MotionLaw, design=True)")

    def validate(self):
        """ModelError for bad timings or a pose outside the joint ranges."""
        for what in ("t_settle", "t_squat", "t_hold", "t_push", "retract_delay", "t_retract", "t_after"):
            v = getattr(self, what)
            positive = what in ("t_squat", "t_push", "t_retract", "t_after")
            if not (math.isfinite(v) and (v > 0 if positive else v >= 0)):
                raise ModelError(f"flegx_jump: {what} = {v!r} s must be {'> 0' if positive else '≥ 0'}.")
        for what in ("stand", "squat", "extend", "landing_pose"):
            p = getattr(self, what)
            if len(p) != 2:
                raise ModelError(f"flegx_jump: {what} must be (θ1, θ2) in rad, got {p!r}.")
            check_angles(p[0], p[1], f"motion law's {what} pose")


def worm_friction(wheel_speed, static=D.WORM_FRICTION_STATIC, dynamic=D.WORM_FRICTION_DYNAMIC,
                  transition=D.WORM_FRICTION_TRANSITION):
    """Friction coefficient f(ω) [-]: ``static`` at rest, ``dynamic`` above ``transition`` [rad/s]
    of wheel speed, cubic STEP between (seed 002 §IV: 0.14 / 0.13)."""
    d = np.clip(np.abs(np.asarray(wheel_speed, float)) / transition, 0.0, 1.0)
    return static + (dynamic - static) * d * d * (3 - 2 * d)


def worm_torques(wheel_torque, wheel_speed, gears="worm", friction=None, worm=None, speed_eps=1e-3):
    """Torque and power at the worm for a given torque and speed at the wheel (seed 002 Eqs. 16-17),
    quasi-statically (no mesh dynamics): the ideal-gear reporting of :func:`jump_metrics`, and the
    closed form the dynamic worm mesh (``gears="worm"``) is tested against.

    Parameters
    ----------
    wheel_torque : (n,) [N m]   τ_out, the torque the wheel delivers to the joint (motion effort)
    wheel_speed : (n,) [rad/s]  ω_out of the joint; the worm turns at ω_in = n ω_out
    gears : "worm" or "ideal"   ideal: τ_in = τ_out / n, no loss
    friction : float or (n,), optional   f; default :func:`worm_friction` of the speed
    worm : WormGear, optional   default the FLEGX set (9.67:1)
    speed_eps : float [rad/s]   blend of the forward/backward branches (GearTrain convention)

    Returns
    -------
    dict: ``worm_torque`` [N m], ``worm_speed`` [rad/s], ``power_in`` = τ_in ω_in,
    ``power_out`` = τ_out ω_out, ``mesh_loss`` = f W v_s [W] from the tooth normal force W and the
    sliding speed v_s (independent of Eq. 16: power_in − power_out = mesh_loss is the check),
    ``efficiency`` η(f), ``back_efficiency`` η_back(f) (≤ 0: self-locking; the worm must then
    drive the load even when lowering it, τ_in has the sign of the motion).
    """
    from ..drives.gears import WormGear

    wg = worm or WormGear(**D.WORM)
    tau = np.asarray(wheel_torque, float)
    w = np.asarray(wheel_speed, float)
    n = wg.ratio
    if gears == "ideal":
        tin = tau / n
        z = np.zeros_like(tau)
        return dict(worm_torque=tin, worm_speed=n * w, power_in=tin * n * w, power_out=tau * w, mesh_loss=z,
                    efficiency=np.ones_like(tau), back_efficiency=np.ones_like(tau))
    if gears != "worm":
        raise ModelError(f"worm_torques: gears must be 'worm' or 'ideal', got {gears!r}.")
    f = worm_friction(w) if friction is None else np.broadcast_to(np.asarray(friction, float), tau.shape)
    cn, lam = math.cos(wg.normal_pressure_angle), wg.lead_angle
    tg = math.tan(lam)
    eta = (cn - f * tg) / (cn + f / tg)
    eta_b = (cn - f / tg) / (cn + f * tg)
    p = np.sign(tau) * w
    fw = np.where(p >= 0, 1.0, 0.0) if speed_eps <= 0 else np.clip(0.5 + 0.75 * (p / speed_eps) - 0.25 * (p / speed_eps) ** 3, 0, 1)
    fw = np.where(np.abs(p) >= speed_eps, np.where(p >= 0, 1.0, 0.0), fw)
    tin = (fw / eta + (1 - fw) * eta_b) * tau / n
    r1, r2 = 0.5 * wg.worm_pitch_diameter, 0.5 * wg.wheel_pitch_diameter
    Ft = np.abs(tau) / r2  # wheel tangential force
    W_f = Ft / (cn * math.cos(lam) - f * math.sin(lam))  # tooth normal force, worm driving
    W_b = Ft / (cn * math.cos(lam) + f * math.sin(lam))  # wheel driving
    vs = np.abs(n * w) * r1 / math.cos(lam)  # sliding speed
    loss = f * vs * (fw * W_f + (1 - fw) * W_b)
    return dict(worm_torque=tin, worm_speed=n * w, power_in=tin * n * w, power_out=tau * w, mesh_loss=loss,
                efficiency=eta, back_efficiency=eta_b)


@dataclass
class JumpResult:
    """What :func:`flegx_jump` returns: the simulation ``result``, scalar ``metrics``, time
    ``series`` (numpy arrays, SI) and the ``model``/``system``/``law`` used."""

    result: object
    metrics: dict
    series: dict
    model: object
    system: object
    law: MotionLaw
    wall_s: float = 0.0
    extra: dict = field(default_factory=dict)

    def frame(self):
        """The time series as a pandas DataFrame (units in the column names)."""
        import pandas as pd

        return pd.DataFrame(self.series)


def _add_motions(model, law: MotionLaw):
    """The law's joint motions on the wheels (ideal gears) or on the worm sliders, s = n r1 Δθ (worm)."""
    info = model.flegx
    s1, s2 = info.stand
    if abs(law.stand[0] - s1) > 1e-12 or abs(law.stand[1] - s2) > 1e-12:
        raise ModelError("flegx_jump: the motion law's stand pose must be the model's modelled pose (flegx(stand=...)).")
    if law.design:  # f(t, state): the law's variables read from the System (no recompiling)
        law.add_variables(model)
        hip = lambda t, st: law.angle(0, t, st) - s1  # noqa: E731
        if info.knee_drive == "tendon":
            knee, knee_joint = (lambda t, st: law.angle(0, t, st) + law.angle(1, t, st) - s1 - s2), "knee_wheel"
        else:
            knee, knee_joint = (lambda t, st: law.angle(1, t, st) - s2), "knee"
    else:
        hip = lambda t: law.angle(0, t) - s1  # noqa: E731
        if info.knee_drive == "tendon":
            knee, knee_joint = (lambda t: law.angle(0, t) + law.angle(1, t) - s1 - s2), "knee_wheel"
        else:
            knee, knee_joint = (lambda t: law.angle(1, t) - s2), "knee"
    if info.gears == "worm":
        from ..drives.gears import WormGear

        wg = WormGear(**D.WORM)
        a = wg.ratio * 0.5 * wg.worm_pitch_diameter  # s = n r1 θ
        if law.design:
            model.add_motion(Motion("hip_motion", "hip_worm", displacement=lambda t, st: a * hip(t, st)))
            model.add_motion(Motion("knee_motion", "knee_worm", displacement=lambda t, st: a * knee(t, st)))
        else:
            model.add_motion(Motion("hip_motion", "hip_worm", displacement=lambda t: a * hip(t)))
            model.add_motion(Motion("knee_motion", "knee_worm", displacement=lambda t: a * knee(t)))
    else:
        model.add_motion(Motion("hip_motion", "hip", displacement=hip))
        model.add_motion(Motion("knee_motion", knee_joint, displacement=knee))


def flegx_jump(configuration: int = 4, link_case: int = 2, link_model: str = "cb", gears: str = "ideal", *,
               law: MotionLaw | None = None, dt_output: float = 1e-3, rtol: float = 1e-5, atol: float = 1e-6,
               system=None, model_options: dict | None = None, progress: bool = False, **motion) -> JumpResult:
    """Simulate the countermovement jump of :func:`proleg.robots.flegx` and compute its metrics.

    Parameters
    ----------
    configuration, link_case, link_model, gears : see :func:`proleg.robots.flegx`.
    law : MotionLaw, optional     the motion law; or give its fields as keywords (``**motion``,
                                  e.g. ``t_push=0.2, extend=(-10*deg, 20*deg)``).
    dt_output : float [s]         output interval.
    rtol, atol : integrator tolerances (HHT/generalized-α, error-controlled).
    system : System, optional     an assembled system of the same model to reuse (no rebuild).
    model_options : dict          extra keywords for :func:`flegx` (``E_scale``, ``cb_modes``, ...).

    Returns
    -------
    JumpResult with ``.result`` and ``.metrics`` (module docstring).
    """
    import time

    import proleg as pl

    if law is None:
        law = MotionLaw(**motion)
    elif motion:
        raise ModelError(f"flegx_jump: give either law= or motion keywords, not both ({sorted(motion)}).")
    law.validate()
    opts = dict(model_options or {})
    model = flegx(configuration, link_case, link_model, gears, stand=law.stand, **opts)
    _add_motions(model, law)
    if system is None:
        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", message=".*redundant constraint.*")
            system = pl.assemble(model)
    t0 = time.perf_counter()
    res = pl.simulate(system, t_end=law.t_end, dt_output=dt_output, integrator=pl.GeneralizedAlpha(rtol=rtol, atol=atol, dt_max=dt_output), progress=progress)
    wall = time.perf_counter() - t0
    metrics, series = jump_metrics(res, model, law)
    return JumpResult(res, metrics, series, model, system, law, wall)


def jump_metrics(res, model, law: MotionLaw) -> tuple[dict, dict]:
    """Scalar metrics and time series of a jump (module docstring)."""
    info = model.flegx
    L, W, t_ = info.link_geometry
    t = np.asarray(res.t)
    N = np.asarray(res.contact("foot").normal_force)
    foot_z = np.asarray(res.marker("foot").position[:, 2]) - D.FOOT_RADIUS
    guide = res.part("guide")
    gz, gvz = np.asarray(guide.position[:, 2]), np.asarray(guide.velocity[:, 2])

    # stress at the clamped end
    clamp = res.joint("link.clamp")
    u2_0 = _strip_axis_local(model)
    axial = np.asarray(clamp.force_local) @ u2_0
    moment = np.asarray(clamp.torque_local)[:, 1]
    stress_clamp = np.abs(axial) / info.area + np.abs(moment) / info.section_modulus
    if info.link_model == "cb":
        stress = np.max(np.asarray(res.stress("link").von_mises), axis=1)
        cb = info.cb
        body = cb["body"]
        eta = np.asarray(res.deformation("link"))
        tip = eta @ cb["reduced"].modes[cb["tip"], 2][body.eta_cols]  # FE z: transverse, in the plane
    elif info.link_model == "prbm":
        stress = stress_clamp
        Th = np.asarray(res.joint("link.pivot").angle)
        tip = -info.prbm.gamma * L * np.sin(Th)  # along the strip's z (u2 × y), as the CB body's FE z
    else:
        stress = stress_clamp
        tip = np.zeros_like(t)

    # torques at the joints and at the worms
    w_up = np.asarray(res.part("upper_leg").angular_velocity[:, 1])
    if info.knee_drive == "tendon":
        w_knee_wheel = np.asarray(res.part("knee_wheel").angular_velocity[:, 1])
    else:
        w_knee_wheel = np.asarray(res.part("knee_flange").angular_velocity[:, 1]) - w_up
    if info.gears == "worm":
        hip_w, knee_w = worm_drive_outputs(res, model, "hip"), worm_drive_outputs(res, model, "knee")
        hip_tau, knee_wheel_tau = hip_w["wheel_torque"], knee_w["wheel_torque"]
    else:
        hip_tau = np.asarray(res.motion("hip_motion").effort)
        knee_wheel_tau = np.asarray(res.motion("knee_motion").effort)
        hip_w = worm_torques(hip_tau, w_up, "ideal")
        knee_w = worm_torques(knee_wheel_tau, w_knee_wheel, "ideal")
    if info.knee_drive == "tendon":
        K = np.asarray(res.marker("knee.I").position)
        knee_joint_tau = np.zeros_like(t)
        for s in "ab":
            jr = res.joint(f"tendon_{s}.knee")  # reaction on the rod; the flange gets −F
            B = np.asarray(res.marker(f"tendon_{s}.knee.J").position)
            knee_joint_tau += np.cross(B - K, -np.asarray(jr.force))[:, 1]
    else:
        knee_joint_tau = knee_wheel_tau

    # take-off and landing (module docstring): the flight that contains the guide's highest
    # airborne point after the push starts; the jump height is that point above the standing height
    jump, (i_to, i_ld) = jump_flight(t, gz, N, law)
    m = dict(total_mass=info.total_mass, **jump)
    i_end = i_to + 1 if jump["flights"] else len(t)  # the take-off phase: samples [0, i_end)
    m.update(max_stress_takeoff=float(np.max(stress[:i_end])),
             peak_hip_torque_takeoff=float(np.max(np.abs(hip_tau[:i_end]))),
             peak_knee_torque_takeoff=float(np.max(np.abs(knee_joint_tau[:i_end]))))
    if jump["flights"]:
        m.update(foot_clearance=float(np.max(foot_z[i_to : i_ld + 1])), take_off_velocity=float(gvz[i_to]))
    else:
        m.update(foot_clearance=0.0, take_off_velocity=math.nan)
    m.update(
        max_stress=float(np.max(stress)), max_stress_clamp_reaction=float(np.max(stress_clamp)),
        tip_displacement=float(np.max(np.abs(tip))),
        peak_hip_torque=float(np.max(np.abs(hip_tau))), peak_knee_torque=float(np.max(np.abs(knee_joint_tau))),
        peak_knee_wheel_torque=float(np.max(np.abs(knee_wheel_tau))),
        peak_hip_torque_worm=float(np.max(np.abs(hip_w["worm_torque"]))),
        peak_knee_torque_worm=float(np.max(np.abs(knee_w["worm_torque"]))),
        motor_energy=float(np.trapezoid(np.abs(hip_w["power_in"]) + np.abs(knee_w["power_in"]), t)),
        motor_work_positive=float(np.trapezoid(np.clip(hip_w["power_in"], 0, None) + np.clip(knee_w["power_in"], 0, None), t)),
        mesh_loss_energy=float(np.trapezoid(hip_w["mesh_loss"] + knee_w["mesh_loss"], t)),
        peak_ground_force=float(np.max(N)), steps=res.stats["steps"],
    )
    series = {
        "time [s]": t, "guide_z [m]": gz, "guide_vz [m/s]": gvz, "foot_clearance [m]": foot_z, "ground_force [N]": N,
        "clamp_stress [Pa]": stress, "clamp_stress_reaction [Pa]": stress_clamp, "tip_displacement [m]": tip,
        "hip_torque [N m]": hip_tau, "knee_wheel_torque [N m]": knee_wheel_tau, "knee_joint_torque [N m]": knee_joint_tau,
        "hip_worm_torque [N m]": hip_w["worm_torque"], "knee_worm_torque [N m]": knee_w["worm_torque"],
        "hip_speed [rad/s]": w_up, "knee_wheel_speed [rad/s]": w_knee_wheel,
        "hip_power_in [W]": hip_w["power_in"], "knee_power_in [W]": knee_w["power_in"],
        "hip_power_out [W]": hip_w["power_out"], "knee_power_out [W]": knee_w["power_out"],
        "hip_mesh_loss [W]": hip_w["mesh_loss"], "knee_mesh_loss [W]": knee_w["mesh_loss"],
    }
    if info.gears == "worm":  # the rest of the drives' energy bookkeeping (worm_drive_outputs)
        for d, o in (("hip", hip_w), ("knee", knee_w)):
            for k in ("spring_energy", "damping_power", "worm_kinetic_energy"):
                series[f"{d}_{k} [{'W' if k.endswith('power') else 'J'}]"] = o[k]
    return m, series


def worm_drive_outputs(res, model, drive: str) -> dict:
    """The worm drive ``drive`` ("hip" or "knee") of a ``gears="worm"`` run, recomputed from the
    result with the same :func:`~proleg.drives.gears.worm_mesh` the dynamics used.

    Returns arrays (n,): ``wheel_torque`` T [N m] (on the wheel about its joint axis),
    ``worm_torque`` r1 F_motor [N m] (the motor's torque at the worm: the Motion's effort times
    r1), ``worm_speed`` [rad/s], ``power_in`` (motor) and ``power_out`` (T φ̇ into the wheel)
    [W], ``mesh_loss`` (friction power μ W v_s) and ``damping_power`` (c δ̇²) [W],
    ``spring_energy`` [J] (mesh) and ``worm_kinetic_energy`` [J] (rotor, relative to the
    housing), ``mu``, ``sliding_speed`` [m/s], ``normal_force`` [N], ``efficiency`` (power_out /
    power_in where the worm drives, NaN elsewhere), ``back_efficiency`` (power_in / power_out
    where the wheel drives). Work balance: power_in = power_out + mesh_loss + damping_power +
    d/dt(spring_energy + worm_kinetic_energy) (the test of ``gears="worm"``).
    """
    import jax.numpy as jnp

    from ..drives.gears import WormGear, worm_mesh

    wg = WormGear(**D.WORM)
    r1 = 0.5 * wg.worm_pitch_diameter
    wheel_joint = {"hip": "hip", "knee": "knee_wheel" if model.flegx.knee_drive == "tendon" else "knee"}[drive]
    pj = res.joint(f"{drive}_worm")
    zs = np.asarray(res.marker(f"{drive}_worm.J").orientation)[:, :, 2]
    sd = np.sum(zs * (np.asarray(res.marker(f"{drive}_worm.I").velocity) - np.asarray(res.marker(f"{drive}_worm.J").velocity)), -1)
    wi, wj = (np.asarray(res.marker(f"{wheel_joint}.{e}").angular_velocity) for e in "IJ")
    zw = np.asarray(res.marker(f"{wheel_joint}.J").orientation)[:, :, 2]
    phid = np.sum(zw * (wi - wj), -1)
    p = res.system.params
    r2c = 0.5 * wg.wheel_pitch_diameter * math.cos(wg.lead_angle)
    out = {k: np.asarray(v) for k, v in worm_mesh(
        wg, jnp.asarray(pj.translation), jnp.asarray(sd), jnp.asarray(res.joint(wheel_joint).angle), jnp.asarray(phid),
        D.WORM_MESH_STIFFNESS / r2c**2, D.WORM_MESH_DAMPING / r2c**2, p["variable_worm_f_static"], p["variable_worm_f_dynamic"],
        D.WORM_V_STATIC, D.WORM_V_DYNAMIC).items()}
    F = np.asarray(res.motion(f"{drive}_motion").effort)
    m = next(q.mass for q in model.parts if q.name == f"{drive}_worm")
    P_in, P_out = F * sd, out["wheel_torque"] * phid
    with np.errstate(invalid="ignore", divide="ignore"):
        eff = np.where((P_in > 0) & (P_out > 0), P_out / P_in, np.nan)
        back = np.where((P_in < 0) & (P_out < 0), P_in / P_out, np.nan)
    return dict(wheel_torque=out["wheel_torque"], worm_torque=F * r1, worm_speed=sd / r1, power_in=P_in, power_out=P_out,
                mesh_loss=out["friction_power"], damping_power=D.WORM_MESH_DAMPING / r2c**2 * out["approach_rate"] ** 2,
                spring_energy=out["spring_energy"], worm_kinetic_energy=0.5 * m * sd**2, mu=out["mu"],
                sliding_speed=out["sliding_speed"], normal_force=out["normal_force"], efficiency=eff, back_efficiency=back)


def jump_flight(t, guide_z, normal_force, law: MotionLaw) -> tuple[dict, tuple[int, int]]:
    """The jump in a run (module docstring, "Jump metrics"): ``jump_height`` [m], ``flight_rise`` [m],
    ``take_off_time``/``landing_time``/``apex_time`` [s], ``flights`` (airborne phases after the push
    starts), and the indices (take-off, landing) of the flight (landing: the last sample if the
    run ends in the air).

    t (n,) [s], guide_z (n,) [m] guide (hip) height, normal_force (n,) [N] foot contact force;
    airborne = zero contact force. Robust to touch-and-go and to the hops after the landing: the
    jump is the flight that holds the highest airborne guide position, and its height is measured
    from the standing height (the guide at the end of ``t_settle``), not from a take-off.
    """
    t, gz, N = (np.asarray(a, float) for a in (t, guide_z, normal_force))
    i0 = int(np.searchsorted(t, law.push_start))
    air = np.r_[False, N[i0:] <= 0.0, False]
    edges = np.flatnonzero(np.diff(air.astype(int)))
    starts, ends = i0 + edges[0::2], i0 + edges[1::2]  # flight k: samples starts[k] ... ends[k] - 1
    if not starts.size:
        return dict(jump_height=0.0, flight_rise=0.0, take_off_time=math.nan, landing_time=math.nan, apex_time=math.nan,
                    flights=0), (len(t) - 1, len(t) - 1)
    z_air = np.where(air[1:-1], gz[i0:], -np.inf)
    i_apex = i0 + int(np.argmax(z_air))
    k = int(np.flatnonzero((starts <= i_apex) & (i_apex < ends))[0])
    i_to, i_end = int(starts[k]), int(ends[k])
    landed = i_end < len(t)
    i_ld = min(i_end, len(t) - 1)
    z_stand = gz[int(np.searchsorted(t, law.t_settle))]
    return dict(jump_height=float(max(gz[i_apex] - z_stand, 0.0)), flight_rise=float(gz[i_apex] - gz[i_to]),
                take_off_time=float(t[i_to]), landing_time=float(t[i_ld]) if landed else math.nan,
                apex_time=float(t[i_apex]), flights=int(starts.size)), (i_to, i_ld)


def _strip_axis_local(model):
    """Strip direction in the clamp's marker-I axes (constant: the marker is fixed to the strip)."""
    j = next(j for j in model.joints if j.name == "link.clamp")
    mI = j.marker_i
    th1, th2 = model.flegx.stand
    u2 = np.array([-math.sin(th1 + th2), 0.0, -math.cos(th1 + th2)])
    return mI.orientation.T @ u2
