"""HyQ trot (issue 33): wall time, steps/s and where the time goes, both actuator variants.

    PYTHONPATH=src nice -n 5 python bench/hyq_trot.py [t_end=8.0] [variants=hydraulic,torque]
    PYTHONPATH=src python bench/hyq_trot.py --from-report results/hyq-trot "note"   (timings of a report run)

Prints a table and writes bench/results/hyq_trot.csv: per variant the simulated time, integrator
steps, wall time of the first (compile included) run, steps/s, and the split assemble /
compile+run / outputs (metrics post-processing), with the machine's load average (the 2-core
machine is shared: the load says how much of it the run had).
"""

import os
import sys
import time
from pathlib import Path

import pandas as pd


def main(t_end=8.0, variants=("hydraulic", "torque")):
    from proleg.analyses.simulate import simulate
    from proleg.assembly.assemble import assemble
    from proleg.robots.hyq_trot import TrotRun, hyq_trot_model, trot_metrics
    from proleg.solvers.galpha import GeneralizedAlpha

    rows = []
    for a in variants:
        t0 = time.perf_counter()
        model = hyq_trot_model(1.0, a)
        system = assemble(model)
        t1 = time.perf_counter()
        ig = GeneralizedAlpha(jacobian_reuse=True)
        res = simulate(system, t_end=t_end, dt_output=5e-3, integrator=ig, progress=False)
        t2 = time.perf_counter()
        m = trot_metrics(TrotRun(res, {}, a, model.trot["gait"], t2 - t1))
        t3 = time.perf_counter()
        st = res.stats
        # warm: the same run again in this process (compiled), the fastest of two; CPU time too
        warm, cpu = [], []
        for _ in range(2):
            w0, c0 = time.perf_counter(), time.process_time()
            simulate(system, t_end=t_end, dt_output=5e-3, integrator=ig, progress=False)
            warm.append(time.perf_counter() - w0)
            cpu.append(time.process_time() - c0)
        rows.append({
            "variant": a, "t_end [s]": t_end, "steps": st["steps"], "rejected": st["rejected"], "newton": st["newton_iterations"],
            "jacobians": st["jacobians"], "assemble [s]": t1 - t0, "compile+simulate [s]": t2 - t1, "metrics [s]": t3 - t2,
            "total [s]": t3 - t0, "steps/s": st["steps"] / (t2 - t1), "warm [s]": min(warm), "warm cpu [s]": min(cpu),
            "coordinates": res.coordinates, "forward_speed": m["forward_speed"], "base_height_min": m["base_height_min"],
            "max_joint_torque": m["max_joint_torque"], "fell": m["fell"], "load (1 min)": os.getloadavg()[0],
        })
        print(pd.DataFrame(rows).to_string(index=False), flush=True)
    out = Path(__file__).parent / "results"
    out.mkdir(exist_ok=True)
    pd.DataFrame(rows).to_csv(out / "hyq_trot.csv", index=False)
    # beside the committed report's metrics (bench/results/hyq_trot_report_metrics.csv), as markdown
    ref = pd.read_csv(out / "hyq_trot_report_metrics.csv", index_col=0) if (out / "hyq_trot_report_metrics.csv").exists() else None
    cols = ["variant", "t_end [s]", "coordinates", "steps", "rejected", "compile+simulate [s]", "warm [s]", "warm cpu [s]",
            "forward_speed", "base_height_min", "max_joint_torque", "load (1 min)"]
    md = ["# HyQ trot, first and warm runs (bench/hyq_trot.py)", "",
          f"{time.strftime('%Y-%m-%d %H:%M')}, {os.cpu_count()} cores; warm = the fastest of two more runs in the same process "
          "(compile excluded), targets of issue 43: torque sources <= 8 s, cylinders <= 16 s for 8 s simulated.", "",
          "| " + " | ".join(cols + ["report's speed / height / torque"]) + " |", "|" + "---|" * (len(cols) + 1)]
    for r in rows:
        refs = "" if ref is None or r["variant"] not in ref.columns else " / ".join(
            f"{float(ref.loc[k, r['variant']]):.4g}" for k in ("forward_speed", "base_height_min", "max_joint_torque"))
        md.append("| " + " | ".join(f"{r[c]:.4g}" if isinstance(r[c], float) else str(r[c]) for c in cols) + f" | {refs} |")
    (out / "hyq_trot_warm.md").write_text("\n".join(md) + "\n")


def from_report(report_dir, note="", t_end=8.0):
    """Record the timings of a ``proleg run hyq-trot`` run (its metrics.csv: both variants ran side
    by side in two threads, compile included) in bench/results/hyq_trot_report.csv."""
    m = pd.read_csv(Path(report_dir) / "metrics.csv", index_col=0)
    rows = []
    for a in m.columns:
        c = m[a]
        sim = float(c["wall_s"])
        rows.append({
            "variant": a, "t_end [s]": t_end, "steps": int(float(c["steps"])),
            "compile+simulate [s]": sim, "steps/s": float(c["steps"]) / sim, "simulated s per wall min": 60 * t_end / sim,
            "forward_speed": float(c["forward_speed"]), "fell": c["fell"], "note": note,
        })
    df = pd.DataFrame(rows)
    print(df.to_string(index=False))
    out = Path(__file__).parent / "results"
    out.mkdir(exist_ok=True)
    df.to_csv(out / "hyq_trot_report.csv", index=False)


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == "--from-report":
        from_report(sys.argv[2], sys.argv[3] if len(sys.argv) > 3 else "", float(sys.argv[4]) if len(sys.argv) > 4 else 8.0)
        sys.exit()
    t_end = float(sys.argv[1]) if len(sys.argv) > 1 else 8.0
    variants = tuple(sys.argv[2].split(",")) if len(sys.argv) > 2 else ("hydraulic", "torque")
    main(t_end, variants)
