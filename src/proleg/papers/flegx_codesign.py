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

Constraints:

- ``max_stress_takeoff`` ≤ ``STRESS_LIMIT`` = 520 MPa: Table I's stresses all lie in
  514.6-530.7 MPa (``flegx_data.TABLE_I``), the phase Table I studies (take-off);
- ``peak_hip_torque``, ``peak_knee_torque`` ≤ 77 N m: the worm wheel's rating with mineral
  grease (seed 002 §III.C, ``flegx_data.WORM_OUTPUT_TORQUE_LIMIT``).

Each optimum reports its binding constraint: the constraint whose slack at the optimum is
within ``BINDING_TOL`` of its bound, or a bound of the law's ranges.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pandas as pd

from ..units import deg
from ..robots import flegx_data as D
from ..robots.flegx import flegx
from .flegx_jump import MotionLaw, _add_motions, jump_metrics

__all__ = ["STRESS_LIMIT", "LAW_SPACE", "codesign_study", "optimise_law", "optimise_table_i"]

STRESS_LIMIT = 520e6  # [Pa] seed 002 Table I: 514.6-530.7 MPa
WHEEL_RATING = D.WORM_OUTPUT_TORQUE_LIMIT  # [N m] seed 002 §III.C
#: ranges of the law's variables: the push 0.12-0.45 s (a push shorter than 0.12 s leaves the
#: ground before the knee has extended; 0.45 s is slower than flegx-jump's 0.30 s), the
#: extended pose inside the joint ranges (flegx_data, assumed) and straighter than the squat
LAW_SPACE = {"law_t_push": (0.12, 0.45), "law_extend_hip": (-40.0 * deg, 0.0), "law_extend_knee": (15.0 * deg, 80.0 * deg)}
BINDING_TOL = 0.02  # a constraint within 2 % of its bound at the optimum binds
CONSTRAINTS = {"max_stress_takeoff": ("<=", STRESS_LIMIT), "peak_hip_torque": ("<=", WHEEL_RATING),
               "peak_knee_torque": ("<=", WHEEL_RATING)}
OUTPUTS = ("jump_height", "max_stress_takeoff", "max_stress", "peak_hip_torque", "peak_knee_torque", "take_off_time",
           "foot_clearance", "tip_displacement")


def codesign_study(configuration: int, link_case: int, link_model: str = "prbm", gears: str = "ideal", *,
                   space: dict | None = None, t_after: float = 0.2, dt_output: float = 2e-3, rtol: float = 1e-5, atol: float = 1e-6):
    """A :class:`proleg.study.Study` of one FLEGX variant over the jump law's variables.

    ``space``: the law variables to vary, {name: (lo, hi)} (default :data:`LAW_SPACE`); a
    variable left out stays at flegx_jump's default law. Returns (study, law)."""
    import proleg as pl

    space = dict(LAW_SPACE if space is None else space)
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
            cache.update(r=r, m=m)
        return cache["m"]

    outputs = {k: (lambda r, k=k: metrics(r)[k]) for k in OUTPUTS}
    t_push_max = space.get("law_t_push", (law.t_push, law.t_push))[1]
    t_end = law.push_start + t_push_max + t_after
    sim = dict(t_end=t_end, dt_output=dt_output, integrator=pl.GeneralizedAlpha(rtol=rtol, atol=atol, dt_max=dt_output))
    study = pl.study.Study(system, space, outputs, simulate=sim, name=f"flegx No.{configuration} case {link_case} {link_model}")
    return study, law


def _binding(row: dict, space: dict) -> str:
    from ..study.codesign import slack

    out = [c for c, (op, b) in CONSTRAINTS.items() if abs(slack(op, b, float(row[c]))) <= BINDING_TOL]
    for k, (lo, hi) in space.items():
        span = hi - lo
        if float(row[k]) <= lo + 0.01 * span:
            out.append(f"{k} = lo")
        elif float(row[k]) >= hi - 0.01 * span:
            out.append(f"{k} = hi")
    return ", ".join(out) if out else "none (interior optimum)"


def optimise_law(configuration: int, link_case: int, link_model: str = "prbm", *, n_trials: int = 24, batch: int = 6,
                 seed: int = 0, space: dict | None = None, store=None, executor: str = "local", progress: bool = False) -> dict:
    """The law of largest ``jump_height`` within :data:`CONSTRAINTS` for one variant (module
    docstring). Returns a row: the optimum's outputs and law, its binding constraint, the
    number of trials and the paper's Table I values beside (``paper_*``)."""
    space = dict(LAW_SPACE if space is None else space)
    study, law = codesign_study(configuration, link_case, link_model, space=space)
    opt = study.optimize("jump_height", CONSTRAINTS, n_trials=n_trials, sampler="cma", direction="maximize", batch=batch,
                         seed=seed, store=store, executor=executor, progress=progress, workers=1)
    tr = opt.trials
    best = tr.loc[tr["key"] == _key_of(tr, opt.best_params)].iloc[0].to_dict() if opt.best_params else {}
    rows = opt.rows.drop_duplicates("key").set_index("key")
    full = {**best, **rows.loc[best["key"]].to_dict()} if best else {}
    mass, h_paper, s_paper = D.TABLE_I[configuration]
    out = {"configuration": configuration, "link_case": link_case, "link_model": link_model, "trials": len(tr),
           "feasible_trials": int(tr["feasible"].sum()), "paper_jump_mm": h_paper, "paper_stress_MPa": s_paper}
    if full:
        out.update({"jump_mm": 1e3 * full["jump_height"], "stress_takeoff_MPa": full["max_stress_takeoff"] / 1e6,
                    "peak_hip_Nm": full["peak_hip_torque"], "peak_knee_Nm": full["peak_knee_torque"],
                    "t_push_s": float(full.get("law_t_push", law.t_push)),
                    "extend_hip_deg": float(full.get("law_extend_hip", law.extend[0])) / deg,
                    "extend_knee_deg": float(full.get("law_extend_knee", law.extend[1])) / deg,
                    "feasible": bool(best["feasible"]), "binding": _binding(full, space)})
    return out


def _key_of(trials: pd.DataFrame, params: dict) -> str:
    names = list(params)
    d = np.zeros(len(trials))
    for k in names:
        d += np.abs(trials[k].to_numpy(float) - float(params[k]))
    return trials["key"].iloc[int(np.argmin(d))]


def optimise_table_i(configurations=(1, 2, 3, 4), cases=(2,), link_model: str = "prbm", **kw) -> pd.DataFrame:
    """:func:`optimise_law` for each configuration and link case; the ranking by jump height per
    case is in the ``rank`` column (1 = highest), the paper's ranking beside (``paper_rank``)."""
    rows = [optimise_law(c, k, link_model, **kw) for k in cases for c in configurations]
    df = pd.DataFrame(rows)
    if "jump_mm" in df:
        df["rank"] = df.groupby("link_case")["jump_mm"].rank(ascending=False, method="min")
    df["paper_rank"] = df.groupby("link_case")["paper_jump_mm"].rank(ascending=False, method="min")
    return df


def push_at_limits(configuration: int, link_case: int, link_model: str = "prbm", *, pushes=(0.16, 0.20, 0.25, 0.30, 0.38, 0.45),
                   gears: str = "ideal", executor: str = "local", store=None, progress: bool = False) -> dict:
    """The reduced co-design: the push duration alone varies (the extended pose at flegx_jump's
    default), over a grid of ``pushes`` [s] run as one batch. Where the jump height falls and
    each constrained output rises as the push lengthens (checked on the grid, reported as
    ``monotone``), the optimum is the shortest push at which every constraint holds: found by
    linear interpolation of each constraint's slack between grid points; the constraint whose
    slack reaches zero last is the binding one, and the jump height is interpolated there.
    Returns a row like :func:`optimise_law`'s plus the grid's own rows (``grid``)."""
    from ..study.codesign import slack

    study, law = codesign_study(configuration, link_case, link_model, gears, space={"law_t_push": (min(pushes), max(pushes))})
    rows = study.evaluate(pd.DataFrame({"law_t_push": sorted(pushes)}), executor=executor, store=store, progress=progress,
                          workers=1)
    rows = rows.sort_values("law_t_push").reset_index(drop=True)
    tp = rows["law_t_push"].to_numpy(float)
    h = rows["jump_height"].to_numpy(float)
    mass, h_paper, s_paper = D.TABLE_I[configuration]
    out = {"configuration": configuration, "link_case": link_case, "link_model": link_model, "paper_jump_mm": h_paper,
           "paper_stress_MPa": s_paper, "grid": rows}
    sl = {c: np.array([slack(op, b, v) for v in rows[c].to_numpy(float)]) for c, (op, b) in CONSTRAINTS.items()}
    out["monotone"] = bool(np.all(np.diff(h) <= 0) and all(np.all(np.diff(v) >= 0) for v in sl.values()))
    # the shortest feasible push for each constraint (slack ≥ 0 from there on)
    t_c = {}
    for c, v in sl.items():
        if np.all(v >= 0):
            t_c[c] = tp[0]
        elif v[-1] < 0:
            t_c[c] = math.nan  # violated on the whole grid: lengthen the pushes
        else:
            k = int(np.max(np.nonzero(v < 0)[0]))
            t_c[c] = tp[k] + (0.0 - v[k]) / (v[k + 1] - v[k]) * (tp[k + 1] - tp[k])
    if any(math.isnan(v) for v in t_c.values()):
        out.update(binding="infeasible on the grid: " + ", ".join(c for c, v in t_c.items() if math.isnan(v)))
        return out
    c_bind = max(t_c, key=t_c.get)
    t_opt = t_c[c_bind]
    at = {c: float(np.interp(t_opt, tp, rows[c].to_numpy(float))) for c in (*OUTPUTS,)}
    out.update({"jump_mm": 1e3 * at["jump_height"], "stress_takeoff_MPa": at["max_stress_takeoff"] / 1e6,
                "peak_hip_Nm": at["peak_hip_torque"], "peak_knee_Nm": at["peak_knee_torque"], "t_push_s": t_opt,
                "extend_hip_deg": law.extend[0] / deg, "extend_knee_deg": law.extend[1] / deg,
                "binding": c_bind if t_opt > tp[0] else "law_t_push = lo (no constraint reached on the grid)"})
    return out


def ranking_text(df: pd.DataFrame) -> str:
    """'No. 3 > No. 4 > ...' per link case, ours and the paper's (numbers from the table)."""
    lines = []
    for k, g in df.groupby("link_case"):
        ours = " > ".join(f"No. {int(c)}" for c in g.sort_values("jump_mm", ascending=False)["configuration"]) if "jump_mm" in g else "n/a"
        paper = " > ".join(f"No. {int(c)}" for c in g.sort_values("paper_jump_mm", ascending=False)["configuration"])
        lines.append(f"case {k}: optimised laws {ours}; paper {paper}")
    return "\n".join(lines)


if __name__ == "__main__":  # pragma: no cover - a manual run: python -m proleg.papers.flegx_codesign
    import sys

    n = int(sys.argv[1]) if len(sys.argv) > 1 else 24
    df = optimise_table_i(n_trials=n)
    with pd.option_context("display.width", 200, "display.max_columns", 30):
        print(df)
    print(ranking_text(df))
