"""FLEGX Table I by co-design (seed 002 §IV, issue 30): for each configuration and link case,
the jump law that maximises the jump height within the paper's stress limit and the worm
wheel's rating, found by an optimiser, not picked by hand.

The law is :class:`~proleg.papers.flegx_jump.MotionLaw` with ``design=True``: the push's
duration ``law_t_push`` [s] and extended pose ``law_extend_hip``, ``law_extend_knee`` [rad] are
design variables of the model (the squat and the stand stay those of flegx_jump's documented
law), so every trial reruns the compiled simulation with other parameter values. The outputs
come from :func:`~proleg.papers.flegx_jump.jump_metrics` (contact timing, apex search: not
smooth), so the optimiser samples: proleg's CMA-ES (``Study.optimize(sampler="cma")``) with
the constraints as a feasibility-first penalty.

Constraints (:func:`constraints`), evaluated over one **phase** of the run (``phase``):

- the von Mises stress at the clamped end ≤ ``STRESS_LIMIT`` = 520 MPa: Table I's stresses
  all lie in 514.6-530.7 MPa (``flegx_data.TABLE_I``), "sufficiently lower than the ultimate
  tensile strength ... between 510 and 530 MPa" (seed 002 §IV);
- the hip and knee joint torques ≤ 77 N m: the worm wheel's rating with mineral grease (seed
  002 §III.C, ``flegx_data.WORM_OUTPUT_TORQUE_LIMIT``).

Phase. ``"takeoff"`` (the default, :data:`CONSTRAINT_PHASE`): from standing still through the
squat and the push to the take-off sample (``*_takeoff`` outputs of
:func:`~proleg.papers.flegx_jump.jump_metrics`). Seed 002 §IV says of Table I's simulations:
"For this first set of analyses, the investigated movement was the take-off phase"; take-off
*and* landing were simulated only in the second group (the machinery model, Fig. 4). ``"all"``:
over the whole simulated run, the landing included. The choice changes the result: the
landing is an impact (foot on the ground at the standing pose, seed 002 prints no landing
law), and with ``"all"`` its peaks bind. Measured (No. 4, link case 2, PRBM, push 0.25 s,
flegx_jump's pose, run to 0.4 s after the push): up to take-off (1.182 s) hip 47 N m, knee
57.5 N m, 522 MPa; at the touchdown (1.532 s, ground force 2.6 kN) the hip torque peaks at
577 N m, the knee at 95 N m (1.574 s), the stress at 870 MPa. bench/flegx_codesign.py
``--phases`` prints that split.

Objective (``objective``, default :data:`OBJECTIVE` = ``"foot_clearance"``): the foot's highest
point above the ground during the jump's flight (flegx_jump docstring). Seed 002 does not say
which height Table I measured. flegx_jump's ``jump_height`` (the guide's apex above its standing
height) counts a leg still straightened at the apex as height: with the extended pose free, the
optimiser straightens the leg instead of jumping (measured, No. 1 case 2, 64 CMA-ES trials on
``jump_height``: 107.1 mm of guide rise but 45.9 mm of foot clearance, the knee at its 15°
bound, the apex 0.07 s before the flight retraction began). The foot's clearance is the height
straightening alone cannot raise; ``jump_height`` is reported beside (``jump_mm``).

The law's family. The flight retraction (back to the standing pose, MotionLaw) starts
``retract_delay`` after the push: it is meant for the flight. If the foot is still on the
ground then, the "retraction" is a second push from an extended pose that need not be
straighter than the standing one (measured, No. 3 case 2, without this limit: the push to
(−0.2°, 68.6°) ended at 1.368 s, the foot left the ground at 1.502 s, mid-retraction, for 158 mm).
So a fourth limit keeps the law a countermovement jump: ``takeoff_in_push`` = (take-off −
push start) / (push duration + retract_delay) ≤ 1 (10 if the foot never leaves the ground).

Each optimum reports its binding constraint: the constraint whose slack at the optimum is
within ``BINDING_TOL`` of its bound, or a bound of the law's ranges. CMA-ES converged when the
best feasible height changed by less than ``CONVERGE_TOL`` over the last ``CONVERGE_GENS``
generations (``converged``; the best after each generation is ``history_mm``). That is a
stall test, not a proof of optimality: on these ridges CMA-ES stalls below the limit (measured,
case 2, 64 trials: No. 4 stalled at 63.5 mm for four generations, and the push line search at
its pose then found 109.7 mm on the 520 MPa limit), so ``polish_gain_mm`` and
``cross_gain_mm`` report what the line searches added after it.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pandas as pd

from ..errors import ModelError
from ..units import deg
from ..robots import flegx_data as D
from ..robots.flegx import flegx
from .flegx_jump import MotionLaw, _add_motions, jump_metrics

__all__ = ["STRESS_LIMIT", "WHEEL_RATING", "LAW_SPACE", "CONSTRAINT_PHASE", "OBJECTIVE", "constraints", "codesign_study", "optimise_law",
           "optimise_table_i", "push_at_limits", "law_shape", "ranking_text"]

STRESS_LIMIT = 520e6  # [Pa] seed 002 Table I: 514.6-530.7 MPa
WHEEL_RATING = D.WORM_OUTPUT_TORQUE_LIMIT  # [N m] seed 002 §III.C
#: ranges of the law's variables: the push 0.12-0.45 s (a push shorter than 0.12 s leaves the
#: ground before the knee has extended; 0.45 s, the longest push of flegx-jump's and flegx-study's push grids), the
#: extended pose inside the joint ranges (flegx_data, assumed) and straighter than the squat
LAW_SPACE = {"law_t_push": (0.12, 0.45), "law_extend_hip": (-40.0 * deg, 0.0), "law_extend_knee": (15.0 * deg, 80.0 * deg)}
BINDING_TOL = 0.02  # a constraint within 2 % of its bound at the optimum binds
#: the phase the limits apply to (module docstring): seed 002 §IV, Table I studies the take-off
CONSTRAINT_PHASE = "takeoff"
_PHASE_OUTPUTS = {"takeoff": ("max_stress_takeoff", "peak_hip_torque_takeoff", "peak_knee_torque_takeoff"),
                  "all": ("max_stress", "peak_hip_torque", "peak_knee_torque")}
#: the height maximised (module docstring): the foot's clearance over the jump's flight
OBJECTIVE = "foot_clearance"
#: rounds of the push line search (each narrows the bracket (n - 1)-fold: 3 rounds of 6 pushes
#: over the push's 0.33 s range leave 2.6 ms, a few MPa of stress on the steepest ridge measured)
POLISH_ROUNDS = 3
#: convergence: the best feasible height moved less than 1 % over the last 3 generations
CONVERGE_TOL, CONVERGE_GENS = 0.01, 3
OUTPUTS = ("jump_height", "max_stress_takeoff", "max_stress", "peak_hip_torque_takeoff", "peak_knee_torque_takeoff",
           "peak_hip_torque", "peak_knee_torque", "take_off_time", "apex_time", "foot_clearance", "flight_rise", "tip_displacement")


def constraints(phase: str = CONSTRAINT_PHASE) -> dict:
    """{output: (op, bound)}: stress ≤ :data:`STRESS_LIMIT`, hip and knee torque ≤ :data:`WHEEL_RATING`
    over ``phase`` ("takeoff": up to take-off, seed 002 §IV's Table I phase; "all": the whole run),
    and ``takeoff_in_push`` ≤ 1 (module docstring: the foot leaves the ground before the flight
    retraction starts)."""
    if phase not in _PHASE_OUTPUTS:
        raise ModelError(f"flegx co-design: phase {phase!r} is not known; expected one of {sorted(_PHASE_OUTPUTS)} "
                         "('takeoff': limits up to take-off, Table I's phase; 'all': the landing included).")
    s, h, k = _PHASE_OUTPUTS[phase]
    return {s: ("<=", STRESS_LIMIT), h: ("<=", WHEEL_RATING), k: ("<=", WHEEL_RATING), "takeoff_in_push": ("<=", 1.0)}


#: the limits over the default phase (take-off)
CONSTRAINTS = constraints()


def codesign_study(configuration: int, link_case: int, link_model: str = "prbm", gears: str = "ideal", *,
                   space: dict | None = None, t_after: float = 0.2, dt_output: float = 2e-3, rtol: float = 1e-5, atol: float = 1e-6):
    """A :class:`proleg.study.Study` of one FLEGX variant over the jump law's variables.

    ``space``: the law variables to vary, {name: (lo, hi)} (default :data:`LAW_SPACE`); a
    variable left out stays at flegx_jump's default law. The run ends ``t_after`` [s] after the
    end of the longest push of the space (the apex of every jump within the limits falls inside
    it; the landing of shorter pushes too, which only the ``"all"`` phase reads). Returns (study, law)."""
    import proleg as pl

    space = dict(LAW_SPACE if space is None else space)
    unknown = sorted(set(space) - set(LAW_SPACE))
    if unknown:
        raise ModelError(f"flegx co-design: space variables {unknown} are not law variables; expected some of {sorted(LAW_SPACE)} "
                         "({name: (lo, hi)} in s and rad).")
    law = MotionLaw(t_after=t_after, design=True)
    model = flegx(configuration, link_case, link_model, gears, stand=law.stand, name=f"flegx_codesign_{configuration}_{link_case}")
    _add_motions(model, law)
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=".*redundant constraint.*")
        system = pl.assemble(model)
    cache = {}

    def metrics(r):
        if cache.get("r") is not r:
            m, _ = jump_metrics(r, model, law)
            p = r.system.params
            t_push = float(p["variable_law_t_push"]) if "variable_law_t_push" in p else law.t_push
            m["takeoff_in_push"] = ((m["take_off_time"] - law.push_start) / (t_push + law.retract_delay)
                                    if m["flights"] else 10.0)
            cache.update(r=r, m=m)
        return cache["m"]

    outputs = {k: (lambda r, k=k: metrics(r)[k]) for k in (*OUTPUTS, "takeoff_in_push")}
    t_push_max = space.get("law_t_push", (law.t_push, law.t_push))[1]
    t_end = law.push_start + t_push_max + t_after
    sim = dict(t_end=t_end, dt_output=dt_output, integrator=pl.GeneralizedAlpha(rtol=rtol, atol=atol, dt_max=dt_output))
    study = pl.study.Study(system, space, outputs, simulate=sim,  # t_end: read by optimise_law (apex in the window)
                           name=f"flegx No.{configuration} case {link_case} {link_model} {gears}")
    return study, law


def _binding(row: dict, space: dict, cons: dict) -> str:
    from ..study.codesign import binding

    out = binding(row, cons, space, BINDING_TOL)
    return ", ".join(out) if out else "none (interior optimum)"


def law_shape(t_push: float, extend_hip: float, extend_knee: float, law: MotionLaw | None = None) -> dict:
    """The push of a law in report units: the cubic STEP (seed 002 Eq. 18) from the squat pose to
    the extended pose (θ1, θ2) [rad] in ``t_push`` [s]; its strokes [deg] and peak joint speeds
    1.5 Δθ / T [deg/s] (the STEP's speed at mid-push)."""
    law = law or MotionLaw()
    d1, d2 = extend_hip - law.squat[0], extend_knee - law.squat[1]
    return {"t_push_s": float(t_push), "extend_hip_deg": float(extend_hip) / deg, "extend_knee_deg": float(extend_knee) / deg,
            "stroke_hip_deg": d1 / deg, "stroke_knee_deg": d2 / deg,
            "speed_hip_dps": 1.5 * d1 / deg / t_push, "speed_knee_dps": 1.5 * d2 / deg / t_push}


def _row(full: dict, law: MotionLaw, space: dict, cons: dict, objective: str = OBJECTIVE) -> dict:
    """An optimum's report row from a study row (outputs and law variables)."""
    s_c, h_c, k_c = list(cons)[:3]
    out = {"height_mm": 1e3 * full[objective], "jump_mm": 1e3 * full["jump_height"], "stress_MPa": full[s_c] / 1e6,
           "peak_hip_Nm": full[h_c], "peak_knee_Nm": full[k_c],
           "stress_all_MPa": full["max_stress"] / 1e6, "peak_hip_all_Nm": full["peak_hip_torque"],
           "peak_knee_all_Nm": full["peak_knee_torque"], "foot_clearance_mm": 1e3 * full["foot_clearance"],
           "flight_rise_mm": 1e3 * full["flight_rise"],
           "take_off_s": full["take_off_time"], "apex_s": full["apex_time"]}
    out.update(law_shape(float(full.get("law_t_push", law.t_push)), float(full.get("law_extend_hip", law.extend[0])),
                         float(full.get("law_extend_knee", law.extend[1])), law))
    out["binding"] = _binding({**full, **{k: full.get(k, 0.0) for k in space}}, space, cons)
    out["takeoff_in_push"] = float(full["takeoff_in_push"])
    return out


def optimise_law(configuration: int, link_case: int, link_model: str = "prbm", gears: str = "ideal", *,
                 phase: str = CONSTRAINT_PHASE, objective: str = OBJECTIVE, n_trials: int = 64, batch: int = 8, seed: int = 0, sigma0: float = 0.3,
                 space: dict | None = None, start: int | None = 6, polish: int | None = 6, poses: list | None = None,
                 reference: dict | None = None, store=None,
                 executor: str = "local", progress: bool = False) -> dict:
    """The law of largest ``objective`` (a height [m], default the foot's clearance) within
    :func:`constraints` over ``phase`` for one variant (module docstring), by proleg's CMA-ES
    (population ``batch``, ``n_trials`` in all).

    ``reference``: a law {variable: value} (missing variables: flegx_jump's default law)
    evaluated beside, reported as ``ref_height_mm`` and ``ref_feasible`` (e.g. flegx_jump's hand
    law: the optimum should be feasible and higher).

    ``start``: CMA-ES's mean starts at the push-only optimum (:func:`push_at_limits`' rule on a
    grid of ``start`` pushes over the push's range, the pose at flegx_jump's default: a law on
    the constraints' boundary), with ``sigma0`` = 0.3 of the mapped box around it, so the
    search refines the pose from a feasible, binding law instead of spending its first
    generations finding the boundary (measured, No. 4 case 2: from the box's middle, 48 trials
    stalled at 112.8 mm with 469 MPa, an interior point below the push-only optimum); ``None``:
    the middle of the box. The start law is evaluated and competes with CMA-ES's trials, so the
    optimum is at least the push-only optimum (``start_height_mm``).

    ``polish``: the optimum of a jump within a stress or torque limit lies on that limit, a
    narrow ridge for a sampler (measured, No. 2 case 2: 64 CMA-ES trials ended at 505 MPa, while
    the clearance falls from 67 to 27 mm as the push lengthens from 0.30 to 0.35 s). So at the
    best pose found, the push is line-searched to its shortest feasible value: ``polish``
    pushes from 0.08 s shorter than the best's up to it, then, :data:`POLISH_ROUNDS` times in
    all, ``polish`` pushes inside the bracket where the limits start to hold (:func:`push_at_limits`' rule); every law evaluated
    competes (after ``|`` in ``history_mm``; ``polish_gain_mm`` what it added). ``None``: no polish.
    ``poses``: more extended poses ({variable: value}) to line-search the push at in the same
    batches, searched over the push's whole range (:func:`optimise_table_i`'s ``cross``).
    Returns a row: the optimum's
    outputs, the law's shape (:func:`law_shape`), its binding constraint, the convergence
    (``history_mm``: best feasible height after each generation; ``converged``: of CMA-ES), the number of
    trials and the paper's Table I values beside (``paper_*``)."""
    if n_trials < 2 * batch:
        raise ModelError(f"flegx co-design: n_trials = {n_trials} is less than two CMA-ES generations of batch = {batch}; "
                         "give n_trials ≥ 2 × batch.")
    if objective not in ("foot_clearance", "jump_height", "flight_rise"):
        raise ModelError(f"flegx co-design: objective {objective!r} is not a jump height; expected 'foot_clearance' (default), "
                         "'jump_height' or 'flight_rise' (flegx_jump docstring).")
    space = dict(LAW_SPACE if space is None else space)
    cons = constraints(phase)
    study, law = codesign_study(configuration, link_case, link_model, gears, space=space)
    run = dict(executor=executor, store=store, progress=progress, workers=1)
    from ..study.codesign import slack

    def feasible(row) -> bool:
        return bool(row["status"] == "success" and all(slack(op, b, float(row[c])) >= 0 for c, (op, b) in cons.items()))

    enqueue, start_row, pool = None, {}, []
    if start is not None and "law_t_push" in space:
        # the push-only optimum at the default pose (push_at_limits' rule), evaluated, as CMA-ES's mean
        lo, hi = space["law_t_push"]
        grid = pd.DataFrame({k: (np.linspace(lo, hi, int(start)) if k == "law_t_push" else _law_value(law, k)) for k in space})
        g = study.evaluate(grid[list(space)], label="push grid", **run).sort_values("law_t_push").reset_index(drop=True)
        t_c, _ = _push_limits(g, cons)
        t0 = hi if any(math.isnan(v) for v in t_c.values()) else float(np.clip(max(t_c.values()), lo, hi))
        enqueue = [{k: (t0 if k == "law_t_push" else _law_value(law, k)) for k in space}]
        r0 = study.evaluate(pd.DataFrame(enqueue), label="start law", **run).iloc[0].to_dict()
        pool.append({**r0, "generation": -1, "feasible": feasible(r0)})
        start_row = {"start_t_push_s": t0, "start_height_mm": 1e3 * r0[objective], "start_feasible": feasible(r0)}
    opt = study.optimize(objective, cons, n_trials=n_trials, sampler="cma", direction="maximize", batch=batch, seed=seed,
                         sigma0=sigma0, enqueue=enqueue, **run)
    tr = opt.trials
    rows = opt.rows.drop_duplicates("key").set_index("key")
    pool += [{**rows.loc[t["key"]].to_dict(), "key": t["key"], "generation": t["generation"], "feasible": bool(t["feasible"])}
             for t in tr.to_dict("records")]
    if polish and "law_t_push" in space:
        pool += _polish(study, pd.DataFrame(pool), space, cons, objective, feasible, int(polish), run, poses)
    pool = pd.DataFrame(pool)
    mass, h_paper, s_paper = D.TABLE_I[configuration]
    out = {"configuration": configuration, "link_case": link_case, "link_model": link_model, "gears": gears, "phase": phase,
           "trials": len(tr), "feasible_trials": int(tr["feasible"].sum()), "paper_mass_kg": mass, "paper_jump_mm": h_paper,
           "paper_stress_MPa": s_paper, **start_row}
    out["total_mass_kg"] = float(flegx(configuration, link_case, link_model, gears).flegx.total_mass)
    # convergence: the best feasible height after each CMA-ES generation (the start law counts as generation -1),
    # then after each polish round
    v = np.where(pool["feasible"], pool[objective].to_numpy(float), -np.inf)
    hist_all = 1e3 * pd.Series(v).groupby(pool["generation"].to_numpy()).max().cummax()
    n_cma = int(tr["generation"].max()) + 1
    hist = hist_all[hist_all.index < n_cma].to_numpy(float)
    fmt = lambda hs: " ".join("-" if not np.isfinite(h) else f"{h:.1f}" for h in hs)  # noqa: E731
    pol = hist_all[hist_all.index >= n_cma].to_numpy(float)
    out["history_mm"] = fmt(hist) + (f" | polish {fmt(pol)}" if len(pol) else "")
    out["polish_gain_mm"] = float(pol[-1] - hist[-1]) if len(pol) and np.isfinite(hist[-1]) else math.nan
    out["converged"] = bool(len(hist) > CONVERGE_GENS and np.isfinite(hist[-CONVERGE_GENS - 1])
                            and abs(hist[-1] - hist[-CONVERGE_GENS - 1]) <= CONVERGE_TOL * abs(hist[-1]))
    if reference is not None:
        ref = study.evaluate(pd.DataFrame([{k: float(reference.get(k, _law_value(law, k))) for k in space}]), label="reference law",
                             **run).iloc[0].to_dict()
        out.update(ref_height_mm=1e3 * ref[objective], ref_feasible=feasible(ref))
    if pool["feasible"].any():
        ok = pool[pool["feasible"]]
        full = ok.loc[ok[objective].idxmax()].to_dict()
        out.update(_row(full, law, space, cons, objective), feasible=True, best_generation=int(full["generation"]))
        t_end = law.push_start + space.get("law_t_push", (law.t_push, law.t_push))[1] + law.t_after
        out["apex_in_window"] = bool(full["apex_time"] < t_end - 0.01)  # else the height is a lower bound
    else:
        out.update(feasible=False, binding="no feasible law found")
    return out


def _polish(study, pool: pd.DataFrame, space: dict, cons: dict, objective: str, feasible, n: int, run: dict,
            poses: list | None = None) -> list:
    """The push line search (:func:`optimise_law`'s ``polish``) at the best pose and at the
    ``poses`` given ({variable: value}, push excluded), all poses in one batch per round; the next
    round's pushes lie between a pose's best feasible push and the shorter infeasible one next to
    it (feasibility need not be monotone in the push: a long push can take off late); :data:`POLISH_ROUNDS`
    grids of ``n`` pushes each; returns their rows with ``generation`` (the CMA-ES count + 1, + 2,
    ...) and ``feasible``."""
    lo, hi = space["law_t_push"]
    ok = pool[pool["feasible"]]
    best = (ok.loc[ok[objective].idxmax()] if len(ok) else pool.loc[pool[objective].idxmax()]).to_dict()
    g0 = int(pool["generation"].max()) + 1
    t_b = float(best["law_t_push"])
    starts = [({v: float(best[v]) for v in space if v != "law_t_push"}, max(lo, t_b - 0.08), t_b) if best["feasible"] else
              ({v: float(best[v]) for v in space if v != "law_t_push"}, t_b, hi)]
    starts += [({v: float(q[v]) for v in space if v != "law_t_push"}, lo, hi) for q in (poses or [])]
    out = []
    for k in range(POLISH_ROUNDS):
        table = pd.DataFrame([{**pose, "law_t_push": float(t)} for pose, a, b in starts for t in np.linspace(a, b, n)])
        rows = study.evaluate(table[list(space)], label=f"polish {k + 1}", **run).to_dict("records")
        out += [{**r, "generation": g0 + k, "feasible": feasible(r)} for r in rows]
        nxt = []
        for j, (pose, a, b) in enumerate(starts):  # per pose: the bracket below its best feasible push
            ts = np.linspace(a, b, n)
            rs = rows[j * n:(j + 1) * n]
            f = np.array([feasible(r) for r in rs])
            if f.any():
                i = max(np.flatnonzero(f), key=lambda m: rs[m][objective])
                if i > 0 and not f[i - 1]:  # a shorter push breaks a limit: the limit lies between
                    nxt.append((pose, float(ts[i - 1]), float(ts[i])))
        if not nxt:
            break
        starts = nxt
    return out


def _law_value(law: MotionLaw, name: str) -> float:
    return {"law_t_push": law.t_push, "law_extend_hip": law.extend[0], "law_extend_knee": law.extend[1]}[name]


def optimise_table_i(configurations=(1, 2, 3, 4), cases=(2,), link_model: str = "prbm", *, store=None, progress: bool = False,
                     cross: bool = True, **kw) -> pd.DataFrame:
    """:func:`optimise_law` for each configuration and link case (``store``: a folder, one store
    per variant under it); the ranking by jump height per case is in the ``rank`` column (1 =
    highest), the paper's ranking beside (``paper_rank``). ``cross``: then, per configuration,
    the push is also line-searched at every other configuration's optimum pose (``poses`` of
    :func:`optimise_law`; ``cross_gain_mm`` what that added): a check that each optimum is not
    a pose its CMA-ES missed."""
    from pathlib import Path

    rows = []
    for k in cases:
        case_rows = []
        for c in configurations:
            st = None if store is None else Path(store) / f"no{c}_case{k}_{link_model}"
            case_rows.append(optimise_law(c, k, link_model, store=st, **kw))
            if progress:
                print({x: (round(v, 3) if isinstance(v, float) else v) for x, v in case_rows[-1].items()}, flush=True)
        if cross and kw.get("polish", 6):
            # restarts at the other configurations' optimum poses (the CMA-ES of one configuration may miss a pose that
            # another found): the stored runs replay, only the new pushes run
            found = {r["configuration"]: {"law_extend_hip": r["extend_hip_deg"] * deg, "law_extend_knee": r["extend_knee_deg"] * deg}
                     for r in case_rows if r.get("feasible")}
            for j, c in enumerate(configurations):
                others = [q for o, q in found.items() if o != c]
                if others:
                    st = None if store is None else Path(store) / f"no{c}_case{k}_{link_model}"
                    r = optimise_law(c, k, link_model, store=st, poses=others, **kw)
                    r["cross_gain_mm"] = r.get("height_mm", math.nan) - case_rows[j].get("height_mm", math.nan)
                    case_rows[j] = r
                    if progress:
                        print({x: (round(v, 3) if isinstance(v, float) else v) for x, v in r.items()}, flush=True)
        rows += case_rows
    df = pd.DataFrame(rows)
    if "height_mm" in df:
        df["rank"] = df.groupby("link_case")["height_mm"].rank(ascending=False, method="min")
    df["paper_rank"] = df.groupby("link_case")["paper_jump_mm"].rank(ascending=False, method="min")
    return df


def push_at_limits(configuration: int, link_case: int, link_model: str = "prbm", *, pushes=(0.16, 0.20, 0.25, 0.30, 0.38, 0.45),
                   gears: str = "ideal", phase: str = CONSTRAINT_PHASE, rule: str = "settled", executor: str = "local", store=None,
                   progress: bool = False) -> dict:
    """The reduced co-design: the push duration alone varies (the extended pose at flegx_jump's
    default), over a grid of ``pushes`` [s] run as one batch. Where the jump height falls and
    each constrained output rises as the push lengthens (checked on the grid, reported as
    ``monotone``), the optimum is the shortest push at which every constraint holds: found by
    linear interpolation of each constraint's slack between grid points; the constraint whose
    slack reaches zero last is the binding one, and the heights are interpolated there
    (``height_mm``: :data:`OBJECTIVE`, ``jump_mm``: the guide's rise).

    ``rule``, where the grid is not monotone (a longer push that takes off late can break a
    limit again: measured, No. 2 case 2, a 0.364 s push leaves the ground just before the
    retraction and its hip torque peaks at 173 N m up to take-off, where 0.348 s and 0.38 s
    give 10 and 20 N m): ``"settled"`` (default, flegx-jump's) takes the shortest push from
    which each limit holds at every longer push of the grid; ``"first"`` the shortest push at
    which every limit holds, i.e. the first feasible grid point, interpolated from the
    infeasible one before it (longer pushes may break a limit again; ``feasible_after``
    says whether every longer push of the grid is feasible).
    Returns a row like :func:`optimise_law`'s plus the grid's own rows (``grid``)."""
    if rule not in ("settled", "first"):
        raise ModelError(f"flegx push_at_limits: rule {rule!r} is not known; expected 'settled' (each limit holds at every longer "
                         "push) or 'first' (the first push at which every limit holds).")
    cons = constraints(phase)
    study, law = codesign_study(configuration, link_case, link_model, gears, space={"law_t_push": (min(pushes), max(pushes))})
    rows = study.evaluate(pd.DataFrame({"law_t_push": sorted(pushes)}), executor=executor, store=store, progress=progress,
                          workers=1)
    rows = rows.sort_values("law_t_push").reset_index(drop=True)
    tp = rows["law_t_push"].to_numpy(float)
    mass, h_paper, s_paper = D.TABLE_I[configuration]
    out = {"configuration": configuration, "link_case": link_case, "link_model": link_model, "phase": phase,
           "paper_jump_mm": h_paper, "paper_stress_MPa": s_paper, "grid": rows}
    t_c, out["monotone"] = _push_limits(rows, cons, rule)
    out["rule"] = rule
    if any(math.isnan(v) for v in t_c.values()):
        out.update(binding="infeasible on the grid: " + ", ".join(c for c, v in t_c.items() if math.isnan(v)))
        return out
    c_bind = max(t_c, key=t_c.get)
    t_opt = t_c[c_bind]
    ok = _feasible_grid(rows, cons)
    out["feasible_after"] = bool(ok[tp > t_opt].all())
    at = {c: float(np.interp(t_opt, tp, rows[c].to_numpy(float))) for c in OUTPUTS}
    s_c, h_c, k_c = list(cons)[:3]
    out.update({"height_mm": 1e3 * at[OBJECTIVE], "jump_mm": 1e3 * at["jump_height"], "stress_MPa": at[s_c] / 1e6,
                "peak_hip_Nm": at[h_c], "peak_knee_Nm": at[k_c],
                **law_shape(t_opt, law.extend[0], law.extend[1], law),
                "binding": c_bind if t_opt > tp[0] else "law_t_push = lo (no constraint reached on the grid)"})
    return out


def _slacks(rows: pd.DataFrame, cons: dict) -> dict:
    from ..study.codesign import slack

    return {c: np.array([slack(op, b, v) for v in rows[c].to_numpy(float)]) for c, (op, b) in cons.items()}


def _all_hold(sl: dict) -> np.ndarray:
    """Per grid row: every constraint's slack (:func:`_slacks`) is non-negative."""
    return np.all(np.stack(list(sl.values())) >= 0, axis=0)


def _feasible_grid(rows: pd.DataFrame, cons: dict) -> np.ndarray:
    """Per grid row: every constraint holds."""
    return _all_hold(_slacks(rows, cons))


def _push_limits(rows: pd.DataFrame, cons: dict, rule: str = "settled") -> tuple[dict, bool]:
    """For a push grid (rows sorted by ``law_t_push``): per constraint, the push [s] from which
    it holds (linear interpolation of its slack; NaN: no such push on the grid), and whether the
    height falls and every slack rises with the push. ``rule`` (:func:`push_at_limits`):
    "settled", it holds at every longer push of the grid; "first", up to the first grid point
    at which every constraint holds (a constraint that holds at the point before it: that point)."""
    tp = rows["law_t_push"].to_numpy(float)
    h = rows["jump_height"].to_numpy(float)
    sl = _slacks(rows, cons)
    monotone = bool(np.all(np.diff(h) <= 0) and all(np.all(np.diff(v) >= 0) for v in sl.values()))
    if rule == "first":
        ok = np.flatnonzero(_all_hold(sl))
        if not ok.size:
            return {c: (math.nan if np.any(v < 0) else tp[0]) for c, v in sl.items()}, monotone
        k = int(ok[0])
        if k == 0:
            return {c: tp[0] for c in sl}, monotone
        return {c: (tp[k - 1] if v[k - 1] >= 0 else tp[k - 1] + (0.0 - v[k - 1]) / (v[k] - v[k - 1]) * (tp[k] - tp[k - 1]))
                for c, v in sl.items()}, monotone
    t_c = {}
    for c, v in sl.items():
        if np.all(v >= 0):
            t_c[c] = tp[0]
        elif v[-1] < 0:
            t_c[c] = math.nan  # violated on the whole grid: lengthen the pushes
        else:
            k = int(np.max(np.nonzero(v < 0)[0]))
            t_c[c] = tp[k] + (0.0 - v[k]) / (v[k + 1] - v[k]) * (tp[k + 1] - tp[k])
    return t_c, monotone


def ranking_text(df: pd.DataFrame) -> str:
    """'No. 3 > No. 4 > ...' per link case, ours and the paper's (numbers from the table)."""
    lines = []
    for k, g in df.groupby("link_case"):
        col = "height_mm" if "height_mm" in g else "jump_mm"
        ours = " > ".join(f"No. {int(c)}" for c in g.sort_values(col, ascending=False)["configuration"]) if col in g else "n/a"
        paper = " > ".join(f"No. {int(c)}" for c in g.sort_values("paper_jump_mm", ascending=False)["configuration"])
        lines.append(f"case {k}: optimised laws {ours}; paper {paper}")
    return "\n".join(lines)


if __name__ == "__main__":  # pragma: no cover - a manual run: python -m proleg.papers.flegx_codesign
    import sys

    n = int(sys.argv[1]) if len(sys.argv) > 1 else 64
    df = optimise_table_i(n_trials=n, progress=True)
    with pd.option_context("display.width", 200, "display.max_columns", 40):
        print(df)
    print(ranking_text(df))
