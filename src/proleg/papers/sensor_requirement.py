"""The HyQ torque sensor designed to its requirement by the optimiser (issue 30 item 4).

Requirement (seed 001 Problem 2, "Numerical Model and Analysis"; MODEL_DATA §2), at the peak
torque T = 140 N m:

- twist about 1 deg ("the maximum dynamic torque transmitted by the motor was around 140 Nm and
  the related angle is around 1 deg": the admissible stiffness k = torque/deg of the control
  loop); the accepted range is 0.2-3 deg (issue 30's target), i.e. 47-700 N m/deg;
- gauge strain <= 0.06 % ("this value, lower than 0.06 %, ... within the linearity that is
  0.15 %") and >= 0.02 % (:data:`REQUIREMENT` ``min_gauge_strain``: a gauge must read something;
  the measurable floor of :func:`proleg.robots.torque_sensor_analysis`, an assumed value);
- no yield: safety factor yield / max von Mises >= 1 (Ergal 7075-T6, 500 MPa).

Why the spoke concept, with the gauge off the strain peak. A part whose largest strain is at
the gauge (seed 001's rule, "concentrate the maximum strain ... where the sensors will be
positioned") stores at most E ε²/2 = 12.9 kJ/m³ at ε = 0.06 %; 1 deg at 140 N m stores
T θ / 2 = 1.22 J, which needs ~95 cm³ of uniformly strained material: more than the whole
assumed envelope (75 cm³). Even 0.2 deg needs ~19 cm³ of links in uniform tension. The tension
links of the paper's last shape (concept ``open_links``, Fig. 13b) therefore twist 0.06 deg (2,309 N m/deg). The strain
energy must sit in material strained towards yield (ε_y = 0.7 %, 54x the energy density), and
the gauge where the strain is ~1/10 of that. A spoke in bending has exactly that: its moment
runs linearly from the hub root (peak) through zero (the inflection) to the ring, and the
gauge's position along the spoke (``gauge_position``) sets its fraction of the peak. The Pareto
front in the report (:func:`pareto_front`) shows the stiffness reachable with the gauge at the
peak: far above 700 N m/deg at 0.06 %.

Problem: minimise |ln(twist / 1 deg)| (the "about 1 deg" as the objective) over
:data:`SPOKE_SPACE` subject to gauge strain 0.02-0.06 %, safety factor >= 1 and the accepted
range (twist >= 0.2 deg, stiffness >= T / 3 deg). The target counts as met within
``twist_tolerance`` (10 %, an assumed reading of "around": 0.91-1.1 deg). Where 1 deg is
reachable with slack everywhere the optimum is not unique (``binding`` is then empty); where it
is not, the optimum is as close to 1 deg as the binding constraint allows. (A first formulation,
maximise the safety factor with the twist held in 0.91-1.1 deg, found no feasible design: the
CMA-ES's feasibility-first penalty caps a variant's summed violation at 1, so it gives no
direction while every variant is far from feasible.) The search starts from the best of
``n_start`` random designs of the closed-form model (:func:`start_design`), with a first step of
0.1 of the box. It runs with
proleg's CMA-ES (``Study.optimize(sampler="cma")``, feasibility-first penalty), each trial an FE
solve (``model="fe"``: P2 tetrahedra, fillets resolved, case A, no stress stiffening) or the
closed form of :mod:`proleg.robots.sensor_beam` (``model="beam"``: the reduced problem of the
fast tests, and the start of the FE search). The optimum is re-analysed on a 3 mm mesh
(:data:`REANALYSIS_MESH`), both load cases and directions, stress stiffening, gauge-face checks. ``n_spokes`` = 8 is fixed
(the validation cap of the concept; the beam model's stress at a given twist does not depend on
n, more spokes only let each be thinner), the fillet (end mill) 1 mm, r_out 38 mm (the default,
2 mm inside the envelope).

Envelope. Seed 001 prints no sensor dimension; it says only that the sensor sits between the
harmonic drive and the motor shaft of a HyQ joint. :data:`proleg.robots.torque_sensor.ENVELOPE`
(r_out <= 40 mm, thickness <= 15 mm, bore >= 6 mm) is assumed: the output flange of a size-25
harmonic drive (~85 mm). It is a parameter (``envelope=``). The FE optimum of the run at ed7a158
(docs/papers/tables/torque-sensor-study/requirement_trials.csv, first row: 0.91 deg, gauge
0.046 %, SF 1.02 on the 5 mm search mesh) has the safety factor and the ring radius (r_ring at its
35 mm bound, a 3 mm ring inside r_out = 38 mm) binding and the thickness at 14.65 of 15 mm: the
envelope is what keeps it from 1 deg.

Mesh (issue 44). The 5 mm search mesh puts about one element across ~3 mm spokes, and the peak
stress at their 1 mm root fillets comes out ~10 % low: that optimum's max von Mises is 495 MPa at
5 mm but 536 MPa at 4 mm and 559 MPa at 3 mm with 0.25 mm fillet elements (SF 0.89: it yields;
bench/results/torque_sensor_convergence_final_study_best.csv). Its SF 1.02 was the mesh's. The
search keeps its 5 mm mesh (40 trials at 3 mm would take hours on the 2-core machine); its
optimum is re-analysed at 3 mm, and the report says whether that meets the requirement.

The library's ``final`` concept (issue 44). That optimum is recorded as
:data:`proleg.robots.torque_sensor.FINAL_STUDY`; the defaults of
``torque_sensor_analysis(concept="final")`` are its dimensions (:func:`spoke_dimensions`) with two
changes (:data:`proleg.robots.torque_sensor.FINAL_CHANGES`): the roots milled with a 2 mm end mill
instead of 1 mm, and the spokes 2.87 mm wide instead of 2.94 mm to bring the twist back up. At its
default 3 mm mesh (the coarsest its convergence accepts) it twists 0.87 deg at 140 N m, with gauge
strain 0.037 % and SF 1.07: the library's default sensor is a design that meets seed 001's
requirements, not the 16x stiffer tension-link shape. The report says whether a new run's
optimum is still the recorded one.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from ..errors import ModelError

REQUIREMENT = dict(torque=140.0, twist_target=1.0, twist_tolerance=0.1, twist_min=0.2, twist_max=3.0,
                   max_gauge_strain=6e-4, min_gauge_strain=2e-4, safety=1.0)  # [N m], [deg], [-], [deg] x2, [-] x3
SPOKE_SPACE = dict(spoke_width=(0.0025, 0.006), r_hub=(0.010, 0.016), r_ring=(0.026, 0.035),
                   thickness=(0.006, 0.015), gauge_offset=(0.0, 0.25))  # [m] x4, [-]
# gauge_offset f: the gauge grid's centre at r = r_hub + x0 (1 - f), x0 the spoke's inflection (zero
# moment) in beam theory (:mod:`proleg.robots.sensor_beam`): f = 0 at the inflection, 1 at the hub root;
# beam theory puts the gauge strain at ~f times the peak. (The spoke's own gauge_position, 0..1 along
# its free face, makes the feasible strip ~0.04 wide; CMA-ES lost it.)
SPOKE_FIXED = dict(n_spokes=8, r_bore=0.007, r_out=0.038, fillet=0.001)
OUTPUTS = ("twist", "stiffness", "gauge_strain", "signal", "safety_factor", "max_von_mises", "twist_error")
# twist_error = |ln(twist / twist_target)|: the "about 1 deg" as one constraint, twist_error <= ln(1 + twist_tolerance)
YIELD = 500e6  # [Pa] Ergal 7075-T6 (MODEL_DATA §2; the FE reads it from proleg.fem.material)
# [m] the optimum's re-analysis: the final concept's default mesh (its convergence, torque_sensor.DEFAULT_MESH);
# at the 5 mm search mesh the root stress of ~3 mm spokes is ~10 % low (the study's optimum: SF 1.02 there, 0.89 here)
REANALYSIS_MESH = 0.003


def _check(req):
    unknown = set(req) - set(REQUIREMENT)
    if unknown:
        raise ModelError(f"sensor requirement: unknown key(s) {sorted(unknown)}; valid: {sorted(REQUIREMENT)}.")
    r = {**REQUIREMENT, **req}
    for k, v in r.items():
        if not (isinstance(v, int | float) and math.isfinite(v) and v > 0):
            raise ModelError(f"sensor requirement {k} = {v!r} must be a positive number.")
    if not r["twist_min"] < r["twist_target"] < r["twist_max"]:
        raise ModelError(f"sensor requirement: need twist_min < twist_target < twist_max [deg]; got "
                         f"{r['twist_min']}, {r['twist_target']}, {r['twist_max']}.")
    if not r["min_gauge_strain"] < r["max_gauge_strain"]:
        raise ModelError("sensor requirement: min_gauge_strain must be below max_gauge_strain.")
    return r


def gauge_position(dims: dict, gauge_offset: float) -> float:
    """The spoke concept's ``gauge_position`` (0..1 along the free face) for a gauge at ``gauge_offset``
    (see :data:`SPOKE_SPACE`), clipped to the face."""
    from ..robots.sensor_beam import spoke_beam, spoke_gauge_x

    x0 = spoke_beam(1.0, **{**dims, "gauge_position": 0.0})["inflection"]
    lo, hi = spoke_gauge_x({**dims, "gauge_position": 0.0}), spoke_gauge_x({**dims, "gauge_position": 1.0})
    return float(np.clip((dims["r_hub"] + x0 * (1.0 - gauge_offset) - lo) / (hi - lo), 0.0, 1.0))


def spoke_sensor(spoke_width, r_hub, r_ring, thickness, gauge_offset, *, n_spokes, r_bore, r_out, fillet,
                 torque, twist_target, min_gauge_strain, model, search_mesh) -> dict:
    """One design of the search: twist [deg], stiffness [N m/deg], gauge_strain [-], signal
    (gauge strain / min_gauge_strain), safety_factor, max_von_mises [Pa], twist_error
    |ln(twist / twist_target)|. ``model``: "fe" or "beam". Invalid geometry raises ModelError."""
    dims = dict(spoke_width=spoke_width, r_hub=r_hub, r_ring=r_ring, thickness=thickness,
                n_spokes=int(n_spokes), r_bore=r_bore, r_out=r_out, fillet=fillet)
    dims["gauge_position"] = gauge_position(dims, gauge_offset)
    if model == "beam":
        from ..robots.sensor_beam import spoke_beam
        from ..robots.torque_sensor import sensor_design

        sensor_design("spokes", search_mesh, **dims)  # the same validity as the FE search
        m = spoke_beam(torque, **dims)
        m["max_von_mises"] = m.pop("max_stress")
        m["safety_factor"] = YIELD / m["max_von_mises"]
    elif model == "fe":
        from ..robots.sensor_fe import torque_sensor_analysis

        m = torque_sensor_analysis("spokes", torque=torque, mesh_size=search_mesh, stress_stiffening=False,
                                   cases=("A",), geometry_checks=False, **dims).metrics
    else:
        raise ModelError(f"spoke_sensor model = {model!r}; use 'fe' or 'beam'.")
    out = {k: float(m[k]) for k in ("twist", "stiffness", "gauge_strain", "safety_factor", "max_von_mises")}
    out["signal"] = out["gauge_strain"] / min_gauge_strain
    out["twist_error"] = abs(math.log(out["twist"] / twist_target))
    return out


def constraints_of(req: dict) -> dict:
    """{output: (op, bound)}: the requirement as ``Study.optimize`` constraints."""
    return {"gauge_strain": ("<=", req["max_gauge_strain"]), "signal": (">=", 1.0),
            "safety_factor": (">=", req["safety"]), "twist": (">=", req["twist_min"]),
            "stiffness": (">=", req["torque"] / req["twist_max"])}


@dataclass
class RequirementOptimum:
    """``best`` (the optimum's row: parameters and outputs), ``target_met`` (twist within
    ``twist_tolerance`` of the target: "about 1 deg"), ``binding`` (constraints within
    ``active_tol`` of their bound, and parameters at a bound of :data:`SPOKE_SPACE`), ``slack``
    {constraint: scaled slack, >= 0 feasible}, ``feasible``, ``trials`` (the optimiser's table),
    ``rows`` (every evaluated design) and the ``requirement``."""

    best: dict
    binding: list
    slack: dict
    feasible: bool
    trials: pd.DataFrame
    rows: pd.DataFrame
    requirement: dict
    model: str

    @property
    def target_met(self) -> bool:
        return bool(self.best["twist_error"] <= math.log(1.0 + self.requirement["twist_tolerance"]))

    @property
    def dimensions(self) -> dict:
        """The optimum's dimensions for ``torque_sensor_analysis("spokes", ...)`` [m]."""
        return spoke_dimensions(self.best)


def spoke_dimensions(params: dict) -> dict:
    """The dimensions [m] for ``torque_sensor_analysis("spokes" | "final", ...)`` of a design of the
    search (the keys of :data:`SPOKE_SPACE`, gauge_offset converted to gauge_position; the fixed ones
    from :data:`SPOKE_FIXED`)."""
    d = {**{k: float(params[k]) for k in SPOKE_SPACE}, **SPOKE_FIXED}
    d["gauge_position"] = gauge_position(d, d.pop("gauge_offset"))
    return d


def optimize_to_requirement(store=None, n_trials: int = 48, *, model: str = "fe", batch: int = 8, workers: int = 2,
                            seed: int = 0, search_mesh: float = 0.005, active_tol: float = 0.02, start=None,
                            requirement: dict | None = None, sigma0: float = 0.1, n_start: int = 2000
                            ) -> RequirementOptimum:
    """Maximise the safety factor at twist about 1 deg under the requirement (module docstring) with CMA-ES.

    Parameters
    ----------
    store : folder or None      the study's Parquet store (restart-safe: stored designs are not solved again)
    n_trials : int              evaluations (generations of ``batch``)
    model : "fe" | "beam"       FE solve per trial, or the closed form (:mod:`proleg.robots.sensor_beam`)
    batch : int                 CMA-ES population (one executor batch)
    workers : int               FE solves in parallel ("processes" executor; the beam runs "local")
    search_mesh : [m]           element size of the search (5 mm: spokes down to 2.5 mm wide)
    active_tol : [-]            a constraint whose scaled slack is within this is reported binding
    start : dict or None        the CMA-ES mean's first design (e.g. the beam optimum), else :func:`start_design`
    requirement : dict          overrides of :data:`REQUIREMENT`
    sigma0 : [-]                CMA-ES's first step in the mapped box (0.1: a local search from ``start``)
    n_start : int               random closed-form designs for :func:`start_design` when ``start`` is None
    """
    from ..study import Study
    from ..study.codesign import slack

    req = _check(requirement or {})
    if model not in ("fe", "beam"):
        raise ModelError(f"optimize_to_requirement model = {model!r}; use 'fe' or 'beam'.")
    if not (isinstance(n_trials, int) and n_trials >= batch >= 2):
        raise ModelError(f"optimize_to_requirement n_trials = {n_trials!r} must be an integer >= batch = {batch!r} >= 2.")
    fixed = {**SPOKE_FIXED, "torque": req["torque"], "twist_target": req["twist_target"],
             "min_gauge_strain": req["min_gauge_strain"], "model": model, "search_mesh": float(search_mesh)}
    study = Study.function(spoke_sensor, {**SPOKE_SPACE, **fixed}, list(OUTPUTS), name=f"torque-sensor-spokes-{model}")
    cons = constraints_of(req)
    ex = dict(executor="processes", workers=workers) if model == "fe" and workers > 1 else dict(executor="local")
    if start is None:
        start = start_design(n_start, requirement=req, seed=seed)
    opt = study.optimize("twist_error", cons, n_trials, sampler="cma", direction="minimize", seed=seed, batch=batch,
                         store=store, enqueue=[start], progress=False, sigma0=sigma0, **ex)
    all_rows, trials = [opt.rows], [opt.trials]
    rows = pd.concat(all_rows, ignore_index=True)
    ok = rows[rows.status == "success"]
    if not len(ok) or not opt.best_params:
        raise ModelError("optimize_to_requirement: no trial gave a valid design; check SPOKE_SPACE and the requirement.")
    key = ok[np.all([np.isclose(ok[k], opt.best_params[k]) for k in SPOKE_SPACE], axis=0)].index[0]
    best = ok.loc[key].to_dict()
    sl = {c: slack(op, b, float(best[c])) for c, (op, b) in cons.items()}
    binding = [c for c, s in sl.items() if abs(s) <= active_tol]
    for k, (lo, hi) in SPOKE_SPACE.items():
        u = (best[k] - lo) / (hi - lo)
        if u <= 0.01 or u >= 0.99:
            binding.append(f"{k} = {'lo' if u <= 0.01 else 'hi'}")
    return RequirementOptimum(best, binding, sl, all(s >= 0 for s in sl.values()), pd.concat(trials, ignore_index=True),
                              rows, req, model)


def start_design(n: int = 2000, *, requirement: dict | None = None, seed: int = 0) -> dict:
    """The best of ``n`` random designs of :data:`SPOKE_SPACE` in the closed-form model: the feasible
    one of largest safety factor, else the one of least summed scaled violation."""
    from ..study.codesign import slack

    req = _check(requirement or {})
    cons = constraints_of(req)
    rng = np.random.default_rng(seed)
    fixed = {**SPOKE_FIXED, "torque": req["torque"], "twist_target": req["twist_target"],
             "min_gauge_strain": req["min_gauge_strain"], "model": "beam", "search_mesh": 0.005}
    best, key = None, (math.inf, 0.0)
    for _ in range(n):
        p = {k: float(rng.uniform(lo, hi)) for k, (lo, hi) in SPOKE_SPACE.items()}
        try:
            m = spoke_sensor(**p, **fixed)
        except ModelError:
            continue
        viol = sum(max(0.0, -slack(op, b, m[c])) for c, (op, b) in cons.items())
        k = (viol, -m["safety_factor"])
        if k < key:
            best, key = p, k
    if best is None:
        raise ModelError(f"start_design: none of {n} random designs of SPOKE_SPACE is a valid geometry.")
    return best


def pareto_front(n: int = 4000, *, gauge_at: float = 0.0, seed: int = 0, requirement: dict | None = None):
    """Stiffness against gauge strain of the spoke concept, closed form (:mod:`proleg.robots.sensor_beam`):
    ``n`` random designs of :data:`SPOKE_SPACE` with the gauge at ``gauge_position = gauge_at`` (0: at the strain
    peak, seed 001's rule) and safety factor >= the requirement's; returns (samples, front), the front
    the designs no other is below in both stiffness and gauge strain (the most compliant sensor for a
    given strain at the gauge), sorted by gauge strain."""
    from ..robots.sensor_beam import spoke_beam
    from ..robots.torque_sensor import sensor_design

    req = _check(requirement or {})
    rng = np.random.default_rng(seed)
    rows = []
    for _ in range(n):
        p = {k: float(rng.uniform(lo, hi)) for k, (lo, hi) in SPOKE_SPACE.items() if k != "gauge_offset"}
        p["gauge_position"] = gauge_at
        d = {**p, **SPOKE_FIXED}
        try:
            sensor_design("spokes", 0.005, **d)
        except ModelError:
            continue
        m = spoke_beam(req["torque"], **d)
        rows.append({**p, "stiffness": m["stiffness"], "gauge_strain": m["gauge_strain"],
                     "safety_factor": YIELD / m["max_stress"]})
    df = pd.DataFrame(rows)
    ok = df[df.safety_factor >= req["safety"]].sort_values("gauge_strain")
    front = ok[ok.stiffness < ok.stiffness.cummin().shift(fill_value=np.inf)]
    return df, front.reset_index(drop=True)


def run_requirement(out, *, n_trials: int = 40, workers: int = 1, batch: int = 8) -> dict:
    """The full study: the beam optimum (200 closed-form CMA-ES trials from :func:`start_design`) starts
    the FE CMA-ES (``n_trials``
    FE solves, store ``out/requirement``), whose optimum is re-analysed on :data:`REANALYSIS_MESH`.
    Writes requirement_trials.parquet, requirement_pareto.parquet; returns the pieces for the report."""
    from ..robots.sensor_fe import torque_sensor_analysis

    t0 = time.perf_counter()
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    beam = optimize_to_requirement(n_trials=200, model="beam", batch=batch)
    fe = optimize_to_requirement(out / "requirement", n_trials=n_trials, model="fe", batch=batch, workers=workers,
                                 start={k: beam.best[k] for k in SPOKE_SPACE})
    final = torque_sensor_analysis("spokes", torque=fe.requirement["torque"], mesh_size=REANALYSIS_MESH,
                                   **fe.dimensions)
    samples, front = pareto_front()
    fe.rows.to_parquet(out / "requirement_trials.parquet")
    front.to_parquet(out / "requirement_pareto.parquet")
    return dict(beam=beam, fe=fe, final=final, samples=samples, front=front, wall_s=time.perf_counter() - t0)


def _pareto_figure(res):
    import matplotlib.pyplot as plt

    req, fe, s, f = res["fe"].requirement, res["fe"], res["samples"], res["front"]
    fig, ax = plt.subplots(figsize=(7, 4.2))
    ok = s.safety_factor >= req["safety"]
    ax.scatter(s.gauge_strain[ok] * 100, s.stiffness[ok], s=3, c="0.75", label="closed form, gauge at the peak, SF >= 1")
    ax.plot(f.gauge_strain * 100, f.stiffness, "k-", lw=1.5, label="Pareto front (gauge at the peak)")
    tr = fe.rows[fe.rows.status == "success"]
    good = ((tr.safety_factor >= req["safety"]) & (tr.gauge_strain <= req["max_gauge_strain"])
            & (tr.gauge_strain >= req["min_gauge_strain"]))
    ax.scatter(tr.gauge_strain[~good] * 100, tr.stiffness[~good], s=14, marker="x", c="tab:red",
               label="FE trials, infeasible")
    ax.scatter(tr.gauge_strain[good] * 100, tr.stiffness[good], s=14, c="tab:blue", label="FE trials, feasible")
    m = res["final"].metrics
    ax.scatter([m["gauge_strain"] * 100], [m["stiffness"]], s=90, marker="*", c="gold", edgecolor="k", zorder=5,
               label="optimum, re-analysed")
    lo, hi = req["torque"] / req["twist_max"], req["torque"] / req["twist_min"]
    ax.fill_between([req["min_gauge_strain"] * 100, req["max_gauge_strain"] * 100], lo, hi, color="tab:green",
                    alpha=0.15, label="requirement: 0.02-0.06 %, 0.2-3 deg")
    ax.axhline(req["torque"] / req["twist_target"], color="tab:green", ls="--", lw=0.8)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("gauge strain at 140 N m [%]")
    ax.set_ylabel("torsional stiffness [N m/deg]")
    ax.legend(fontsize=7, loc="lower left")
    fig.tight_layout()
    return fig


def _final_concept_note(fe, final_metrics) -> str:
    """How this run's optimum compares with the library's ``final`` concept, whose defaults are the
    optimum of the recorded run (:data:`proleg.robots.torque_sensor.FINAL_STUDY`)."""
    from ..robots.torque_sensor import DEFAULTS, FINAL_CHANGES, FINAL_STUDY

    diff = max(abs(float(fe.best[k]) / FINAL_STUDY[k] - 1.0) for k in SPOKE_SPACE if k != "gauge_offset")
    same = diff <= 1e-3 and abs(float(fe.best["gauge_offset"]) - FINAL_STUDY["gauge_offset"]) <= 1e-3
    text = ("The library's final concept (torque_sensor_analysis(concept='final') at its defaults) is the FE search "
            "optimum of a recorded run of this study (proleg.robots.torque_sensor.FINAL_STUDY) with the changes its "
            "mesh convergence forced (FINAL_CHANGES: "
            + ", ".join(f"{k} {v * 1e3:.4g} mm" for k, v in FINAL_CHANGES.items()) + "); its dimensions: "
            + ", ".join(f"{k} {v * 1e3:.4g} mm" for k, v in DEFAULTS["final"].items()
                        if k not in ("n_spokes", "gauge_position")) + f", {DEFAULTS['final']['n_spokes']} spokes, "
            f"gauge_position {DEFAULTS['final']['gauge_position']:.3g}. This run's optimum is "
            + ("the recorded one." if same else f"a different design (dimensions up to {diff * 100:.2g} % apart); "
               "the defaults are the recorded run's until they are updated."))
    if final_metrics is not None:
        m = final_metrics
        text += (f" The final concept at its defaults (its default mesh): twist {m['twist']:.3g} deg, gauge strain "
                 f"{m['gauge_strain'] * 100:.3g} %, SF {m['safety_factor']:.3g}.")
    return text


def add_requirement_section(rep, res) -> None:
    """The requirement study (:func:`run_requirement`) as a report section; every number from ``res``."""
    fe, beam, req = res["fe"], res["beam"], res["fe"].requirement
    m = res["final"].metrics
    f = res["front"]
    at = f[f.gauge_strain <= req["max_gauge_strain"]]
    kmin = float(at.stiffness.min()) if len(at) else math.nan
    ok = (req["twist_min"] <= m["twist"] <= req["twist_max"], m["gauge_strain"] <= req["max_gauge_strain"],
          m["safety_factor"] >= req["safety"])
    rep.add_heading("The sensor to its requirement: twist about 1 deg at 140 N m (issue 30)")
    rep.add_text(
        f"Requirement (seed 001, Problem 2): about {req['twist_target']:g} deg at {req['torque']:g} N m (accepted "
        f"{req['twist_min']:g}-{req['twist_max']:g} deg, {req['torque'] / req['twist_max']:.0f}-"
        f"{req['torque'] / req['twist_min']:.0f} N m/deg), gauge strain <= {req['max_gauge_strain'] * 100:g} % (and "
        f">= {req['min_gauge_strain'] * 100:g} %, assumed floor), safety factor >= {req['safety']:g}. The paper's "
        f"tension-link shape above (open_links) keeps its largest strain at the gauge and twists "
        f"{res.get('open_links_twist', math.nan):.3g} deg. "
        f"With the gauge at the strain peak of a spoke, the most compliant design of the space that keeps the gauge <= "
        f"{req['max_gauge_strain'] * 100:g} % is {kmin:.0f} N m/deg (closed form, Pareto front in the figure): a "
        "strain-gauge sensor that twists about 1 deg must carry its gauge where the strain is a fraction of the "
        "peak. The optimiser places it along the spoke (gauge_offset: 0 at the spoke's inflection, 1 at the hub root).")
    rep.add_text(
        f"Search: CMA-ES minimising |ln(twist / 1 deg)| under the constraints, {len(beam.rows)} closed-form trials "
        f"(optimum twist {beam.best['twist']:.3g} deg, SF {beam.best['safety_factor']:.3g}), then {len(fe.rows)} FE "
        f"trials from that design (5 mm mesh, fillets, case A). FE search optimum: twist {fe.best['twist']:.3g} deg, "
        f"gauge strain {fe.best['gauge_strain'] * 100:.3g} %, SF {fe.best['safety_factor']:.3g}; binding: "
        f"{', '.join(fe.binding) or 'none'}; twist target (1 deg +- {req['twist_tolerance'] * 100:g} %) "
        f"{'met' if fe.target_met else 'not met'} on the search mesh. Re-analysed on a {REANALYSIS_MESH * 1e3:g} mm mesh "
        "(one the final concept's mesh convergence accepts; the 5 mm search mesh under-resolves thin spokes' root "
        "stress by ~10 %), both load cases and directions, "
        f"stress stiffening: twist {m['twist']:.3g} deg ({m['stiffness']:.0f} N m/deg), gauge strain "
        f"{m['gauge_strain'] * 100:.3g} %, SF {m['safety_factor']:.3g} (max von Mises {m['max_von_mises'] / 1e6:.0f} MPa "
        f"at r = {m['max_von_mises_radius_mm']:.1f} mm), gauge faces planar {m['gauge_planar']}, reachable "
        f"{m['gauge_reachable']}, calibration mismatch CW/CCW {m['calibration_mismatch'] * 100:.2g} %. Targets: twist in "
        f"range {'met' if ok[0] else 'NOT met'}, gauge strain {'met' if ok[1] else 'NOT met'}, SF "
        f"{'met' if ok[2] else 'NOT met'}. Envelope: assumed (seed 001 prints none), r_out <= 40 mm, thickness <= 15 mm.")
    rep.add_text(_final_concept_note(fe, res.get("final_concept")))
    rep.add_figure(_pareto_figure(res), "Stiffness against gauge strain: closed-form designs with the gauge at the "
                   "strain peak (grey) and their Pareto front (black), the FE trials of the search (gauge placed by "
                   "the optimiser), the requirement box and the optimum.")
    d = {k: v * 1e3 if k not in ("gauge_position", "n_spokes") else v for k, v in fe.dimensions.items()}
    rep.add_key_values({f"{k} [{'mm' if k not in ('gauge_position', 'n_spokes') else '-'}]": f"{v:.4g}"
                        for k, v in d.items()}, "Optimum dimensions (spokes concept)")
    cols = [*SPOKE_SPACE, "twist", "stiffness", "gauge_strain", "safety_factor", "status"]
    rep.add_table(fe.rows[[c for c in cols if c in fe.rows]], "FE trials of the search (5 mm mesh, case A).",
                  float_format="{:.4g}")
