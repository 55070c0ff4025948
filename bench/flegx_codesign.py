"""FLEGX Table I by co-design (issue 30): per configuration, the jump law found by CMA-ES
within the paper's stress limit (520 MPa) and the worm wheel's rating (77 N m) over the
take-off phase (seed 002 §IV), beside the paper's Table I (proleg.papers.flegx_codesign).

    python bench/flegx_codesign.py                          # full: CMA-ES, push and pose, 64 trials, case 2
    python bench/flegx_codesign.py --trials 24 --batch 6    # the reduced size of `proleg run flegx-study`
    python bench/flegx_codesign.py --push-only              # push duration only (push_at_limits)
    python bench/flegx_codesign.py --phases 4 0.25 0.4      # per-phase peaks of one jump (No., push [s], t_after [s])

Writes bench/results/flegx_codesign_full.md (or _push.md): the table, the ranking, the
convergence history, the wall time and the load average; every number from the run.
"""

from __future__ import annotations

import argparse
import os
import pathlib
import time

import numpy as np
import pandas as pd

from proleg.papers import flegx_codesign as FC

HERE = pathlib.Path(__file__).parent
COLS = ["configuration", "link_case", "total_mass_kg", "paper_mass_kg", "height_mm", "paper_jump_mm", "jump_mm", "flight_rise_mm", "foot_clearance_mm", "stress_MPa", "paper_stress_MPa",
        "peak_hip_Nm", "peak_knee_Nm", "binding"]
LAW = ["configuration", "link_case", "t_push_s", "extend_hip_deg", "extend_knee_deg", "stroke_hip_deg", "stroke_knee_deg",
       "speed_hip_dps", "speed_knee_dps", "take_off_s", "apex_s"]
RUN = ["configuration", "link_case", "trials", "feasible_trials", "start_t_push_s", "start_height_mm", "ref_height_mm", "ref_feasible", "history_mm",
       "converged", "polish_gain_mm", "cross_gain_mm", "best_generation", "apex_in_window", "takeoff_in_push", "stress_all_MPa", "peak_hip_all_Nm", "peak_knee_all_Nm"]


def phases(configuration: int, t_push: float, t_after: float) -> str:
    """Peaks of hip torque, knee torque, clamp stress and ground force per phase of one jump (PRBM, case 2)."""
    from proleg.papers.flegx_jump import flegx_jump

    j = flegx_jump(configuration, 2, "prbm", t_push=t_push, t_after=t_after, dt_output=2e-3)
    m, s, law = j.metrics, j.series, j.law
    t = s["time [s]"]
    t_ld = m["landing_time"] if np.isfinite(m["landing_time"]) else np.inf
    cuts = [("stand + squat", 0.0, law.push_start), ("push to take-off", law.push_start, m["take_off_time"] + 1e-9),
            ("flight", m["take_off_time"] + 1e-9, t_ld), ("landing on", t_ld, np.inf)]
    rows = []
    for col in ("hip_torque [N m]", "knee_joint_torque [N m]", "clamp_stress [Pa]", "ground_force [N]"):
        x = np.abs(s[col])
        r = {"channel": col}
        for lab, a, b in cuts:
            sel = (t >= a) & (t < b)
            r[lab] = f"{x[sel].max():.4g} at {t[sel][np.argmax(x[sel])]:.3f} s" if sel.any() else "-"
        rows.append(r)
    head = (f"No. {configuration}, case 2, PRBM, push {t_push} s, run to {t_after} s after the push: take-off "
            f"{m['take_off_time']:.3f} s, apex {m['apex_time']:.3f} s, landing {m['landing_time']:.3f} s, jump {1e3 * m['jump_height']:.1f} mm")
    return head + "\n\n" + pd.DataFrame(rows).to_string(index=False)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--configurations", type=int, nargs="+", default=[1, 2, 3, 4])
    ap.add_argument("--cases", type=int, nargs="+", default=[2])
    ap.add_argument("--link-model", default="prbm")
    ap.add_argument("--phase", default=FC.CONSTRAINT_PHASE, help="'takeoff' (Table I's phase) or 'all' (landing included)")
    ap.add_argument("--push-only", action="store_true", help="push duration only, on a grid (push_at_limits)")
    ap.add_argument("--pushes", type=float, nargs="+", default=[0.16, 0.20, 0.25, 0.30, 0.38, 0.45])
    ap.add_argument("--trials", type=int, default=64)
    ap.add_argument("--batch", type=int, default=8)
    ap.add_argument("--phases", type=float, nargs=3, metavar=("NO", "T_PUSH", "T_AFTER"))
    ap.add_argument("--objective", default=FC.OBJECTIVE, choices=["foot_clearance", "flight_rise", "jump_height"],
                    help="the height maximised (flegx_jump's metrics; seed 002 does not say which height Table I measured)")
    ap.add_argument("--out", default=None)
    a = ap.parse_args()
    if a.phases:
        print(phases(int(a.phases[0]), a.phases[1], a.phases[2]))
        return
    t0, load0 = time.perf_counter(), os.getloadavg()
    store = HERE / "results" / "flegx_codesign_store" / a.phase
    if a.objective != FC.OBJECTIVE:
        store = store / a.objective
    if a.push_only:
        rows = []
        for k in a.cases:
            for c in a.configurations:
                r = FC.push_at_limits(c, k, a.link_model, pushes=tuple(a.pushes), phase=a.phase, store=store / f"push_{c}_{k}")
                r.pop("grid")
                rows.append(r)
        df = pd.DataFrame(rows)
    else:
        df = FC.optimise_table_i(a.configurations, a.cases, a.link_model, phase=a.phase, n_trials=a.trials, batch=a.batch, objective=a.objective,
                                 reference={}, store=store / f"cma_n{a.trials}_b{a.batch}", progress=True)
    wall, load1 = time.perf_counter() - t0, os.getloadavg()
    for col in COLS + LAW + RUN:
        if col not in df:
            df[col] = float("nan")
    kind = "push duration only (push_at_limits)" if a.push_only else (f"CMA-ES over push and pose, {a.trials} trials, population {a.batch}, "
                                                                                   "started at the push-only optimum, polished along the push, cross-restarts")
    text = [f"# FLEGX Table I by co-design ({kind}; {a.link_model}; limits over the '{a.phase}' phase)", "",
            f"Wall {wall:.0f} s on a 2-core machine shared with other developers (load average, 1 min: {load0[0]:.1f} at start, "
            f"{load1[0]:.1f} at end); `python bench/flegx_codesign.py {' '.join(os.sys.argv[1:])}`.", "",
            "## Optimum vs seed 002 Table I (link 250 × 70 × 3 mm)", "",
            f"height_mm: the objective, {a.objective} (foot_clearance: the foot's clearance over the flight; flight_rise: the guide's rise "
            "from take-off to apex, v²/2g of the flight; jump_height: the guide's apex above standing); flight_rise_mm and foot_clearance_mm beside; jump_mm: the guide's apex above standing (flegx_jump's "
            "jump_height); stress and torques up to take-off; binding: the limits within 2 % at the optimum, or a bound of the law.", "", "```", df[COLS].round(2).to_string(index=False), "```", "",
            FC.ranking_text(df), "", "## The law at the optimum (push from the squat (−50°, 100°) to the extended pose; cubic STEP, Eq. 18)",
            "", "```", df[LAW].round(3).to_string(index=False), "```", "",
            "## Run: convergence (best feasible height after each generation, mm), the reference law (flegx_jump's 0.30 s, (−20°, 40°)), "
            "and the whole-run peaks (landing included) at the optimum", "", "```", df[RUN].round(2).to_string(index=False), "```"]
    suffix = "" if a.objective == FC.OBJECTIVE else f"_{a.objective}"
    out = pathlib.Path(a.out) if a.out else HERE / "results" / (f"flegx_codesign_push{suffix}.md" if a.push_only else f"flegx_codesign_full{suffix}.md")
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text("\n".join(text) + "\n")
    print("\n".join(text))


if __name__ == "__main__":
    main()
