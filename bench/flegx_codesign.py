"""FLEGX Table I by co-design (issue 30): per configuration, the jump law found by an
optimiser within the paper's stress limit (520 MPa) and the worm wheel's rating (77 N m),
beside the paper's Table I (proleg.papers.flegx_codesign).

    python bench/flegx_codesign.py                      # reduced: push duration only, case 2, PRBM
    python bench/flegx_codesign.py --full --trials 32   # push duration and extended pose, CMA-ES

Writes bench/results/flegx_codesign.md (the table and the ranking, every number from the run).
"""

from __future__ import annotations

import argparse
import pathlib
import time

import pandas as pd

from proleg.papers import flegx_codesign as FC

HERE = pathlib.Path(__file__).parent
COLS = ["configuration", "link_case", "jump_mm", "paper_jump_mm", "stress_takeoff_MPa", "paper_stress_MPa", "peak_hip_Nm",
        "peak_knee_Nm", "t_push_s", "extend_hip_deg", "extend_knee_deg", "binding"]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--configurations", type=int, nargs="+", default=[1, 2, 3, 4])
    ap.add_argument("--cases", type=int, nargs="+", default=[2])
    ap.add_argument("--link-model", default="prbm")
    ap.add_argument("--pushes", type=float, nargs="+", default=[0.16, 0.20, 0.25, 0.30, 0.38, 0.45])
    ap.add_argument("--full", action="store_true", help="CMA-ES over push duration and extended pose")
    ap.add_argument("--trials", type=int, default=24)
    a = ap.parse_args()
    t0 = time.perf_counter()
    rows, grids = [], []
    for k in a.cases:
        for c in a.configurations:
            if a.full:
                r = FC.optimise_law(c, k, a.link_model, n_trials=a.trials, store=HERE / "results" / "flegx_codesign" / f"{c}_{k}")
            else:
                r = FC.push_at_limits(c, k, a.link_model, pushes=tuple(a.pushes), store=HERE / "results" / "flegx_codesign_push" / f"{c}_{k}_{min(a.pushes):g}-{max(a.pushes):g}")
                g = r.pop("grid")
                g.insert(0, "configuration", c)
                grids.append(g)
            rows.append(r)
            print(r, flush=True)
    df = pd.DataFrame(rows)
    for col in COLS:
        if col not in df:
            df[col] = float("nan")
    text = [f"# FLEGX co-design ({'CMA-ES, push and pose' if a.full else 'push duration only'}; {a.link_model}; "
            f"{time.perf_counter() - t0:.0f} s)", "", df[COLS].round(3).to_string(index=False), "", FC.ranking_text(df)]
    if grids:
        text += ["", "Grid (every push run):", "", pd.concat(grids)[["configuration", "law_t_push", *FC.OUTPUTS]].round(4).to_string(index=False)]
    out = HERE / "results" / ("flegx_codesign_full.md" if a.full else f"flegx_codesign_{min(a.pushes):g}-{max(a.pushes):g}.md")
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text("\n".join(text) + "\n")
    print("\n".join(text))


if __name__ == "__main__":
    main()
