"""Throughput of one proleg.study design (variants/s) by executor: a loop of sequential
``simulate()`` calls, ``vmap`` (proleg.sweep batches in this process), ``processes`` (2 local
worker processes) and ``dask`` (LocalCluster, 2 single-threaded workers).

    PYTHONPATH=src python bench/study_throughput.py --model pendulum --n 64
    PYTHONPATH=src python bench/study_throughput.py --model hyq --n 1000      # the issue's case (long)

``--rows`` measures what issue 42 item 5 asks instead: on the README pendulum, the HyQ leg and
a FLEGX variant, a sweep with no integrator named (the method ``simulate`` would choose,
analyses/sweep.py ``batch_integrator``) against the same sweep with ``GeneralizedAlpha()``
named (what a sweep ran before it made ``simulate``'s choice): compile and run times and run
throughput, and each row's largest relative difference from ``simulate(system.with_params(row))``
(positions over the whole run, and a Study's scalar output). Writes
bench/results/study_rows_vs_simulate[_TAG].md and .json.

    PYTHONPATH=src python bench/study_throughput.py --rows --models readme,hyq,flegx --n 12

Every executor starts from an empty store (wall time includes compilation and, for processes
and dask, starting the workers); the persistent compilation cache is on, as for a user.
Writes bench/results/study_throughput_<model>_<n>.csv.
"""

from __future__ import annotations

import argparse
import os
import platform
import shutil
import sys
import tempfile
import time
from pathlib import Path

import pandas as pd

import proleg as pl

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from models import spring_pendulum  # noqa: E402  (one definition, shared with the tests)


def pendulum_study():
    """The tests' spring double pendulum (tests/models.py) as a two-parameter study."""
    return pl.study.Study(spring_pendulum("bench_pendulum"), space={"spring.stiffness": (10.0, 1000.0), "spring.damping": (0.1, 1.0)},
                          outputs={"x_end": _x_end}, simulate=dict(t_end=1.0, dt_output=0.01))


def _x_end(r):
    return r.part("lower").position[-1, 0]


def _rows_models(names):
    """{name: (System, {param: (lo, hi)}, simulate kwargs, output part)} of ``--rows``."""
    from proleg.robots import flegx, hyq_leg

    out = {}
    for name in names:
        if name == "readme":  # README "Ten lines": the spring-hung double pendulum, 2 s at 1 ms outputs
            out[name] = (spring_pendulum("double_pendulum"), {"spring.stiffness": (20.0, 100.0), "spring.damping": (0.1, 1.0)},
                         dict(t_end=2.0, dt_output=1e-3), "lower")
        elif name == "hyq":  # the HyQ leg's drop on the HAL bench (rigid pins, high gain)
            out[name] = (pl.assemble(hyq_leg("rigid")), {"foot.stiffness": (5e4, 2e5), "knee_servo.kp": (200.0, 400.0)},
                         dict(t_end=0.3, dt_output=1e-3), "lower_leg")
        elif name == "flegx":  # FLEGX configuration 4, link case 2, rigid link: a drop onto its foot
            out[name] = (pl.assemble(flegx(4, 2, "rigid")), {"foot.stiffness": (5e4, 2e5), "foot.damping": (50.0, 200.0)},
                         dict(t_end=0.2, dt_output=1e-3), "link")
        else:
            raise SystemExit(f"--models: unknown model {name!r} (readme, hyq, flegx)")
    return out


def rows_vs_simulate(args):
    """Issue 42 item 5: rows against simulate, and the sweep's throughput with the method
    simulate chooses against the α-method a sweep ran before."""
    import json
    import warnings

    import numpy as np

    from proleg.analyses.sweep import batch_integrator
    from proleg.analyses.simulate import simulate_kwargs

    warnings.simplefilter("ignore")  # the models' own assembly notes
    table = []
    for name, (system, space, kw, part) in _rows_models(args.models.split(",")).items():
        study = pl.study.Study(system, space=space, outputs={"x_end": lambda r, p=part: r.part(p).position[-1, 0]}, simulate=kw)
        design = study.design("lhs", args.n, seed=1)
        values = {k: design[k].to_numpy(float) for k in space}
        chosen, why, _ = batch_integrator(system, kw["t_end"], kw.get("dt_output"), simulate_kwargs(kw))
        cases = [("auto", {})]
        if type(chosen).__name__ != "GeneralizedAlpha":  # the same code path otherwise
            cases.append(("GeneralizedAlpha() named (the sweep's method before)", {"integrator": pl.GeneralizedAlpha()}))
        for label, extra in cases:
            res = pl.sweep(system, values, **kw, **extra)
            res2 = pl.sweep(system, values, **kw, **extra)  # warm: the compiled batch again, run only
            worst = 0.0
            for i in range(min(args.check, len(res))):
                ref = pl.simulate(system.with_params({k: v[i] for k, v in values.items()}), progress=False, **kw, **extra)
                q, qr = np.asarray(res[i].q), np.asarray(ref.q)
                worst = max(worst, float(np.abs(q - qr).max() / np.abs(qr).max()))
            row = {"model": name, "integrator": label if extra else res.integrator.describe(), "variants": len(res),
                   "compile [s]": round(res.compile_time, 2), "run [s]": round(min(res.wall_time, res2.wall_time), 3),
                   "run variants/s": round(len(res) / min(res.wall_time, res2.wall_time), 2),
                   "steps (mean)": float(np.mean(res.stats["steps"])), f"max rel |q - simulate| ({args.check} rows)": f"{worst:.2e}"}
            if not extra:  # a Study's rows (vmap executor) against simulate's scalar output
                tab = study.evaluate(design, executor="vmap", progress=False)
                dev = 0.0
                for i in range(min(args.check, len(tab))):
                    ref = pl.simulate(system.with_params({k: tab[k][i] for k in space}), progress=False, **kw)
                    x = float(ref.part(part).position[-1, 0])
                    dev = max(dev, abs(float(tab["x_end"][i]) - x) / max(abs(x), 1e-300))
                row["study rows: max rel |x_end - simulate|"] = f"{dev:.2e}"
            table.append(row)
            print(row, flush=True)
    cols = list(dict.fromkeys(k for r in table for k in r))
    md = ["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    md += ["| " + " | ".join(str(r.get(c, "")) for c in cols) + " |" for r in table]
    machine = f"{platform.node()}, {os.cpu_count()} cores, load (1 min) {os.getloadavg()[0]:.1f} at the end"
    text = (f"# Sweep rows against simulate, and sweep throughput (issue 42 item 5)\n\n{machine}; "
            f"{time.strftime('%Y-%m-%d %H:%M')} UTC; run [s]: the faster of two runs of the compiled batch.\n\n" + "\n".join(md) + "\n")
    print(text)
    stem = Path(__file__).parent / "results" / f"study_rows_vs_simulate{'_' + args.tag if args.tag else ''}"
    stem.with_suffix(".md").write_text(text)
    stem.with_suffix(".json").write_text(json.dumps({"machine": machine, "rows": table}, indent=1))
    print(f"wrote {stem}.md/.json")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--rows", action="store_true", help="rows against simulate and sweep throughput by method (issue 42 item 5)")
    ap.add_argument("--models", default="readme,hyq,flegx", help="--rows: models (readme, hyq, flegx)")
    ap.add_argument("--check", type=int, default=3, help="--rows: rows compared with simulate per model")
    ap.add_argument("--tag", default="", help="--rows: suffix of the results file")
    ap.add_argument("--model", choices=["pendulum", "hyq"], default="pendulum")
    ap.add_argument("--n", type=int, default=64)
    ap.add_argument("--executors", default="sequential,vmap,processes,dask")
    ap.add_argument("--lanes", type=int, default=None,
                    help="variants per compiled vmap call inside a batch (Study.run lanes=; default: the whole batch)")
    args = ap.parse_args()
    if args.rows:
        return rows_vs_simulate(args)
    if args.model == "hyq":
        from proleg.papers.hyq_study import bushing_study

        study = bushing_study()
    else:
        study = pendulum_study()
    rows = []
    for ex in args.executors.split(","):
        store = Path(tempfile.mkdtemp(prefix=f"study-{ex}-"))
        t0 = time.perf_counter()
        if ex == "sequential":
            from proleg.analyses.simulate import simulate_kwargs
            from proleg.assembly.system import System

            table = study.design("lhs", args.n, seed=1)
            apply = study.apply or System.with_params
            ok = 0
            for r in table.to_dict("records"):
                res = pl.simulate(apply(study.target, {k: r[k] for k in study.space.dims}), progress=False, throw=False,
                                  **simulate_kwargs(study.simulate))
                ok += res.ok
        else:
            tab = study.run(design="lhs", n=args.n, seed=1, executor=ex, store=store, workers=None if ex == "vmap" else 2, progress=False,
                            lanes=args.lanes)
            ok = int((tab["status"] == "success").sum())
        wall = time.perf_counter() - t0
        shutil.rmtree(store, ignore_errors=True)
        rows.append({"executor": ex, "lanes": "-" if ex == "sequential" else (args.lanes or "batch"), "variants": args.n, "succeeded": ok, "wall [s]": wall, "variants/s": args.n / wall,
                     "load (1 min) at end": os.getloadavg()[0]})
        print(rows[-1], flush=True)
    df = pd.DataFrame(rows)
    df.attrs["machine"] = f"{platform.node()} {os.cpu_count()} cores"
    print(df.to_string(index=False))
    suffix = f"_lanes{args.lanes}" if args.lanes else ""
    out = Path(__file__).parent / "results" / f"study_throughput_{args.model}_{args.n}{suffix}.csv"
    df.to_csv(out, index=False)
    print(f"wrote {out} ({platform.processor() or platform.machine()}, {os.cpu_count()} cores)")


if __name__ == "__main__":
    main()
