"""Self-contained HTML report of a study store: output vs parameter scatter, parallel
coordinates, Pareto front of two outputs, Sobol' bars and the optimisation history."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd

from ..errors import DataError
from .store import Store


def _numeric(df, cols):
    return [c for c in cols if c in df.columns and pd.api.types.is_numeric_dtype(df[c])]


def scatter_figure(df, params, outputs):
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(len(outputs), len(params), figsize=(3.2 * len(params), 2.6 * len(outputs)), squeeze=False)
    ok = df["status"] == "success"
    for i, o in enumerate(outputs):
        for j, p in enumerate(params):
            ax = axes[i, j]
            ax.scatter(df.loc[ok, p], df.loc[ok, o], s=10, color="#1f5fa8")
            if (~ok).any():
                ax.scatter(df.loc[~ok, p], np.full((~ok).sum(), np.nanmin(df.loc[ok, o]) if ok.any() else 0.0), s=14, marker="x", color="#c0392b", label="failed")
            ax.set_xlabel(p)
            ax.set_ylabel(o)
            span = df[p].max() / max(df[p].min(), 1e-300) if (df[p] > 0).all() else 0
            if span > 1e3:
                ax.set_xscale("log")
    fig.tight_layout()
    return fig


def parallel_figure(df, params, outputs):
    import matplotlib.pyplot as plt

    cols = params + outputs
    ok = df[df["status"] == "success"]
    x = ok[cols].astype(float)
    z = (x - x.min()) / (x.max() - x.min()).replace(0, 1)
    color_by = ok[outputs[0]].astype(float)
    c = (color_by - color_by.min()) / max(color_by.max() - color_by.min(), 1e-300)
    fig, ax = plt.subplots(figsize=(1.6 * len(cols) + 2, 3.5))
    cmap = plt.get_cmap("viridis")
    for i in range(len(z)):
        ax.plot(range(len(cols)), z.iloc[i].to_numpy(), color=cmap(float(c.iloc[i])), alpha=0.5, lw=0.8)
    ax.set_xticks(range(len(cols)), [f"{k}\n[{x[k].min():.3g}, {x[k].max():.3g}]" for k in cols], fontsize=7)
    ax.set_yticks([])
    ax.set_title(f"colour: {outputs[0]}", fontsize=9)
    fig.tight_layout()
    return fig


def pareto_mask(y: np.ndarray) -> np.ndarray:
    """(n,) True for the points of (n, 2) ``y`` (both minimised) that no other point dominates."""
    n = len(y)
    keep = np.ones(n, bool)
    for i in range(n):
        dom = np.all(y <= y[i], axis=1) & np.any(y < y[i], axis=1)
        keep[i] = not dom.any()
    return keep


def pareto_figure(df, a, b):
    import matplotlib.pyplot as plt

    ok = df[df["status"] == "success"]
    y = ok[[a, b]].to_numpy(float)
    m = pareto_mask(y)
    fig, ax = plt.subplots(figsize=(4.5, 3.5))
    ax.scatter(y[:, 0], y[:, 1], s=10, color="#999999", label="variants")
    front = y[m][np.argsort(y[m][:, 0])]
    ax.plot(front[:, 0], front[:, 1], "o-", color="#c0392b", ms=4, label="Pareto front (both minimised)")
    ax.set_xlabel(a)
    ax.set_ylabel(b)
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


def sobol_figure(si):
    import matplotlib.pyplot as plt

    outs = list(dict.fromkeys(si["output"]))
    fig, axes = plt.subplots(1, len(outs), figsize=(4 * len(outs), 3), squeeze=False)
    for ax, o in zip(axes[0], outs):
        d = si[si["output"] == o]
        x = np.arange(len(d))
        ax.bar(x - 0.2, d["S1"], 0.4, yerr=d["S1_conf"], label="S1 (first order)")
        ax.bar(x + 0.2, d["ST"], 0.4, yerr=d["ST_conf"], label="ST (total)")
        ax.set_xticks(x, d["parameter"], fontsize=7)
        ax.set_title(o)
        ax.legend(fontsize=7)
    fig.tight_layout()
    return fig


def history_figure(trials):
    import matplotlib.pyplot as plt

    t = trials[trials["state"] == "COMPLETE"].sort_values("number")
    fig, ax = plt.subplots(figsize=(5, 3))
    ax.plot(t["number"], t["value"], ".", color="#999999", label="trial")
    ax.plot(t["number"], t["value"].cummin(), "-", color="#1f5fa8", label="best so far")
    ax.set_xlabel("trial")
    ax.set_ylabel("objective")
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


def study_report(store, path=None, *, pareto: tuple[str, str] | None = None) -> Path:
    """Write ``STORE/report.html`` (or ``path``) from the rows, Sobol' indices
    (``sobol.parquet``) and optuna trials (``optuna.db``) found in the store."""
    from ..report.html import Report

    st = Store(store)
    definition = st.definition()
    if definition is None:
        raise DataError(f"study report: '{store}' is not a study store (no study.json).")
    df = st.read()
    params = _numeric(df, list(definition["space"])) if len(df) else []
    params = [p for p in params if df[p].nunique() > 1]
    outputs = _numeric(df, list(definition["outputs"])) if len(df) else []
    status = st.status()
    tgt = definition["target"]
    rep = Report(f"Study: {tgt.get('model') or tgt.get('builder') or tgt.get('function')}", f"store {Path(store).resolve()}")
    rep.add_key_values({"variants stored": status["rows"], "succeeded": status["done"], "failed": status["failed"],
                        "pending": status["pending"], "duplicates": status["duplicates"]}, "Status")
    rep.add_table(pd.DataFrame([{"parameter": k, "kind": v[0], "values": json.dumps(v[1:])} for k, v in definition["space"].items()]), "Space")
    if definition["simulate"]:
        rep.add_key_values(definition["simulate"], "Simulation options")
    if len(df) and params and outputs:
        rep.add_figure(scatter_figure(df, params, outputs), "Each output against each parameter (red crosses: failed variants).")
        if len(params) + len(outputs) >= 2 and (df["status"] == "success").sum() > 1:
            rep.add_figure(parallel_figure(df, params, outputs), "Parallel coordinates of the successful variants (each axis scaled to its range).")
        pair = pareto or (tuple(outputs[:2]) if len(outputs) >= 2 else None)
        if pair:
            rep.add_figure(pareto_figure(df, *pair), f"Pareto front of {pair[0]} and {pair[1]} (both minimised).")
    sob = Path(store) / "sobol.parquet"
    if sob.exists():
        si = pd.read_parquet(sob)
        rep.add_figure(sobol_figure(si), "Sobol' indices (Saltelli design, SALib; bars: 95 % bootstrap intervals).")
        rep.add_table(si, "Sobol' indices", float_format="{:.3g}")
    db = Path(store) / "optuna.db"
    if db.exists():
        import optuna

        optuna.logging.set_verbosity(optuna.logging.WARNING)
        url = f"sqlite:///{db.resolve()}"
        for s in optuna.get_all_study_summaries(url):
            trials = optuna.load_study(study_name=s.study_name, storage=url).trials_dataframe()
            if "value" in trials.columns and len(trials):
                rep.add_figure(history_figure(trials), f"Optimisation history ({s.study_name}, {len(trials)} trials).")
    if len(df):
        fails = df[df["status"] != "success"]
        if len(fails):
            rep.add_table(fails[["key", *params, "status", "reason"]].head(50), "Failed variants (first 50)")
    return rep.save(path or Path(store) / "report.html")
