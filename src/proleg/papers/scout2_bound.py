"""Scout II bounding runs and their gait metrics (seed 003 §3.2, §3.3, §5.2–5.3, Eq. 8, Fig. 16).

:func:`scout2_bound` simulates :func:`proleg.robots.scout2` from a documented initial
condition (flight, legs at 0°, ``height``, ``speed``, ``pitch``, ``pitch_rate`` of
:class:`~proleg.robots.scout2.Scout2Params`) and returns a :class:`BoundRun`: the proleg
Result, a per-stride table and the metrics.

Strides are counted from back-leg lift-off, as in the paper ("the term stride refers to ... all
four phases starting with the lift-off event of the back virtual leg", §5.2): lift-off is the
back controller's switch from a stance state to flight (the robot's own detection). A stride's

- speed is the body's forward travel over its duration, its frequency 1 / duration;
- duty factors β_b, β_f are the fractions of it that each toe is on the ground (contact force > 0);
- pitch and COM height extremes are the body's (positive pitch nose-up);
- mechanical power is the mean of Σ_legs max(τ φ̇, 0), the motors' positive output power at the
  legs (seed 003 Fig. 7 "based on the average mechanical output power of the actuators"; the
  net Σ τ φ̇ is reported too), electrical power the mean battery terminal power V_s i_s
  (footnote 2: "the total average product of battery current and voltage").

Specific resistance ε = P / (m g v) (Eq. 8) with m the whole robot's mass.

Steady state: strides that start after ``transient`` seconds. :func:`detect_period` classifies
the last ``PERIOD_WINDOW`` of them as period one (every stride alike), period two (alternate strides alike, the
"quasi-bounding" gait of §5.3 at 0.8 m/s) or 0 (no steady gait, or the robot fell).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from ..analyses.result import Result
from ..analyses.simulate import simulate
from ..assembly.assemble import assemble
from ..assembly.system import System
from ..drives.dcmotor import specific_resistance
from ..errors import ModelError
from ..solvers.galpha import GeneralizedAlpha
from ..robots import scout2_data as D
from ..robots.scout2 import LEGS, scout2

__all__ = ["BoundRun", "scout2_bound", "stride_table", "gait_metrics", "stance_brake_stall", "detect_period", "energy_balance", "pitch_deg"]

G = 9.81
PERIOD_WINDOW = 10  # the period is judged on the last this-many steady strides (a converged gait)


@dataclass
class BoundRun:
    """One bounding run: ``result`` (proleg Result), ``strides`` (per-stride DataFrame, units in
    the column names), ``metrics`` (dict), ``model`` ("I"/"II"), ``system``, ``info``
    (:class:`~proleg.robots.scout2.Scout2Info`), ``wall_time`` [s] (compile included)."""

    result: Result
    strides: pd.DataFrame
    metrics: dict
    model: str
    system: System
    info: object
    wall_time: float = 0.0
    params: dict = field(default_factory=dict)


def pitch_deg(result: Result):
    """Body pitch [deg], positive nose-up (rotation about −y)."""
    R = result.part("body").orientation
    return np.degrees(np.arctan2(R[:, 2, 0], R[:, 0, 0]))


def total_mass(system: System) -> float:
    return float(np.sum(np.asarray(system.params["body_mass"])))


def _liftoffs(state):
    """Output indices where a leg's controller goes from stance (1, 2) to flight (0)."""
    s = np.asarray(state)
    return np.flatnonzero((s[1:] == 0) & (s[:-1] > 0)) + 1


def stride_table(result: Result, info) -> pd.DataFrame:
    """Per-stride gait quantities between consecutive back-leg lift-offs (see module docstring)."""
    t = np.asarray(result.t)
    body = result.part("body")
    x, z = body.position[:, 0], body.position[:, 2]
    pitch = pitch_deg(result)
    lo = _liftoffs(result.controller("back_controller").state[:, 0])
    contact = {leg: np.asarray(result.contact(f"{leg}_toe_contact").normal_force) > 0 for leg in LEGS}
    p_leg = sum(np.asarray(result.actuator(info.motors[leg]).power) for leg in LEGS)
    p_pos = sum(np.maximum(np.asarray(result.actuator(info.motors[leg]).power), 0.0) for leg in LEGS)
    bat = result.element("battery")
    p_el = np.asarray(bat.voltage) * np.asarray(bat.current)
    rows = []
    for a, b in zip(lo[:-1], lo[1:]):
        sl = slice(a, b + 1)
        T = t[b] - t[a]
        tt = t[sl]

        def mean(y):
            return float(np.trapezoid(y[sl], tt) / T)

        def frac(c):
            return float(np.trapezoid(c[sl].astype(float), tt) / T)

        rows.append({
            "start [s]": t[a],
            "duration [s]": T,
            "frequency [Hz]": 1.0 / T,
            "speed [m/s]": (x[b] - x[a]) / T,
            "duty back [-]": frac(contact["back"]),
            "duty front [-]": frac(contact["front"]),
            "pitch max [deg]": float(pitch[sl].max()),
            "pitch min [deg]": float(pitch[sl].min()),
            "height max [m]": float(z[sl].max()),
            "height min [m]": float(z[sl].min()),
            "mechanical power [W]": mean(p_pos),
            "net mechanical power [W]": mean(p_leg),
            "electrical power [W]": mean(p_el),
        })
    return pd.DataFrame(rows)


def detect_period(features, tol: float = 0.03, min_strides: int = 4) -> int:
    """Period of a stride sequence: 1, 2, or 0 (no steady gait).

    Parameters
    ----------
    features : (n_strides, k) array — per-stride quantities (e.g. duration, speed, pitch max)
    tol : relative tolerance; a quantity is "steady" when its strides stay within ``tol`` of
        their mean (relative to the mean's magnitude, or to the feature's range over all strides
        when the mean is near 0)
    min_strides : fewer steady strides than this is period 0

    Period one: every feature within ``tol``. Period two: not period one, but the even and the
    odd strides each within ``tol`` (the quasi-bounding gait of seed 003 §5.3).
    """
    f = np.asarray(features, float)
    if f.ndim == 1:
        f = f[:, None]
    if len(f) < min_strides or not np.all(np.isfinite(f)):
        return 0
    scale = np.maximum(np.abs(f).mean(0), 1e-9)

    def steady(y):
        return len(y) >= 2 and bool(np.all(np.max(np.abs(y - y.mean(0)), 0) <= tol * scale))

    if steady(f):
        return 1
    if steady(f[0::2]) and steady(f[1::2]) and len(f) >= 2 * max(2, min_strides // 2):
        return 2
    return 0


STALL_WINDOW = 0.5  # s: both legs braked throughout this final window is the stall (see stance_brake_stall)


def stance_brake_stall(result: Result, window: float = STALL_WINDOW) -> tuple[bool, float]:
    """(stalled, longest brake [s]): the stance-brake stall of the seed's controller.

    Seed 003 §3.1 / Fig. 4: stance-brake is left only at lift-off. A robot standing on both
    legs never lifts off, so both legs braked with neither lifting off is a fixed point of the
    controller: no leg reaches touchdown again, so no stance-retraction injects energy. The run
    is *stalled* when both controllers are in stance-brake throughout its last ``window``
    seconds; ``longest brake`` is the longest uninterrupted stance-brake of either leg.
    """
    t = np.asarray(result.t)
    st = {leg: np.asarray(result.controller(f"{leg}_controller").state[:, 0]) for leg in LEGS}
    tail = t >= t[-1] - window
    stalled = bool(t[-1] - t[0] >= window and all(np.all(s[tail] == 2) for s in st.values()))
    longest = 0.0
    for s in st.values():
        edges = np.flatnonzero(np.diff(np.r_[0, (s == 2).astype(int), 0]))
        if len(edges):
            longest = max(longest, float(np.max(t[np.minimum(edges[1::2], len(t) - 1)] - t[edges[0::2]])))
    return stalled, longest


def gait_metrics(result: Result, strides: pd.DataFrame, system: System, *, transient: float, period_tol: float = 0.03) -> dict:
    """The issue's metrics from the steady strides (those starting at or after ``transient``);
    ``stalled`` and ``longest_brake`` [s] from :func:`stance_brake_stall`."""
    pitch = pitch_deg(result)
    z = result.part("body").position[:, 2]
    fell = bool(np.any(np.abs(pitch) > 60.0) or np.any(z < 0.12))
    steady = strides[strides["start [s]"] >= transient] if len(strides) else strides
    m = total_mass(system)
    stalled, longest = stance_brake_stall(result)
    out = {"strides": int(len(steady)), "fell": fell, "stalled": stalled and not fell, "longest_brake": longest}
    if len(steady) == 0 or fell:
        out.update(period=0, forward_speed=float("nan"))
        for k in ("stride_frequency", "duty_factor_back", "duty_factor_front", "pitch_max", "pitch_min", "height_max", "height_min",
                  "specific_resistance_mechanical", "specific_resistance_electrical", "speed_variation"):
            out[k] = float("nan")
        return out
    feats = np.column_stack([steady["duration [s]"], steady["speed [m/s]"], steady["pitch max [deg]"] - steady["pitch min [deg]"]])
    v = float(np.sum(steady["speed [m/s]"] * steady["duration [s]"]) / np.sum(steady["duration [s]"]))
    tw = steady["duration [s]"].to_numpy()

    def wmean(col):
        return float(np.sum(steady[col].to_numpy() * tw) / np.sum(tw))

    out.update(
        period=detect_period(feats[-PERIOD_WINDOW:], tol=period_tol),
        forward_speed=v,
        stride_frequency=float(len(steady) / np.sum(tw)),
        duty_factor_back=wmean("duty back [-]"),
        duty_factor_front=wmean("duty front [-]"),
        pitch_max=float(steady["pitch max [deg]"].mean()),
        pitch_min=float(steady["pitch min [deg]"].mean()),
        height_max=float(steady["height max [m]"].mean()),
        height_min=float(steady["height min [m]"].mean()),
        specific_resistance_mechanical=float(specific_resistance(wmean("mechanical power [W]"), m, v, G)),
        specific_resistance_electrical=float(specific_resistance(wmean("electrical power [W]"), m, v, G)),
        mechanical_power=wmean("mechanical power [W]"),
        electrical_power=wmean("electrical power [W]"),
        speed_variation=float(np.ptp(steady["speed [m/s]"]) / abs(v)) if v else float("nan"),
        mass=m,
    )
    return out


def _held_integrals(result: Result, info) -> dict:
    """∫ dt of the drive and battery powers, exact for the controllers' zero-order hold.

    The commands jump at the sample instants, which are output times: an output at t_k holds
    the new command, the interval's right end the old one. Each interval [t_k, t_k+1] is
    integrated by the trapezoidal rule between the post-sample value at t_k and the value at
    t_k+1 evaluated with the command held since t_k (second order, no error at the jumps).
    """
    import jax.numpy as jnp

    from ..analyses.result import _outputs_batch

    r = result
    t = np.asarray(r.t)
    dt = np.diff(t)
    post = {k: {f: np.asarray(a) for f, a in v.items()} for k, v in r._element_outputs.items()}
    pre = _outputs_batch(r.system, r.q[1:], r.v[1:], jnp.asarray(t[1:]), r.z[:-1])
    pre = {k: {f: np.asarray(a) for f, a in v.items()} for k, v in pre.items()}
    ja = r.system.topo.extensions
    names = next(g.names for g in ja if g.kind == "joint_actuator")
    d = info.drive
    out = {"battery": 0.0, "battery_internal": 0.0, "hip_work": 0.0, "copper": 0.0, "gear": 0.0}

    def integral(y_post, y_pre):
        return float(np.sum(0.5 * dt * (y_post[:-1] + y_pre)))

    for leg in LEGS:
        k = names.index(info.motors[leg])
        beta = 1.0 if info.variant == "II" else float(d.beta)

        def powers(o):
            P = o["power"][:, k]
            i = o["current"][:, k]
            w_m = o["rate"][:, k] * beta
            return P, float(d.R_a) * i * i, float(d.K_T) * i * w_m - P

        for key, a, b in zip(("hip_work", "copper", "gear"), powers(post["joint_actuator"]), powers(pre["joint_actuator"])):
            out[key] += integral(a, b)
    bp, bq = post["battery"], pre["battery"]
    out["battery"] = integral(bp["voltage"][:, 0] * bp["current"][:, 0], bq["voltage"][:, 0] * bq["current"][:, 0])
    out["battery_internal"] = integral(bp["internal_loss"][:, 0], bq["internal_loss"][:, 0])
    return out


def energy_balance(result: Result, info) -> dict:
    """Energy bookkeeping over a run [J].

    - ``battery``: ∫ V_s i_s dt, delivered at the battery terminals (``battery_internal``:
      ∫ R_s i_s² dt lost inside it);
    - ``hip_work``: ∫ Σ τ φ̇ dt, the drives' work on the legs; ``copper``: ∫ Σ R_a i² dt;
      ``gear``: ∫ Σ (K_T i ω_m − τ φ̇) dt, the transmission losses; battery = hip_work +
      copper + gear holds to round-off (K_ω = K_T). These are quadratures of the outputs that
      respect the controllers' zero-order hold (:func:`_held_integrals`).
    - ``input``: the integrator's ∫ (power of every applied load) dt, step by step (the hip
      work again, independently), ``dissipated``: its ∫ (leg dampers, toe contacts and
      friction, extension stops, belt, joint friction) dt, ``mechanical_energy_change``: T + V
      at the end minus at the start; ``input − dissipated − mechanical_energy_change`` is the
      integration error.
    """
    out = _held_integrals(result, info)
    e = result.energy
    out.update(
        input=float(e.input[-1] - e.input[0]),
        dissipated=float(e.dissipated[-1] - e.dissipated[0]),
        mechanical_energy_change=float((e.kinetic[-1] + e.potential[-1]) - (e.kinetic[0] + e.potential[0])),
    )
    return out


def scout2_bound(model: str = "I", t_end: float = 10.0, *, per: str = D.TABLE6_READING, transient: float | None = None, dt_output: float = 1e-3,
                 system: System | None = None, variables: dict | None = None, rtol: float = 1e-6, progress: bool | None = None, **params) -> BoundRun:
    """Run Scout II bounding and measure the gait (see the module docstring).

    Parameters
    ----------
    model : "I" or "II"
    t_end : float [s], simulated time (default 10 s)
    per : how Table 6's leg values are read (:func:`proleg.robots.scout2`)
    transient : float [s], strides starting before it are not steady (default 0.4 t_end)
    system : an assembled Scout II system to reuse (no recompilation); ``params`` then only
        change the initial condition fields (height, speed, pitch, pitch_rate)
    variables : design variables to change without recompiling (``touchdown_front`` [rad], ...)
    **params : fields of :class:`~proleg.robots.scout2.Scout2Params`

    Returns
    -------
    :class:`BoundRun`
    """
    if not t_end > 0:
        raise ModelError(f"scout2_bound: t_end must be positive [s], got {t_end}.")
    transient = 0.4 * t_end if transient is None else transient
    wall0 = time.perf_counter()
    mdl = scout2(model, per=per, **params)
    if system is None:
        system = assemble(mdl)
    else:
        from ..assembly.system import initial_coordinates

        q0, v0 = initial_coordinates(mdl)
        system = system.with_params(q_init=q0, v_init=v0)
    if variables:
        system = system.with_params(variables)
    res = simulate(system, t_end=t_end, dt_output=dt_output, integrator=GeneralizedAlpha(rtol=rtol, dt_max=min(dt_output, 1e-2)), throw=False, progress=progress)
    info = mdl.scout2
    st = stride_table(res, info) if len(res.t) > 2 else pd.DataFrame()
    met = gait_metrics(res, st, system, transient=transient)
    met["status"] = res.status.name if hasattr(res.status, "name") else str(res.status)
    return BoundRun(res, st, met, model, system, info, time.perf_counter() - wall0, dict(params))
