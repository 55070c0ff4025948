"""Scout II studies (issues 31, 44): set points for a commanded speed, the specific resistance
against speed (seed 003 Fig. 7) and the finding across the ranges of the unknown parameters.
The one calibrated quantity of the decided reading, the leg damping, is fitted in
:mod:`proleg.papers.scout2_reading`.

Every run starts the same way for both models (:class:`~proleg.robots.scout2.Scout2Params`: at
rest in the standing posture, released from a small drop; the controller brings the robot into
the bound) and reuses one compiled system per model (:func:`run_point`), so a study changes
numbers only.

- :func:`setpoint_for_speed`: the touchdown angles (Table 4's, shifted together by δ) that give a
  commanded forward speed, by bisection on δ (a run that stops or falls counts as too slow);
- :func:`range_rows`: Model II at the ends of each unknown parameter's justified range.

Each run becomes a row (:func:`point_row`): set point, speed, period, specific resistances; the
rows of all studies together are the points of the Fig. 7 analogue.
"""

from __future__ import annotations

import numpy as np

from ..assembly.assemble import assemble
from ..assembly.system import System
from ..units import deg
from ..robots import scout2_data as D
from ..robots.scout2 import scout2
from .scout2_bound import scout2_bound

__all__ = ["variant_system", "run_point", "point_row", "setpoint_for_speed", "range_rows", "RANGES", "PAPER_POINTS"]

#: Unknown Model II parameters and their justified ranges (scout2_data cites the reasoning).
RANGES = {
    "leg_mu": (D.LEG_MU_RANGE, "-", "telescopic-leg bushing friction coefficient (dry plain bearings)"),
    "leg_overlap": (D.LEG_OVERLAP_RANGE, "m", "bushing overlap (bending-moment arm)"),
    "gear_drag": (D.GEAR_DRAG_RANGE, "N m", "gearbox + motor no-load drag at the motor shaft"),
    "gear_viscous": (D.GEAR_VISCOUS_RANGE, "N m s/rad", "gearbox viscous drag at the motor shaft"),
    "belt_no_load": (D.BELT_NO_LOAD_RANGE, "-", "belt no-load drag / full leg torque (Table 3's 96 % kept at full torque)"),
}
#: The paper's measured points (seed 003 §3.3, Fig. 7): (speed [m/s], mechanical, electrical
#: specific resistance). Reference values for the comparison tables only.
PAPER_POINTS = ((1.3, D.SR_MECHANICAL, D.SR_ELECTRICAL), D.SR_LOW_SPEED)


#: Scout2Params fields that change the (static) drive object rather than System parameters.
DRIVE_FIELDS = frozenset({"drive", "motors_per_leg", "V_nom", "R_s", "gear_drag", "gear_viscous", "belt_no_load"})


def variant_system(base: System, model: str, **params) -> System:
    """The system of ``scout2(model, **params)`` on ``base``'s compiled topology.

    Valid when the variant changes numbers only (masses, stiffnesses, gear inertias, the
    initial condition): its parameter arrays replace ``base``'s, so nothing recompiles. A
    variant of the drive (``DRIVE_FIELDS``) is assembled anew: the drive is static topology,
    and reusing ``base``'s would silently keep the old drive.
    """
    other = assemble(scout2(model, **params))
    if DRIVE_FIELDS & set(params):
        return other  # the drive (DCMotorDrive, its belt) is static in the topology: recompile
    if set(other.params) != set(base.params) or any(np.shape(other.params[k]) != np.shape(base.params[k]) for k in base.params):
        return other
    return System(dict(other.params), base.topo)


def _td(delta):
    return {"touchdown_front": D.TOUCHDOWN_FRONT + delta, "touchdown_back": D.TOUCHDOWN_BACK + delta}


def run_point(model, t_end, *, base=None, delta=0.0, **params):
    """One bounding run with touchdown angles Table 4 + ``delta`` [rad] and parameter changes
    ``params`` (fields of Scout2Params), on ``base``'s compiled system when given."""
    if base is not None and params:
        system = variant_system(base.system, model, **params)
    else:
        system = None if base is None else base.system
    return scout2_bound(model, t_end, system=system, transient=t_end / 2, variables=_td(delta), **params)


def point_row(run, label, delta=0.0, **extra) -> dict:
    """The Fig. 7 point of a run: speed and specific resistances (NaN when it does not bound)."""
    m = run.metrics
    ok = not m["fell"] and m["strides"] > 0
    return {
        "run": label, "model": run.model, "touchdown offset [deg]": delta / deg, **extra,
        "speed [m/s]": m["forward_speed"] if ok else np.nan, "period": m["period"], "fell": m["fell"],
        "SR mechanical": m["specific_resistance_mechanical"] if ok else np.nan,
        "SR electrical": m["specific_resistance_electrical"] if ok else np.nan,
    }


def setpoint_for_speed(model, target, t_end, *, base, bounds=(-10 * deg, 4 * deg), xtol=0.75 * deg, rows=None, **params):
    """Touchdown offset δ [rad] whose run bounds at ``target`` m/s (bisection; see module doc).

    Returns (δ, run at δ). ``rows`` collects every run's :func:`point_row`. Raises
    ConvergenceError when the speed is not bracketed on ``bounds``.
    """
    from ..identify.calibration import fit_to

    runs = {}

    def predict(delta):
        r = run_point(model, t_end, base=base, delta=delta, **params)
        runs[delta] = r
        row = point_row(r, f"Model {model}, set-point search", delta)
        if rows is not None:
            rows.append(row)
        v = row["speed [m/s]"]
        return {"forward speed": 0.0 if not np.isfinite(v) else v}

    cal = fit_to("touchdown offset", predict, {"forward speed": target}, bounds, unit="rad", xtol=xtol,
                    source="controller set point for a commanded speed (not a model parameter)")
    best = min(runs, key=lambda d: abs(d - cal.value))
    return best, runs[best]


def range_rows(t_end, *, base, names=tuple(RANGES), rows=None, **params) -> list[dict]:
    """Model II at the lower and upper end of each parameter's range (others nominal)."""
    out = []
    for name in names:
        (lo, hi), unit, what = RANGES[name]
        for end, value in (("lower", lo), ("upper", hi)):
            kw = {**params, name: value}
            r = run_point("II", t_end, base=base, **kw)
            row = point_row(r, f"Model II, {name} {end}", **{"parameter": name, "value": value, "unit": unit})
            out.append(row)
            if rows is not None:
                rows.append(row)
    return out
