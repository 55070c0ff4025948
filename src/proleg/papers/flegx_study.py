"""FLEGX design study (seed 002 §IV, Table I) through :class:`proleg.study.Study`.

The variants (configurations No. 1-4 × link cases 1-6, PRBM link; CB link for one case) are
grouped by **compiled shape**: configurations No. 1-3 drive the knee directly and No. 4 through
the tendons (other bodies and joints), and the PRBM and CB links are different bodies. Within
a group every variant is the same System with other parameter values: the mass split, the
strip's geometry, the PRBM's γ, K_t, C_t and the standing pose's coordinates are all
parameters of the assembled System (checked: the constraint, force and mass functions of a
variant built from scratch and of the group's base System with the variant's parameters agree
to the last bit, ``tests/test_flegx.py``). So each group is one :class:`~proleg.study.Study`
of the group's base System over the space {configuration, link_case} whose ``apply`` looks the
variant's parameter arrays up in a table: one compilation per group (four in all), the variants
in ``vmap`` batches, rows stored as Parquet with resume (a rerun with the same store skips what
is done), rich progress.

:class:`proleg.study.Study` with a *builder* now groups rebuilt variants by their traced
simulation, so the variants of a group would share one compile that way too (checked: every
variant of a group has the same key, the planar rows being canonical). The table ``apply``
stays because it is cheaper and simpler here: a builder study traces every variant's
simulation to key it (seconds per variant, minutes more for Table I), and an output
function sees only the Result, whose System is the group base's, while
:func:`~proleg.papers.flegx_jump.jump_metrics` needs each variant's own model
(:meth:`_Variants.key_of` finds it from the body masses).

Simulated window: the jump of :func:`~proleg.papers.flegx_jump.flegx_jump` (same motion law
for every variant) up to ``STUDY_T_AFTER`` after the end of the push: take-off and apex (Table
I's "investigated movement was the take-off phase"); a variant whose apex falls on the last
output is flagged (``apex_in_window`` false).

The shared law (:func:`shared_push`). One law for all configurations is a controlled
comparison: only the hardware differs. Its push duration is not picked by hand: it is the
shortest push at which **every** configuration stays within the limits up to take-off (von
Mises ≤ 520 MPa at the clamp, hip and knee torque ≤ 77 N m, the worm wheel's rating; the
take-off inside the push: :func:`~proleg.papers.flegx_codesign.constraints`), found with the
PRBM link on Table I's strip, link case 2 (250 × 70 × 3 mm: seed 002 §IV, "The four mechanical
configurations were equipped with a 250 mm long, 70 mm wide and 3 mm thick flexible link. The
simulations were performed by requiring that the maximum value of the stresses in the lower
link was sufficiently lower than the ultimate tensile strength ..., namely between 510 and
530MPa"). Each configuration's shortest push within the limits comes from
:func:`~proleg.papers.flegx_codesign.push_at_limits` (a push grid, interpolated; ``rule="first"``:
the first feasible push, since a long push that takes off late can break a limit again); the
common law is the longest of them, so the configuration that sets it binds (its stress or
torque at its limit, to the interpolation's accuracy) and the others, which reach their limits
at shorter pushes, are checked within theirs at the shared push (interpolated on their grids:
``within_at_shared``; the study's rows then give their simulated peaks). The squat, the
extended pose and the other timings stay flegx_jump's documented ones (assumed: seed 002 prints
no angles or timings). The other link cases and the Craig-Bampton link run the same law and
may exceed 520 MPa: the table flags them (``> 510 MPa``); Table I reports case 2 only.
"""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np
import pandas as pd

from ..errors import ModelError
from ..robots import flegx_data as D
from ..robots.flegx import flegx
from .flegx_jump import MotionLaw, _add_motions, jump_metrics

__all__ = ["STUDY_T_AFTER", "SHARED_PUSHES", "SHARED_LAW_CASE", "SHARED_LAW_MODEL", "study_groups", "group_study", "run_table_i",
           "shared_push", "shared_law", "ranking"]

#: simulated time after the end of the push [s]: the apex of every variant falls inside it
#: (measured: the apex falls 0.03 s before to 0.05 s after the push end; the landing is not needed for Table I)
STUDY_T_AFTER = 0.2
#: the push grid [s] of the shared law's search (:func:`shared_push`; flegx-jump's grid): the
#: constraints' slack is interpolated between its points, then refined in the binding bracket
SHARED_PUSHES = (0.16, 0.20, 0.25, 0.30, 0.38, 0.45)
#: the refinement: this many pushes inside the bracket that holds the shared push
SHARED_REFINE = 4
#: the strip and link model the shared law is found on (module docstring): Table I's case 2, PRBM
SHARED_LAW_CASE, SHARED_LAW_MODEL = 2, "prbm"
#: the metrics kept as study outputs (flegx_jump docstring)
OUTPUTS = ("jump_height", "flight_rise", "foot_clearance", "take_off_time", "apex_time", "max_stress_takeoff",
           "max_stress", "tip_displacement", "total_mass", "peak_hip_torque", "peak_knee_torque", "peak_hip_torque_takeoff",
           "peak_knee_torque_takeoff")


def study_groups(configurations=(1, 2, 3, 4), cases=(1, 2, 3, 4, 5, 6), cb_case: int | None = 2) -> list[dict]:
    """The compiled-shape groups: (link model, knee drive) with their configurations and cases."""
    direct = [c for c in configurations if D.UPPER_LEG[c]["knee_drive"] == "direct"]
    tendon = [c for c in configurations if D.UPPER_LEG[c]["knee_drive"] == "tendon"]
    groups = []
    for lm, cs in (("cb", [cb_case] if cb_case else []), ("prbm", list(cases))):
        for drive, confs in (("direct", direct), ("tendon", tendon)):
            if confs and cs:
                groups.append(dict(name=f"{lm}-{drive}", link_model=lm, configurations=tuple(confs), cases=tuple(cs)))
    return groups


class _Variants:
    """The models and assembled Systems of one group, and the table of their differing parameters."""

    def __init__(self, group: dict, law: MotionLaw):
        import proleg as pl

        self.group, self.law = group, law
        self.keys = [(c, k) for c in group["configurations"] for k in group["cases"]]
        self.models, self.systems = {}, {}
        for c, k in self.keys:
            m = flegx(c, k, group["link_model"], stand=law.stand, name=f"flegx_{group['name']}")
            _add_motions(m, law)
            with warnings.catch_warnings():
                warnings.filterwarnings("ignore", message=".*redundant constraint.*")
                self.systems[c, k] = pl.assemble(m)
            self.models[c, k] = m
        self.base = self.systems[self.keys[0]]
        names = [n for n in sorted(self.base.params)
                 if any(not np.array_equal(np.asarray(s.params[n]), np.asarray(self.base.params[n])) for s in self.systems.values())]
        self.table = {n: np.stack([np.asarray(self.systems[key].params[n]) for key in self.keys]) for n in names}
        self.mass = np.stack([np.asarray(self.systems[key].params["body_mass"]) for key in self.keys])

    def apply(self, system, vals):
        """Traceable: the variant's parameter arrays, looked up by (configuration, link_case)."""
        import jax.numpy as jnp

        confs, cases = self.group["configurations"], self.group["cases"]
        ci = jnp.argmin(jnp.abs(jnp.asarray(confs, float) - vals["configuration"]))
        ki = jnp.argmin(jnp.abs(jnp.asarray(cases, float) - vals["link_case"]))
        i = ci * len(cases) + ki
        return system.with_params(**{n: jnp.take(jnp.asarray(v), i, axis=0) for n, v in self.table.items()})

    def key_of(self, result) -> tuple[int, int]:
        """(configuration, link_case) of a variant's Result (by its body masses, unique per variant)."""
        m = np.asarray(result.system.params["body_mass"])
        return self.keys[int(np.argmin(np.abs(self.mass - m).sum(axis=1)))]


def group_study(group: dict, law: MotionLaw | None = None, dt_output: float = 2e-3, rtol: float = 1e-5, atol: float = 1e-6):
    """A :class:`proleg.study.Study` of one group (module docstring) and its design table."""
    from ..study import Study

    law = law or MotionLaw(t_after=STUDY_T_AFTER)
    var = _Variants(group, law)
    cache = {}

    def metrics(r):
        if cache.get("r") is not r:
            m, _ = jump_metrics(r, var.models[var.key_of(r)], law)
            m["apex_in_window"] = float(m["apex_time"] < r.t[-1] - 1.5 * dt_output) if m["flights"] else 1.0
            cache.update(r=r, m=m)
        return cache["m"]

    outputs = {k: (lambda r, k=k: metrics(r)[k]) for k in (*OUTPUTS, "apex_in_window")}
    study = Study(var.base, {"configuration": list(group["configurations"]), "link_case": list(group["cases"])}, outputs,
                  simulate=dict(t_end=law.t_end, dt_output=dt_output, rtol=rtol, atol=atol, dt_max=dt_output), apply=var.apply,
                  name=f"flegx {group['name']}")
    design = pd.DataFrame(var.keys, columns=["configuration", "link_case"]).astype(float)
    return study, design


#: seconds per variant of each group, measured on the loaded 2-core machine (load ≈ 10), for the order
COST_S = {("cb", "direct"): 45.0, ("cb", "tendon"): 150.0, ("prbm", "direct"): 6.5, ("prbm", "tendon"): 12.0}


def _cost(group) -> float:
    """Estimated wall time of a group [s]: variants × COST_S + 30 s of compilation."""
    drive = group["name"].split("-")[1]
    return 30.0 + COST_S[group["link_model"], drive] * len(group["configurations"]) * len(group["cases"])


def _run_group(group: dict, store_dir: str, executor: str, progress: bool, law) -> pd.DataFrame:
    """One group's Study (module-level: worker processes run it)."""
    import time

    t0 = time.perf_counter()
    study, design = group_study(group, law)
    rows = study.evaluate(design, executor=executor, store=Path(store_dir) / group["name"], progress=progress,
                          workers=1 if executor == "vmap" else None, label=f"flegx {group['name']}")
    rows.insert(0, "link model", group["link_model"])
    rows["group wall [s]"] = time.perf_counter() - t0
    return rows


def run_table_i(store_dir, configurations=(1, 2, 3, 4), cases=(1, 2, 3, 4, 5, 6), cb_case: int | None = 2,
                progress: bool = True, executor: str = "vmap", law: MotionLaw | None = None, workers: int | None = None) -> pd.DataFrame:
    """Every group's Study, stored under ``store_dir/<group>``; one row per variant with
    ``link model``, the metrics (SI), ``> 510 MPa`` (stress up to take-off) and the batch's
    wall time per variant (compilation included).

    ``law``: the one law every variant runs; default flegx_jump's documented law (push 0.30 s,
    an assumed value) up to :data:`STUDY_T_AFTER` after the push. ``proleg run flegx-study``
    passes the law found by :func:`shared_push` (:func:`shared_law`), not the default.

    The groups run in ``workers`` processes at once (default: the cores this process may use),
    longest first (CB before PRBM), each group's variants in one ``vmap`` batch: on 2 cores the
    single long CB run of No. 4 takes one core while the other groups share the other.
    """
    import concurrent.futures as cf
    import multiprocessing as mp

    groups = study_groups(configurations, cases, cb_case)
    workers = workers or default_workers(len(groups))
    groups.sort(key=lambda g: -_cost(g))
    frames = {}
    bar = _bar(progress, sum(len(g["configurations"]) * len(g["cases"]) for g in groups))
    try:
        if workers == 1:
            for g in groups:
                frames[g["name"]] = _run_group(g, str(store_dir), executor, False, law)
                if bar:
                    bar.advance(g)
        else:
            with cf.ProcessPoolExecutor(workers, mp_context=mp.get_context("spawn")) as ex:
                futs = {ex.submit(_run_group, g, str(store_dir), executor, False, law): g for g in groups}
                for f in cf.as_completed(futs):
                    frames[futs[f]["name"]] = f.result()
                    if bar:
                        bar.advance(futs[f])
    finally:
        if bar:
            bar.stop()
    tab = pd.concat([frames[g["name"]] for g in groups], ignore_index=True)
    tab[["configuration", "link_case"]] = tab[["configuration", "link_case"]].astype(int)
    tab["> 510 MPa"] = tab["max_stress_takeoff"] > D.ULTIMATE_STRENGTH[0]
    bad = tab[tab["status"] != "success"]
    if len(bad):
        warnings.warn(f"flegx study: {len(bad)} variants failed: " + "; ".join(f"No. {r.configuration} case {r.link_case}: {r.reason}"
                                                                          for r in bad.itertuples()), stacklevel=2)
    return tab.sort_values(["link model", "configuration", "link_case"], ignore_index=True)


def default_workers(n_jobs: int) -> int:
    """Processes for ``n_jobs`` independent FLEGX runs: no more than the jobs, nor than the cores
    this process may use (its affinity mask; the CPU count where the OS has none)."""
    import os

    try:
        cores = len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        cores = os.cpu_count() or 1
    return max(1, min(n_jobs, cores))


def _push_job(kw: dict) -> dict:
    """One configuration's :func:`~proleg.papers.flegx_codesign.push_at_limits` (module-level:
    worker processes run it)."""
    from . import flegx_codesign as FC

    return FC.push_at_limits(**kw)


def _map(fn, jobs: list[dict], workers: int) -> list:
    import concurrent.futures as cf
    import multiprocessing as mp

    if workers == 1 or len(jobs) <= 1:
        return [fn(j) for j in jobs]
    with cf.ProcessPoolExecutor(min(workers, len(jobs)), mp_context=mp.get_context("spawn")) as ex:
        return list(ex.map(fn, jobs))


def shared_push(configurations=(1, 2, 3, 4), link_case: int = SHARED_LAW_CASE, link_model: str = SHARED_LAW_MODEL, *,
                pushes=SHARED_PUSHES, refine: int = SHARED_REFINE, store=None, workers: int | None = None) -> dict:
    """The shared law's push duration (module docstring): the shortest push [s] at which every
    configuration keeps within :func:`~proleg.papers.flegx_codesign.constraints` up to take-off.

    Each configuration's shortest push within the limits is found by
    :func:`~proleg.papers.flegx_codesign.push_at_limits` (``rule="first"``) on the grid
    ``pushes`` [s]; the longest of them is the shared push. Then the configurations whose push
    lies in the grid's bracket around the shared push (a < t ≤ b) are searched again with
    ``refine`` more pushes inside it (the grid's own rows replay from ``store``), so the binding
    limit is interpolated over ``(b - a) / (refine + 1)``, not over the grid's step. ``store``:
    a folder, one study store per configuration under it (a rerun replays them); ``workers``:
    processes (default the cores this process may use).

    Returns a dict: ``t_push_s``, ``binding_configuration``, ``binding`` (its binding
    constraint), ``stress_MPa``, ``peak_hip_Nm``, ``peak_knee_Nm`` (the binding
    configuration's, interpolated at the push), ``within_all`` (every configuration within the
    limits at the shared push, interpolated on its grid), and ``per_configuration``: a
    DataFrame, one row per configuration: its own shortest push at the limits (``t_push_s``),
    binding constraint, peaks and heights there (push_at_limits' row, ``feasible_after``:
    whether every longer push of its grid is feasible), and at the shared push, interpolated
    on its grid: ``stress_shared_MPa``, ``hip_shared_Nm``, ``knee_shared_Nm``,
    ``height_shared_mm``, ``jump_shared_mm``, ``within_at_shared``.

    Raises
    ------
    ModelError
        a configuration breaks a limit at every push of the grid (lengthen ``pushes``).
    """
    from .flegx_codesign import OBJECTIVE, _feasible_grid, constraints

    configurations = tuple(configurations)
    workers = workers or default_workers(len(configurations))
    grid = tuple(sorted(float(t) for t in pushes))

    def job(c, ts):
        return dict(configuration=c, link_case=link_case, link_model=link_model, pushes=ts, rule="first",
                    store=None if store is None else Path(store) / f"no{c}_case{link_case}_{link_model}")

    found = dict(zip(configurations, _map(_push_job, [job(c, grid) for c in configurations], workers), strict=True))
    bad = {c: r["binding"] for c, r in found.items() if "t_push_s" not in r}
    if bad:
        raise ModelError("flegx shared law: no push of " + f"{grid} s keeps " + "; ".join(f"No. {c} within the limits ({b})" for c, b in bad.items())
                         + ". Lengthen the pushes (SHARED_PUSHES).")
    t_max = max(r["t_push_s"] for r in found.values())
    if refine and t_max > grid[0]:
        k = int(np.searchsorted(grid, t_max))  # grid[k - 1] < t_max <= grid[k]
        a, b = grid[k - 1], grid[k]
        fine = tuple(sorted({*grid, *np.linspace(a, b, int(refine) + 2)[1:-1].round(6).tolist()}))
        again = [c for c, r in found.items() if r["t_push_s"] > a]
        found.update(zip(again, _map(_push_job, [job(c, fine) for c in again], workers), strict=True))
    t_sh = max(r["t_push_s"] for r in found.values())
    cons = constraints()
    s_c, h_c, k_c = list(cons)[:3]
    rows = []
    for c, r in found.items():
        g = r["grid"]
        tp = g["law_t_push"].to_numpy(float)
        at = {x: float(np.interp(t_sh, tp, g[x].to_numpy(float))) for x in (*cons, OBJECTIVE, "jump_height")}
        row = {k: v for k, v in r.items() if not isinstance(v, (pd.DataFrame, dict, list))}
        row.update(grid_rows=len(g), stress_shared_MPa=at[s_c] / 1e6, hip_shared_Nm=at[h_c], knee_shared_Nm=at[k_c],
                   height_shared_mm=1e3 * at[OBJECTIVE], jump_shared_mm=1e3 * at["jump_height"],
                   within_at_shared=bool(_feasible_grid(pd.DataFrame([at]), cons)[0]))
        rows.append(row)
    per = pd.DataFrame(rows)
    top = per.iloc[int(per["t_push_s"].to_numpy(float).argmax())]
    return {"t_push_s": float(top["t_push_s"]), "binding_configuration": int(top["configuration"]), "binding": str(top["binding"]),
            "stress_MPa": float(top["stress_MPa"]), "peak_hip_Nm": float(top["peak_hip_Nm"]), "peak_knee_Nm": float(top["peak_knee_Nm"]),
            "within_all": bool(per["within_at_shared"].all()), "link_case": link_case, "link_model": link_model, "per_configuration": per}


def shared_law(shared: dict) -> MotionLaw:
    """The study's law with the push of :func:`shared_push` (the rest: flegx_jump's documented law)."""
    return MotionLaw(t_push=float(shared["t_push_s"]), t_after=STUDY_T_AFTER)


def _bar(show: bool, total: int):
    return _Bar(total) if show else None


class _Bar:
    """rich progress over the variants of all groups, advanced as each group's Study returns."""

    def __init__(self, total):
        from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

        self.p = Progress(TextColumn("[bold]flegx-study[/] {task.fields[last]}"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn())
        self.task = self.p.add_task("study", total=total, last="")
        self.p.start()

    def advance(self, group):
        n = len(group["configurations"]) * len(group["cases"])
        self.p.update(self.task, advance=n, last=f"{group['name']} done")

    def stop(self):
        self.p.stop()


def ranking(values: dict) -> list[int]:
    """Configurations sorted by decreasing jump height ({configuration: height})."""
    return [c for c, _ in sorted(values.items(), key=lambda kv: -kv[1] if math.isfinite(kv[1]) else math.inf)]
