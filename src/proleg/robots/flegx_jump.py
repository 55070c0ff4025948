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
No. 4 leg and the 250×70×3 CB link this gives a 91 mm jump, 432 MPa at take-off and
506 MPa at landing, 35 mm tip displacement (PRBM link: 103 mm; the rigid link does not take off) (the paper: 104 mm / 531 MPa, Table I; 447 MPa
and 32 mm for its 50 mm machinery jump, Fig. 4). The push is close to the leg's bounce
period on the strip (≈ 0.2-0.3 s), so the flexible link stores and returns energy: shorter
pushes jump much higher on the flexible link than on the rigid one.
The motions are imposed on the hip joint and on the knee wheel (No. 4: θ1 + θ2 through the
tendon parallelogram) or the knee joint (No. 1-3), as the paper imposes motion laws "as a
function of time" on the hip and knee.

Jump metrics
------------
- ``take_off_time`` [s] and ``landing_time``: start and end (first and last-plus-one output
  with zero foot normal force) of the flight that contains the guide's highest point after
  the push starts (none: the leg did not jump, ``jump_height`` = 0): a brief
  touch-and-go of the still-extending leg before the main flight, and the hops after the
  landing (the strip springs back), are not the jump. ``flights`` counts all airborne phases.
- ``jump_height`` [m]: the paper's "jumping height" is taken as the **guide's rise** from
  take-off to the apex of the flight (the hip's ballistic rise, ≈ v²/2g with v the take-off
  velocity; the usual jump height of jumping biomechanics). ``foot_clearance`` is the highest
  position of the foot cylinder's lowest point above the ground during the flight (smaller:
  the leg is still extending when the foot leaves the ground).
- ``max_stress`` [Pa]: von Mises at the clamped end of the strip, over the whole run
  (take-off and landing; ``max_stress_takeoff`` up to take-off, Table I's phase). CB: stress
  recovery of the modal body (σ_xx at the root surfaces). Rigid and PRBM: from the clamp's
  reaction, |N|/A + |M| / (W t²/6) (the beam formula for the same section).
- ``tip_displacement`` [m]: max free-end displacement transverse to the strip relative to the
  clamped end (CB: modal deformation of the tip node; PRBM: γ L sin Θ; rigid: 0); the series
  ``tip_displacement`` is signed along the strip's thickness axis u2 × y (u2 from knee to foot).
- ``peak_hip_torque``/``peak_knee_torque`` [N m]: at the joint (wheel side) and, as
  ``*_worm``, at the worm (motor side) with :func:`worm_torques` for the model's ``gears``.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field

import numpy as np

from ..errors import ModelError
from ..model.control import Motion
from ..units import deg
from . import flegx_data as D
from .flegx import check_angles, flegx

__all__ = ["MotionLaw", "flegx_jump", "JumpResult", "worm_torques", "worm_friction", "jump_metrics"]


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

    def angle(self, k: int, t):
        """θ_k(t) [rad] (k = 0 hip, 1 knee), JAX-traceable."""
        from ..fn import step

        out = self.stand[k]
        for a, b, p0, p1 in self._knots():
            out = out + step(t, a, 0.0, b, p1[k] - p0[k])
        return out

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
    """Torque and power at the worm for a given torque and speed at the wheel (seed 002 Eqs. 16-17).

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
    info = model.flegx
    s1, s2 = info.stand
    if abs(law.stand[0] - s1) > 1e-12 or abs(law.stand[1] - s2) > 1e-12:
        raise ModelError("flegx_jump: the motion law's stand pose must be the model's modelled pose (flegx(stand=...)).")
    model.add_motion(Motion("hip_motion", "hip", displacement=lambda t: law.angle(0, t) - s1))
    if info.knee_drive == "tendon":
        model.add_motion(Motion("knee_motion", "knee_wheel", displacement=lambda t: law.angle(0, t) + law.angle(1, t) - s1 - s2))
    else:
        model.add_motion(Motion("knee_motion", "knee", displacement=lambda t: law.angle(1, t) - s2))


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
    res = pl.simulate(system, t_end=law.t_end, dt_output=dt_output, integrator=pl.GeneralizedAlpha(rtol=rtol, atol=atol), progress=progress)
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
    hip_tau = np.asarray(res.motion("hip_motion").effort)
    knee_wheel_tau = np.asarray(res.motion("knee_motion").effort)
    w_up = np.asarray(res.part("upper_leg").angular_velocity[:, 1])
    if info.knee_drive == "tendon":
        w_knee_wheel = np.asarray(res.part("knee_wheel").angular_velocity[:, 1])
        K = np.asarray(res.marker("knee.I").position)
        knee_joint_tau = np.zeros_like(t)
        for s in "ab":
            jr = res.joint(f"tendon_{s}.knee")  # reaction on the rod; the flange gets −F
            B = np.asarray(res.marker(f"tendon_{s}.knee.J").position)
            knee_joint_tau += np.cross(B - K, -np.asarray(jr.force))[:, 1]
    else:
        w_knee_wheel = np.asarray(res.part("knee_flange").angular_velocity[:, 1]) - w_up
        knee_joint_tau = knee_wheel_tau
    hip_w = worm_torques(hip_tau, w_up, info.gears)
    knee_w = worm_torques(knee_wheel_tau, w_knee_wheel, info.gears)

    # take-off and landing: the flight that contains the guide's apex after the push starts (a
    # touch-and-go of the still-extending leg, or the hops after landing, are not the jump)
    i0 = int(np.searchsorted(t, law.push_start))
    air = np.r_[False, N[i0:] <= 0.0, False]
    edges = np.flatnonzero(np.diff(air.astype(int)))
    starts, ends = edges[0::2], edges[1::2]  # flight k: samples i0 + starts[k] ... i0 + ends[k] - 1
    m = dict(total_mass=info.total_mass)
    k_apex = int(np.argmax(gz[i0:]))
    hit = np.flatnonzero((starts <= k_apex) & (k_apex < ends))
    if hit.size:
        k = int(hit[0])
        i_to = i0 + int(starts[k])
        landed = i0 + int(ends[k]) < len(t)
        i_ld = min(i0 + int(ends[k]), len(t) - 1)
        flight = slice(i_to, i_ld + 1)
        m.update(take_off_time=float(t[i_to]), landing_time=float(t[i_ld]) if landed else math.nan,
                 jump_height=float(np.max(gz[flight]) - gz[i_to]), foot_clearance=float(np.max(foot_z[flight])),
                 take_off_velocity=float(gvz[i_to]), max_stress_takeoff=float(np.max(stress[: i_to + 1])),
                 flights=int(starts.size))
    else:
        m.update(take_off_time=math.nan, landing_time=math.nan, jump_height=0.0, foot_clearance=0.0,
                 take_off_velocity=math.nan, max_stress_takeoff=float(np.max(stress)), flights=0)
    m.update(
        max_stress=float(np.max(stress)), max_stress_clamp_reaction=float(np.max(stress_clamp)),
        tip_displacement=float(np.max(np.abs(tip))),
        peak_hip_torque=float(np.max(np.abs(hip_tau))), peak_knee_torque=float(np.max(np.abs(knee_joint_tau))),
        peak_knee_wheel_torque=float(np.max(np.abs(knee_wheel_tau))),
        peak_hip_torque_worm=float(np.max(np.abs(hip_w["worm_torque"]))),
        peak_knee_torque_worm=float(np.max(np.abs(knee_w["worm_torque"]))),
        motor_energy=float(np.trapezoid(np.abs(hip_w["power_in"]) + np.abs(knee_w["power_in"]), t)),
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
    return m, series


def _strip_axis_local(model):
    """Strip direction in the clamp's marker-I axes (constant: the marker is fixed to the strip)."""
    j = next(j for j in model.joints if j.name == "link.clamp")
    mI = j.marker_i
    th1, th2 = model.flegx.stand
    u2 = np.array([-math.sin(th1 + th2), 0.0, -math.cos(th1 + th2)])
    return mI.orientation.T @ u2
