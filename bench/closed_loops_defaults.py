"""Closed loops at the defaults (issue 43, item 2): end error and warm wall time of what
``integrator="auto"`` picks for a smooth closed-loop model with no tolerance asked for, against
the alternatives.

Problems:

- ``ladder``: a planar mechanism of ``N_LOOPS`` identical parallelogram loops (the many-loop
  case of the issue). ``N_LOOPS + 1`` equal cranks (1 kg, 0.3 m rods) hang from ground pivots
  0.4 m apart along x, their tips joined by ``N_LOOPS`` couplers (1 kg, 0.4 m), revolutes about
  y, gravity −z, released at rest from 50° off the vertical. Every crank keeps the same angle θ
  and every coupler translates, so the mechanism is one pendulum,

      J θ̈ = −g G sin θ,  J = (N+1) m_k r²/3 + N m_c r²,  G = (N+1) m_k r/2 + N m_c r,

  integrated by scipy's DOP853 at rtol = atol = 1e-13 (an independent reference, not a run of
  proleg). Error: the largest distance of any part's centre of mass from its exact position
  [m], at the end of the run and over it. Period about 1.1 s; 30 s is about 27 periods.
- ``four_bar``: tests/test_core_fourbar.py's crank-rocker (no gravity, the crank turning at
  about 6.5 rad/s, about one turn a second), ``--t-fourbar`` s: the crank tip's distance from a
  Radau5 run at rtol 1e-11 on joint coordinates (the four-bar has no closed-form time history).
- ``squeezer``: Andrews' squeezing mechanism (bench/accuracy.py), 0.03 s, against the Test Set's
  reference.

Methods: ``auto`` (no integrator named, no tolerance: what ``simulate`` picks), ``ga 1e-6`` (the
α-method's defaults: auto's choice before issue 43), ``ga <rtol>`` (tighter), ``radau5 <rtol>``
(planar coordinates, what ``coordinates="auto"`` gives a named Radau5), ``radau5 <rtol> joint``
(joint coordinates); atol = rtol/10 throughout. Wall time: the fastest of ``--repeat`` warm runs;
"first run" is compile + run where the method's loop was not compiled yet in the process (the
tolerances are traced, so later rows of the same method and coordinates reuse the compile).

    python bench/closed_loops_defaults.py                      # all problems and methods
    python bench/closed_loops_defaults.py --problems ladder --methods auto "radau5 1e-7"
"""

from __future__ import annotations

import argparse
import math
import os
import time
import warnings

import numpy as np
from common import add_output_args, emit, log

N_LOOPS = 6
CRANK, SPACING, MASS = 0.3, 0.4, 1.0  # crank and coupler length [m], part mass [kg]
THETA0 = math.radians(50.0)  # initial crank angle from the downward vertical [rad]
G = 9.81
#: rows left out of the default table, and why (a probe's measurement, in the notes)
SKIP = {("ladder", "radau5 1e-6"): "planar coordinates: 93.8 s warm, 2,704 steps, error 7.6e-7 m in a probe at load 6.7 "
                                   "(radau5 1e-7: 161.8 s, 4.2e-8 m; 1e-8: 272.3 s, 2.2e-9 m)"}
COLUMNS = ["problem", "method", "end error", "max error", "bound 100×rtol", "met", "wall [s]", "steps", "rejected", "first run [s]"]


def _rod(model, name, p, q, mass):
    """A slender rod from p to q in the x-z plane (part x axis along it, y the joint axis)."""
    L = float(np.linalg.norm(q - p))
    x = (q - p) / L
    y = np.array([0.0, 1.0, 0.0])
    R = np.column_stack([x, y, np.cross(x, y)])
    rad = 0.005
    return model.add_part(name, mass=mass, inertia=(mass * rad**2 / 2, mass * L**2 / 12, mass * L**2 / 12),
                          position=tuple((p + q) / 2), orientation=R)


def ladder_tips(theta, n_loops=N_LOOPS):
    """Crank pivots and tips [m] (n_loops + 1, 3) at crank angle theta [rad]."""
    piv = np.array([[k * SPACING, 0.0, 0.0] for k in range(n_loops + 1)])
    return piv, piv + CRANK * np.array([math.sin(theta), 0.0, -math.cos(theta)])


def ladder_model(n_loops=N_LOOPS, theta0=THETA0):
    """The parallelogram ladder (module docstring): n_loops + 1 cranks ``crank{k}``, n_loops
    couplers ``coupler{k}``; 2 n_loops + 1 revolutes about y."""
    import proleg as pl

    model = pl.Model(f"ladder{n_loops}", gravity=(0.0, 0.0, -G))
    piv, tip = ladder_tips(theta0, n_loops)
    y = (0.0, 1.0, 0.0)
    cranks = [_rod(model, f"crank{k}", piv[k], tip[k], MASS) for k in range(n_loops + 1)]
    for k, c in enumerate(cranks):
        model.add_joint(pl.Revolute(f"pivot{k}", model.ground, c, at=tuple(piv[k]), axis=y))
    for k in range(n_loops):
        cp = _rod(model, f"coupler{k}", tip[k], tip[k + 1], MASS)
        model.add_joint(pl.Revolute(f"left{k}", cranks[k], cp, at=tuple(tip[k]), axis=y))
        model.add_joint(pl.Revolute(f"right{k}", cp, cranks[k + 1], at=tuple(tip[k + 1]), axis=y))
    return model


def ladder_system(n_loops=N_LOOPS):
    import proleg as pl

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the 3D rows of a planar loop are redundant: assembly says so
        return pl.assemble(ladder_model(n_loops))


def ladder_theta(t, n_loops=N_LOOPS, theta0=THETA0):
    """Exact crank angle θ(t) [rad] at times t: the one-DOF pendulum of the module docstring by
    DOP853 at rtol = atol = 1e-13."""
    from scipy.integrate import solve_ivp

    n = n_loops
    J = (n + 1) * MASS * CRANK**2 / 3 + n * MASS * CRANK**2
    Gm = (n + 1) * MASS * CRANK / 2 + n * MASS * CRANK
    t = np.asarray(t, float)
    sol = solve_ivp(lambda _, y: [y[1], -G * Gm / J * math.sin(y[0])], (0.0, float(t[-1])), [theta0, 0.0], method="DOP853",
                    t_eval=t, rtol=1e-13, atol=1e-13)
    return sol.y[0]


def ladder_error(r, n_loops=N_LOOPS):
    """(end, max) over time of the largest distance of a part's COM from its exact position [m]."""
    th = ladder_theta(np.asarray(r.t), n_loops)
    d = np.zeros(len(th))
    off = np.stack([np.sin(th), np.zeros_like(th), -np.cos(th)], 1)
    for k in range(n_loops + 1):
        exact = np.array([k * SPACING, 0.0, 0.0]) + 0.5 * CRANK * off
        d = np.maximum(d, np.linalg.norm(np.asarray(r.part(f"crank{k}").position) - exact, axis=1))
    for k in range(n_loops):
        exact = np.array([(k + 0.5) * SPACING, 0.0, 0.0]) + CRANK * off
        d = np.maximum(d, np.linalg.norm(np.asarray(r.part(f"coupler{k}").position) - exact, axis=1))
    return float(d[-1]), float(d.max())


def _fourbar():
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
    import test_core_fourbar as fb

    return fb


def problems(names, t_ladder=30.0, t_fourbar=30.0):
    """{name: dict(system, t_end, dt, error, what)} for the problems in ``names`` (assembled here)."""
    out = {}
    if "ladder" in names:
        out["ladder"] = dict(system=ladder_system(), t_end=t_ladder, dt=0.05, error=ladder_error,
                             what=f"{N_LOOPS} parallelogram loops, {t_ladder:g} s (~{t_ladder / 1.1:.0f} periods): "
                                  "max COM distance from the exact motion [m]")
    if "four_bar" in names:
        out["four_bar"] = _fourbar_problem(t_fourbar)
    if "squeezer" in names:
        out["squeezer"] = _squeezer_problem()
    return out


def _fourbar_problem(t_fourbar):
    import proleg as pl

    fb = _fourbar()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fsys = pl.assemble(fb.build())
    ref = {}

    def crank_angle(r):
        c = np.asarray(r.part("crank").position)
        return np.unwrap(np.arctan2(c[:, 2] - fb.A_PT[2], c[:, 0] - fb.A_PT[0]))

    def fourbar_error(r):
        if "phi" not in ref:
            rr = pl.simulate(fsys, t_end=t_fourbar, dt_output=0.01, integrator=pl.Radau5(rtol=1e-11, atol=1e-12), coordinates="joint",
                             progress=False)
            ref["phi"] = crank_angle(rr)
        phi = crank_angle(r)
        d = np.abs(phi - ref["phi"]) * fb.LA  # crank tip distance [m] (small angles)
        return float(d[-1]), float(d.max())

    return dict(system=fsys, t_end=t_fourbar, dt=0.01, error=fourbar_error,
                what=f"crank-rocker, {t_fourbar:g} s (~{t_fourbar:.0f} crank turns): crank tip distance from a Radau5 rtol 1e-11 run [m]")


def _squeezer_problem():
    import proleg as pl
    from accuracy import SQ_REF, squeezer_angles, squeezer_model

    def sq_error(r):
        e = float(np.abs(squeezer_angles(r) - SQ_REF).max())
        return e, e

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        system = pl.assemble(squeezer_model())
    return dict(system=system, t_end=0.03, dt=1e-4, error=sq_error,
                what="Andrews' squeezer, 0.03 s: max angle error at the end [rad] (Test Set reference)")


def method_kw(name):
    """simulate() keywords and the rtol the 100× rule refers to for a method label."""
    import proleg as pl

    if name == "auto":
        return {}, None
    kind, rtol, *extra = name.split()
    rtol = float(rtol)
    opts = dict(rtol=rtol, atol=rtol / 10)
    kw = {}
    for e in extra:  # "joint" / "absolute": coordinates; "rho<x>": the α-method's ρ∞
        if e.startswith("rho"):
            opts["rho_inf"] = float(e[3:])
        else:
            kw["coordinates"] = e
    ig = {"ga": pl.GeneralizedAlpha, "radau5": pl.Radau5, "hht": pl.HHT}[kind](**opts)
    return dict(integrator=ig, **kw), rtol


def run_rows(probs, names, methods, repeat):
    import proleg as pl

    rows = []
    for pname in names:
        p = probs[pname]
        for mname in methods:
            if (pname, mname) in SKIP:
                log(f"{pname} {mname}: skipped ({SKIP[pname, mname]})")
                continue
            kw, rtol = method_kw(mname)
            run = lambda: pl.simulate(p["system"], t_end=p["t_end"], dt_output=p["dt"], progress=False, throw=False, **kw)  # noqa: B023,E731
            t0 = time.perf_counter()
            r = run()
            first = time.perf_counter() - t0
            walls = []
            for _ in range(repeat):
                t0 = time.perf_counter()
                r = run()
                walls.append(time.perf_counter() - t0)
            end, mx = p["error"](r) if r.ok else (float("nan"), float("nan"))
            if rtol is None:
                rtol = getattr(r.stats.get("integrator_object"), "rtol", None) or _rtol_of(r.stats["integrator"])
            bound = 100 * rtol if rtol else None
            label = f"auto: {r.stats['integrator']}" if mname == "auto" else mname
            rows.append({"problem": pname, "method": label, "end error": end, "max error": mx, "bound 100×rtol": bound,
                         "met": bool(bound and mx <= bound), "wall [s]": min(walls), "steps": r.stats["steps"],
                         "rejected": r.stats["rejected"], "first run [s]": first})
            log(f"{pname} {label}: end {end:.3g}, max {mx:.3g} (bound {bound}), {min(walls):.3f} s, {r.stats['steps']} steps "
                f"(load {os.getloadavg()[0]:.2f})")
    return rows


def _rtol_of(desc: str):
    """rtol from an integrator's description, e.g. 'GeneralizedAlpha(rho_inf=0.8, rtol=1e-06, ...)'."""
    import re

    m = re.search(r"rtol=([0-9.eE+-]+)", desc)
    return float(m.group(1)) if m else None


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--problems", nargs="+", default=["ladder", "four_bar", "squeezer"])
    ap.add_argument("--methods", nargs="+", default=["auto", "ga 1e-6", "ga 1e-7", "ga 1e-8", "ga 3e-9", "radau5 1e-5 joint",
                                                     "radau5 1e-6 joint", "radau5 1e-7 joint", "radau5 1e-6"])
    ap.add_argument("--t-end", type=float, default=30.0, help="run length of the ladder [s]")
    ap.add_argument("--t-fourbar", type=float, default=20.0, help="run length of the four-bar [s]")
    add_output_args(ap, "closed_loops_defaults")
    args = ap.parse_args(argv)
    probs = problems(args.problems, args.t_end, args.t_fourbar)
    rows = run_rows(probs, args.problems, args.methods, max(args.repeat, 1))
    notes = [f"{k}: {v['what']}" for k, v in probs.items() if k in args.problems]
    notes += [f"{p} {m}: skipped, {why}" for (p, m), why in SKIP.items() if p in args.problems and m in args.methods]
    notes.append("bound: 100 × the rtol the method ran at (auto docstring's rule for smooth models over a few tens of periods); "
                 "met: max error within it. Wall: fastest warm run; first run: compile + run for the first row of each method and "
                 "coordinates (later rtols reuse the compile: tolerances are traced)")
    emit(args, "issue 43: closed loops at the defaults, end error and warm wall time", rows, COLUMNS,
         meta={"load average": os.getloadavg()[0], "n_loops": N_LOOPS}, notes=notes)


if __name__ == "__main__":
    main()
