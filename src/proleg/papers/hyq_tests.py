"""Virtual bench tests of the HyQ leg (seed 000 §3; seed 001 drop test) and synthetic bench data.

Each test builds :func:`proleg.robots.hyq_leg`, runs a proleg analysis and returns a
:class:`BenchTest`: the Results plus derived pandas tables (units in the column names).

- :func:`static_test`: payloads 0, 3, 7 kg on the slider, static equilibrium on the plate:
  pose, cylinder forces, joint angles SU and UL, GRF, and (rigid model) the joint torques by
  virtual work next to cylinder force × lever arm.
- :func:`quasistatic_test`: from the equilibrium, a Motion moves the slider sinusoidally up and
  down; force-stroke loops of both cylinders and the seed 000 Eq. 4/5 identification of k and c.
- :func:`drop_test`: the leg falls from ``drop_height`` (foot above the plate) and oscillates to
  rest: slider displacement, cylinder forces, joint angles and the 3-axis GRF against time.
- :func:`bench_measurement`: "measured" data as the seed's instruments would record them, from
  a higher-fidelity variant (8 bushings, perturbed parameters).

Scenario entry points writing files (:func:`run_static`, :func:`run_quasistatic`, :func:`run_drop`)
are in hyq_report.py, which builds on this module.
Sign conventions: cylinder force = actuator axial force, positive pushing (cylinder in
compression, extending); GRF = contact force on the foot (z up); SU = θ1 (HFE), UL = θ2 (KFE).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import pandas as pd

from ..analyses.equilibrium import solve_equilibrium
from ..analyses.result import Result
from ..analyses.simulate import simulate
from ..solvers.galpha import GeneralizedAlpha
from ..assembly.constraints import joint_angle
from ..assembly.assemble import assemble
from ..assembly.system import constraints, generalized_forces, kinematics
from ..errors import ModelError
from ..model.control import Motion
from ..units import deg
from ..robots import hyq_data as D
from ..robots.hyq_leg import cylinder_forces, hyq_leg, joint_angles
from ..compile_cache import jit

__all__ = [
    "BenchTest",
    "static_test",
    "quasistatic_test",
    "drop_test",
    "drop_summary",
    "joint_torques",
    "bench_measurement",
    "variant_system",
]


@dataclass
class BenchTest:
    """Outcome of a virtual bench test: ``results`` (name → Result), ``tables`` (name → DataFrame),
    ``models`` (name → Model) and ``systems`` (name → System)."""

    name: str
    results: dict = field(default_factory=dict)
    tables: dict = field(default_factory=dict)
    models: dict = field(default_factory=dict)
    systems: dict = field(default_factory=dict)

    @property
    def result(self) -> Result:
        """The first (or only) Result."""
        return next(iter(self.results.values()))


# ------------------------------------------------------------------------------------------
# helpers
# ------------------------------------------------------------------------------------------
def equilibrium_result(eq) -> Result:
    """A one-sample Result of an Equilibrium that carries the servo commands at the equilibrium
    (the controllers' static law, as :func:`proleg.solve_equilibrium` evaluates them)."""
    from ..analyses.simulate import initial_z
    from ..solvers.driver import sample_controllers_first

    system = eq.system
    q = jnp.asarray(eq.q)
    z = sample_controllers_first(system, eq.t, q, jnp.zeros_like(q), initial_z(system))
    return Result(system, np.array([eq.t]), q[None], jnp.zeros((1, q.size)), jnp.zeros((1, 2)), z[None], message="equilibrium")


def _slider_z(result) -> np.ndarray:
    b = result.system.topo.body_names.index("slider")
    return np.asarray(result.q)[:, 7 * b + 2]


def channels(result, *, light: bool = False) -> pd.DataFrame:
    """The bench channels of a Result: slider height and displacement, cylinder forces, SU, UL,
    3-axis GRF, servo torques and the energy terms, one row per output time.

    ``light=True`` keeps the slider, force and GRF channels only (one output evaluation instead
    of three: for parameter sweeps)."""
    z = _slider_z(result)
    fh, fk = cylinder_forces(result)
    grf = np.asarray(result.contact("foot").force) if "foot" in _contact_names(result) else np.zeros((len(z), 3))
    df = pd.DataFrame(
        {
            "time [s]": result.t,
            "slider z [m]": z,
            "slider displacement [m]": z - z[0],
            "hip force [N]": fh,
            "knee force [N]": fk,
            "GRF x [N]": grf[:, 0],
            "GRF y [N]": grf[:, 1],
            "GRF z [N]": grf[:, 2],
        }
    )
    if light:
        return df
    th1, th2 = joint_angles(result)
    df.insert(5, "SU [deg]", th1 / deg)
    df.insert(6, "UL [deg]", th2 / deg)
    for side in ("hip", "knee"):
        name = f"{side}_servo"
        if any(name in g.names for g in result.system.topo.extensions if g.kind == "controller"):
            df[f"{side} servo torque [N m]"] = np.asarray(result.controller(name).state)[:, 0]
    for side in ("hip", "knee"):
        el = result.element(f"{side}_actuator")
        df[f"{side} cylinder length [m]"] = np.asarray(el.length)
    if len(result.t) > 1:
        e = result.energy
        for k in ("kinetic", "potential", "dissipated", "input", "total"):
            df[f"energy {k} [J]"] = np.asarray(e[k])
    return df


def _contact_names(result):
    return [n for g in result.system.topo.extensions if g.kind == "contact" for n in g.names]


_TORQUE_MARKERS = ("hip.I", "hip.J", "knee.I", "knee.J", "hip_actuator.I", "hip_actuator.J", "knee_actuator.I", "knee_actuator.J")


@jit
def _torque_pieces(system, q, t):
    """Φ_q, ∂(z, θ1, θ2)/∂q, ∂(ℓ_hip, ℓ_knee)/∂q and the generalized forces without actuators."""
    from ..analyses.simulate import initial_z

    topo = system.topo
    mi = {k: topo.marker_names.index(k) for k in _TORQUE_MARKERS}
    b = topo.body_names.index("slider")

    def coords(qq):
        _, mk = kinematics(system, qq)
        th1 = joint_angle(mk.R[mi["hip.I"]][None], mk.R[mi["hip.J"]][None])[0]
        th2 = joint_angle(mk.R[mi["knee.I"]][None], mk.R[mi["knee.J"]][None])[0]
        ell = [jnp.linalg.norm(mk.r[mi[f"{s}_actuator.I"]] - mk.r[mi[f"{s}_actuator.J"]]) for s in ("hip", "knee")]
        return jnp.stack([qq[7 * b + 2], th1, th2]), jnp.stack(ell)

    Pq = jax.jacfwd(lambda x: constraints(system, x, t))(q)
    G = jax.jacfwd(lambda x: coords(x)[0])(q)
    L = jax.jacfwd(lambda x: coords(x)[1])(q)
    passive = system.with_params(hydraulic_actuator_stiffness=jnp.zeros(2), hydraulic_actuator_damping=jnp.zeros(2))
    Q = generalized_forces(passive, q, jnp.zeros_like(q), t, jnp.zeros_like(initial_z(system)))
    return Pq, G, L, Q


def joint_torques(system, q, t: float = 0.0) -> dict:
    """Joint torques by virtual work at a static pose ``q`` of the **rigid** model.

    The tangent vectors δq_k of unit slider height, θ1 and θ2 (the other two held) solve
    [Φ_q; ∂(z, θ1, θ2)/∂q] δq = e_k. With every load except the two hydraulic actuators
    (gravity of all parts, contact), Q_o, the torque the hip actuator must supply is
    τ1 = −Q_o·δq_θ1 (knee likewise); the cylinder length rates dℓ/dθ = ∇ℓ·δq_θ are the signed
    lever arms (MODEL_DATA §1: +l1, −l2). In equilibrium F_cyl · dℓ/dθ = τ exactly.

    Returns dict with ``hip_torque``, ``knee_torque`` [N m], ``hip_lever``, ``knee_lever`` [m]
    (signed, from the model), ``cross`` (dℓ_hip/dθ2, dℓ_knee/dθ1, both 0 for this linkage) and
    ``vertical_force`` [N] (generalized force along the slider of the non-actuator loads).
    """
    if not any(j.name == "hip" for j in system.topo.joints):
        raise ModelError("joint_torques needs the rigid model (joints='rigid'): the bushing models have no hip joint to rotate.")
    Pq, G, L, Q = (np.asarray(a) for a in _torque_pieces(system, jnp.asarray(q), jnp.asarray(t, jnp.float64)))
    A = np.vstack([Pq, G])
    if A.shape[0] != A.shape[1]:
        raise ModelError(f"joint_torques: expected a 3-DOF rigid model, the constraint set has {Pq.shape[0]} rows for {Pq.shape[1]} coordinates.")
    rhs = np.zeros((A.shape[0], 3))
    rhs[-3:] = np.eye(3)
    X = np.linalg.solve(A, rhs)
    W = Q @ X
    dl = L @ X
    return {
        "hip_torque": float(-W[1]),
        "knee_torque": float(-W[2]),
        "hip_lever": float(dl[0, 1]),
        "knee_lever": float(dl[1, 2]),
        "cross": (float(dl[0, 2]), float(dl[1, 1])),
        "vertical_force": float(W[0]),
    }


# ------------------------------------------------------------------------------------------
# static test
# ------------------------------------------------------------------------------------------
def static_test(payloads=(0.0, 3.0, 7.0), *, joints: str = "rigid", gain: str = "high", **model_kw) -> BenchTest:
    """Seed 000 static test: the leg standing on the force plate under 0, 3 and 7 kg payloads.

    One model (quasi-static Table 2 row, seed 000: "used ... for the numerical static
    simulation"), assembled once; each payload changes the slider mass by ``with_params``.

    Returns a BenchTest with ``results["payload 3 kg"]`` (one-sample Results) and
    ``tables["static"]``: payload [kg], total weight [N], slider z [m], SU/UL [deg], hip/knee
    force [N], GRF x/y/z [N], and for the rigid model the joint torques by virtual work and the
    MODEL_DATA lever arms with force × lever [N m].
    """
    payloads = [float(p) for p in payloads]
    for p in payloads:
        if not np.isfinite(p) or p < 0:
            raise ModelError(f"static_test: payload must be ≥ 0 kg, got {p}.")
    model_kw.setdefault("actuators", "quasi-static")
    model = hyq_leg(joints=joints, gain=gain, payload=0.0, drop_height=0.0, **model_kw)
    system = assemble(model)
    m_slider = model.part("slider").mass
    g = float(np.linalg.norm(model.gravity))
    out = BenchTest("static", models={"static": model}, systems={"static": system})
    rows = []
    q_guess = None
    # Force tolerance (relative to the heaviest weight): round-off in 1e8 N/m bushings leaves
    # residuals of ~1e-10 of the weight, so the bushing models are solved to 1e-9.
    tol = 1e-10 if joints == "rigid" else 1e-9
    for p in payloads:
        sp = system.with_params({"slider.mass": m_slider + p})
        eq = solve_equilibrium(sp, q_guess, tol=tol)
        q_guess = eq.q
        res = equilibrium_result(eq)
        key = f"payload {p:g} kg"
        out.results[key] = res
        ch = channels(res).iloc[0]
        weight = (model.hyq.total_mass + p) * g
        row = {
            "payload [kg]": p,
            "total weight [N]": weight,
            "slider z [m]": ch["slider z [m]"],
            "SU [deg]": ch["SU [deg]"],
            "UL [deg]": ch["UL [deg]"],
            "hip force [N]": ch["hip force [N]"],
            "knee force [N]": ch["knee force [N]"],
            "GRF x [N]": ch["GRF x [N]"],
            "GRF y [N]": ch["GRF y [N]"],
            "GRF z [N]": ch["GRF z [N]"],
            "GRF z / weight [-]": ch["GRF z [N]"] / weight,
        }
        if joints == "rigid":
            jt = joint_torques(sp, eq.q, eq.t)
            th1, th2 = ch["SU [deg]"] * deg, ch["UL [deg]"] * deg
            row.update(
                {
                    "hip torque [N m]": jt["hip_torque"],
                    "knee torque [N m]": jt["knee_torque"],
                    "hip lever l1 [m]": float(D.hip_lever_arm(th1)),
                    "knee lever l2 [m]": float(D.knee_lever_arm(th2)),
                    "hip force × l1 [N m]": ch["hip force [N]"] * float(D.hip_signed_lever(th1)),
                    "knee force × l2 [N m]": ch["knee force [N]"] * float(D.knee_signed_lever(th2)),
                    "hip lever (model) [m]": jt["hip_lever"],
                    "knee lever (model) [m]": jt["knee_lever"],
                }
            )
        rows.append(row)
    out.tables["static"] = pd.DataFrame(rows)
    return out


# ------------------------------------------------------------------------------------------
# quasi-static test
# ------------------------------------------------------------------------------------------
def loop_identification(stroke, force, frequency) -> dict:
    """Seed 000 Eqs. 4-5 on one force-stroke loop: k = slope of the least-squares (RMS) line
    F = k δ + F0 [N/m]; c = ΔE_cyc / (π ω X²) [N s/m] with ΔE_cyc = |∮ F dδ| and X the stroke
    half-range."""
    stroke, force = np.asarray(stroke), np.asarray(force)
    k, f0 = np.polyfit(stroke, force, 1)
    dE = abs(np.trapezoid(force, stroke)) if hasattr(np, "trapezoid") else abs(np.trapz(force, stroke))
    X = 0.5 * (stroke.max() - stroke.min())
    omega = 2 * np.pi * frequency
    c = dE / (np.pi * omega * X**2) if X > 0 else np.nan
    return {"k [N/m]": k, "F0 [N]": f0, "loop energy [J]": dE, "stroke amplitude [m]": X, "c [N s/m]": c}


def quasistatic_test(
    amplitude: float = 0.003, frequency: float = 0.5, cycles: int = 2, *, offset: float | None = None, joints: str = "rigid",
    gain: str = "high", dt_output: float = 2e-3, progress: bool = False, **model_kw
) -> BenchTest:
    """Seed 000 quasi-static test: from the standing equilibrium the slider is pushed down and
    pulled up by a Motion on the slider joint, Δz(t) = s(t) (offset + amplitude · sin(2π f t)),
    with s(t) a cubic ramp from 0 to 1 over the first half period (the leg starts at rest: with
    the Table 2 dampers, c ≈ 1e6 N s/m, a velocity jump would load the cylinders with kN).

    With Table 2's quasi-static dampers (hip c = 2.1e6 N s/m) the leg relaxes with time
    constants c/k of seconds: at 0.5 Hz the cylinders barely stroke (< 1 mm), the rubber foot
    takes most of the slider motion and the foot lifts off near the top of each cycle even with
    the default ``offset = −amplitude`` (the slider cycles between the equilibrium and
    2 × amplitude below it). The loops are then not ellipses: the loop energy gives c close to
    Table 2 (seed 000 Eq. 5), but the least-squares slope is not a stiffness.

    Parameters
    ----------
    amplitude : float [m], default 3 mm
    frequency : float [Hz]    cycles : int (full periods after the half-period ramp)
    offset : float [m], default −amplitude

    Returns a BenchTest with ``results["quasi-static"]``, ``tables["channels"]`` (time
    histories, with cylinder strokes) and ``tables["identification"]`` (k and c of the last
    loop of each cylinder by seed 000 Eqs. 4-5, next to the Table 2 inputs).
    """
    if not amplitude > 0 or not frequency > 0 or int(cycles) < 1:
        raise ModelError(f"quasistatic_test: amplitude [m] and frequency [Hz] must be positive and cycles ≥ 1, got {amplitude}, {frequency}, {cycles}.")
    model_kw.setdefault("actuators", "quasi-static")
    free = hyq_leg(joints=joints, gain=gain, drop_height=0.0, **model_kw)
    eq = solve_equilibrium(assemble(free))
    z_eq = float(_slider_z(equilibrium_result(eq))[0] - free.hyq.slider_height)
    model = hyq_leg(joints=joints, gain=gain, drop_height=0.0, **model_kw)
    w = 2 * np.pi * frequency
    t_ramp = 0.5 / frequency

    offset = -amplitude if offset is None else float(offset)

    def pull(t):
        h = jnp.clip(t / t_ramp, 0.0, 1.0)
        return z_eq + (offset + amplitude * jnp.sin(w * t)) * h * h * (3.0 - 2.0 * h)

    model.add_motion(Motion("pull", joint="slider", displacement=pull))
    system = assemble(model)
    t_end = t_ramp + cycles / frequency
    res = simulate(system, t_end=t_end, dt_output=dt_output, q0=eq.q, progress=progress)
    df = channels(res)
    for side in ("hip", "knee"):
        df[f"{side} stroke [m]"] = df[f"{side} cylinder length [m]"] - df[f"{side} cylinder length [m]"].iloc[0]
    last = df["time [s]"] >= t_end - 1.0 / frequency - 1e-12
    coef = model.hyq.coefficients
    ident = []
    for side in ("hip", "knee"):
        row = {"cylinder": side, **loop_identification(df.loc[last, f"{side} stroke [m]"], df.loc[last, f"{side} force [N]"], frequency)}
        row["Table 2 k [N/m]"] = coef[f"{side}_k"]
        row["Table 2 c [N s/m]"] = coef[f"{side}_c"]
        ident.append(row)
    return BenchTest(
        "quasi-static",
        results={"quasi-static": res},
        tables={"channels": df, "identification": pd.DataFrame(ident)},
        models={"quasi-static": model},
        systems={"quasi-static": system},
    )


# ------------------------------------------------------------------------------------------
# drop test
# ------------------------------------------------------------------------------------------
def drop_summary(df: pd.DataFrame, band: float = 0.02) -> dict:
    """Peak forces, peak GRF, first contact and settling time of one drop (channels table).

    Settling time: from release until the slider stays within ``band`` × its total travel
    |z(end) − z(0)| of its final value (the mean of the last 5 % of samples). The "5 ms"
    peaks are those of a centred 5 ms moving average, roughly what a load cell of 200 Hz
    bandwidth reads (the bushing models ring at several hundred Hz after the impact).
    """
    t = df["time [s]"].to_numpy()
    z = df["slider z [m]"].to_numpy()
    n_tail = max(1, len(t) // 20)
    z_end = float(np.mean(z[-n_tail:]))
    tol = band * abs(z_end - z[0])
    outside = np.nonzero(np.abs(z - z_end) > tol)[0]
    t_settle = float(t[min(outside[-1] + 1, len(t) - 1)]) if outside.size else 0.0
    grf = df["GRF z [N]"].to_numpy()
    touch = np.nonzero(grf > 1.0)[0]
    dt = float(np.median(np.diff(t))) if len(t) > 1 else 1.0
    n_avg = max(1, int(round(5e-3 / dt)))

    def smooth_peak(col):
        x = df[col].to_numpy()
        if len(x) >= n_avg:
            x = np.convolve(x, np.ones(n_avg) / n_avg, mode="same")
        return float(np.max(np.abs(x)))

    return {
        "peak hip force [N]": float(np.max(np.abs(df["hip force [N]"]))),
        "peak knee force [N]": float(np.max(np.abs(df["knee force [N]"]))),
        "peak hip force, 5 ms [N]": smooth_peak("hip force [N]"),
        "peak knee force, 5 ms [N]": smooth_peak("knee force [N]"),
        "peak GRF z [N]": float(np.max(grf)),
        "peak |GRF x| [N]": float(np.max(np.abs(df["GRF x [N]"]))),
        "first contact [s]": float(t[touch[0]]) if touch.size else np.nan,
        "settling time [s]": t_settle,
        "final slider displacement [m]": z_end - z[0],
        "final SU [deg]": float(df["SU [deg]"].iloc[-n_tail:].mean()),
        "final UL [deg]": float(df["UL [deg]"].iloc[-n_tail:].mean()),
    }


def drop_test(
    joints: str = "rigid", gain: str = "high", drop_height: float = 0.05, t_end: float = 1.2, *,
    dt_output: float = 1e-3, progress: bool = False, system=None, rtol: float = 1e-6, atol: float = 1e-7,
    light: bool = False, **model_kw
) -> BenchTest:
    """Seed 000/001 drop test: released with the foot ``drop_height`` above the plate (the leg
    at its servo setpoints, all at rest), free to bounce and oscillate to rest.

    The release starts a free fall with every element unloaded, which is the exact state of
    the leg at release (in free fall no internal force is needed). Pass ``system`` (an
    assembled model of the same kind) to reuse a compiled System, e.g. with changed parameters.

    Returns a BenchTest with ``results["drop"]``, ``tables["channels"]`` and ``tables["summary"]``
    (``light=True``: force channels only, no summary; see :func:`channels`).
    """
    model_kw.setdefault("actuators", "drop")
    model = hyq_leg(joints=joints, gain=gain, drop_height=drop_height, **model_kw) if system is None else system.topo.model
    system = assemble(model) if system is None else system
    # dt_max given explicitly: the same solver options for any t_end, so runs of one System of
    # different lengths share the compiled integrator. At most the 1 ms the bench records at
    # (the step resolves the contact there); finer outputs come from the dense output
    res = simulate(system, t_end=t_end, dt_output=dt_output, integrator=GeneralizedAlpha(dt_max=max(min(dt_output, 1e-2), 1e-3), rtol=rtol, atol=atol), progress=progress)
    df = channels(res, light=light)
    tables = {"channels": df} if light else {"channels": df, "summary": pd.DataFrame([drop_summary(df)])}
    return BenchTest(
        "drop", results={"drop": res}, tables=tables,
        models={"drop": model}, systems={"drop": system},
    )


# ------------------------------------------------------------------------------------------
# synthetic bench data
# ------------------------------------------------------------------------------------------
def _quantize(x, step):
    return np.round(np.asarray(x) / step) * step


def instrument(df: pd.DataFrame, rng: np.random.Generator) -> pd.DataFrame:
    """What the bench instruments (seed 000 §3) record of a channels table.

    Joint encoders quantize SU/UL to 0.0045°; the 12-bit slider encoder quantizes the wheel
    angle (0.0879°, wheel radius ``SLIDER_WHEEL_RADIUS``, assumed); each load cell has a gain
    error drawn once in ±0.5 % and white noise of 0.5 % of 5 kN / 3 rms (accuracy band ≈ 3σ),
    clipped at ±5 kN; the force plate adds ``FORCE_PLATE_NOISE`` rms and clips at ±2.5 kN
    (Fx, Fy) and 0–5 kN (Fz). Cylinder strokes are computed from the quantized angles with
    the MODEL_DATA c(θ), as seed 000 did ("calculated by the HAL kinematics").
    """
    n = len(df)
    out = pd.DataFrame({"time_s": df["time [s]"].to_numpy()})
    step_z = D.SLIDER_ENCODER_RESOLUTION_DEG * deg * D.SLIDER_WHEEL_RADIUS
    out["slider_position_m"] = _quantize(df["slider z [m]"], step_z)
    su = _quantize(df["SU [deg]"], D.JOINT_ENCODER_RESOLUTION_DEG)
    ul = _quantize(df["UL [deg]"], D.JOINT_ENCODER_RESOLUTION_DEG)
    out["su_angle_deg"], out["ul_angle_deg"] = su, ul
    fs = D.LOAD_CELL_RANGE
    for side in ("hip", "knee"):
        gain_err = 1.0 + rng.uniform(-D.LOAD_CELL_ACCURACY, D.LOAD_CELL_ACCURACY)
        f = gain_err * df[f"{side} force [N]"].to_numpy() + rng.normal(0.0, D.LOAD_CELL_ACCURACY * fs / 3.0, n)
        out[f"{side}_force_N"] = np.clip(f, -fs, fs)
    c1 = np.asarray(D.hip_cylinder_length(su * deg))
    c2 = np.asarray(D.knee_cylinder_length(ul * deg))
    out["hip_stroke_mm"] = (c1 - c1[0]) * 1e3
    out["knee_stroke_mm"] = (c2 - c2[0]) * 1e3
    for ax, (lo, hi) in (("x", (-D.FORCE_PLATE_RANGE_XY, D.FORCE_PLATE_RANGE_XY)), ("y", (-D.FORCE_PLATE_RANGE_XY, D.FORCE_PLATE_RANGE_XY)), ("z", (0.0, D.FORCE_PLATE_RANGE_Z))):
        f = df[f"GRF {ax} [N]"].to_numpy() + rng.normal(0.0, D.FORCE_PLATE_NOISE, n)
        out[f"grf_{ax}_N"] = np.clip(f, lo, hi)
    return out


def bench_variant(seed: int = 0, gain: str = "high", actuators: str = "drop", **variant) -> dict:
    """Keyword arguments of the "physical leg" behind :func:`bench_measurement`: 8 bushings,
    half the nominal bushing stiffness, Table 2 k and c drawn with their printed σ (seed 000),
    a 20 % softer foot. ``variant`` overrides any of them."""
    rng = np.random.default_rng(seed)
    coef = D.actuator_coefficients(actuators, gain)
    sig = D.TABLE2_SIGMA[(actuators, gain)]
    drawn = {k: float(v * max(0.2, 1.0 + sig[k] * rng.standard_normal())) for k, v in coef.items()}
    kw = dict(
        joints="bushings8", gain=gain, actuators=actuators, bushing_stiffness=0.5 * D.BUSHING_RADIAL_STIFFNESS,
        actuator_coefficients=drawn, foot_stiffness=0.8 * D.foot_stiffness(),
    )
    kw.update(variant)
    return kw


def variant_system(system, *, bushing_stiffness=None, bushing_damping=None, actuator_coefficients=None, foot_stiffness=None, **ignored):
    """``system`` with the parameters of a :func:`hyq_leg` variant replaced in place of a new
    build: same topology, so the compiled simulation is reused (``with_params``).

    Accepts the :func:`hyq_leg` arguments ``bushing_stiffness``/``bushing_damping`` (every
    bushing), ``actuator_coefficients`` (hip_k, hip_c, knee_k, knee_c) and ``foot_stiffness``;
    other keywords (``joints``, ``gain``, ...) must match the system and are ignored.
    """
    from ..robots.hyq_leg import bushing_vector

    upd = {}
    nb = system.params["bushing_stiffness"].shape[0] if "bushing_stiffness" in system.params else 0
    if bushing_stiffness is not None and nb:
        kb = bushing_vector(bushing_stiffness, "bushing_stiffness")
        cb = D.BUSHING_DAMPING_BETA * kb if bushing_damping is None else bushing_vector(bushing_damping, "bushing_damping")
        upd["bushing_stiffness"] = np.broadcast_to(np.diag(kb), (nb, 6, 6)).copy()
        upd["bushing_damping"] = np.broadcast_to(np.diag(cb), (nb, 6, 6)).copy()
    for side in ("hip", "knee"):
        if actuator_coefficients and f"{side}_k" in actuator_coefficients:
            upd[f"{side}_actuator.stiffness"] = actuator_coefficients[f"{side}_k"]
        if actuator_coefficients and f"{side}_c" in actuator_coefficients:
            upd[f"{side}_actuator.damping"] = actuator_coefficients[f"{side}_c"]
    if foot_stiffness is not None:
        upd["foot.stiffness"] = foot_stiffness
    return system.with_params(upd)


def bench_measurement(test: str = "drop", seed: int = 0, path=None, *, t_end: float = 1.2, payloads=(0.0, 3.0, 7.0), **variant) -> pd.DataFrame:
    """Synthetic "measured" bench data for ``test`` in {"static", "quasi-static", "drop"}.

    Simulates the higher-fidelity variant :func:`bench_variant` (override any :func:`hyq_leg`
    argument through ``variant``) and passes it through :func:`instrument`. Columns carry their
    unit as a suffix (``time_s``, ``hip_force_N``, ``su_angle_deg``, ``hip_stroke_mm``), the
    convention of :mod:`proleg.identify.data`. With ``path`` the table is also written as CSV.
    """
    tests = ("static", "quasi-static", "drop")
    if test not in tests:
        raise ModelError(f"bench_measurement: unknown test {test!r}; valid choices are {list(tests)}.")
    kw = bench_variant(seed, actuators="drop" if test == "drop" else "quasi-static", **variant)
    rng = np.random.default_rng(seed + 1)
    if test == "drop":
        df = drop_test(t_end=t_end, **kw).tables["channels"]
    elif test == "quasi-static":
        df = quasistatic_test(**kw).tables["channels"]
    else:
        st = static_test(payloads, **kw)
        df = pd.concat([channels(r) for r in st.results.values()], ignore_index=True)
        df["time [s]"] = np.arange(len(df), dtype=float)  # one sample per payload
    meas = instrument(df, rng)
    if test == "static":
        meas.insert(1, "payload_kg", [float(p) for p in payloads])
    meas.attrs["provenance"] = f"proleg synthetic bench data: test={test}, seed={seed}, variant={ {k: v for k, v in kw.items()} }"
    if path is not None:
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        meas.to_csv(path, index=False, float_format="%.9g")
    return meas
