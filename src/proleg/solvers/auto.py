"""``integrator="auto"`` (the default of :func:`proleg.simulate`): the method that fits the model.

MuJoCo, Adams (GSTIFF by default), Simscape (its ``auto`` solver) and DifferentialEquations.jl
(``solve(prob)``) give a good answer without a method named; so does proleg. The choice is
made from what :func:`proleg.assemble` knows, before anything compiles:

====================================================  ==========================================
model                                                 method (coordinates)
====================================================  ==========================================
loop-free tree, smooth forces only (springs, dampers, ``Tsit5``, order 5, on joint coordinates
loads), not stiff; a floating base included (free     (an ODE: no constraint to drift; a
flight)                                               floating base's quaternion normalisation
                                                      is held by the ODE, solvers/ode.py)
loop-free tree on a floating base with contacts,      ``GeneralizedAlpha`` (ρ∞ = 0.8) on joint
servos, actuators, stops or friction (a legged        coordinates, Newton matrix reused across
robot: assembly/coordinates.py ``floating_tree``)     steps (modified Newton)
closed loops, motions or couplers, smooth, and a      ``Radau5``, order 5, index-2 (constraints
tolerance asked for (``rtol=``)                       held exactly; error follows rtol)
anything else: contacts, stops, backlash, friction,   ``GeneralizedAlpha`` (ρ∞ = 0.8), index 3,
bushings, flexible bodies, controllers, actuators,    error-controlled, numerically damped
stiff springs, closed loops at ordinary tolerances
====================================================  ==========================================

Why the floating-base row: in absolute coordinates a quadruped's Newton matrix is ~8× larger
(HyQ: 91 coordinates + 73 rows against 19 + 1) and was rebuilt every step; in joint
coordinates with the matrix kept (rebuilt when Newton contracts slowly or h moves) a step
costs tens of times less and compiles faster (bench/results/whole_robot.md). The error
estimate stays on positions: with ``error_on="positions+velocities"`` a Go1 standing 1 s took
5,694 steps and 1,677 rejections instead of 1,006 and none (17× the time) for joint positions
within 1e-5 rad of each other — the 1 kHz servo samples bound the step at 1 ms either way, and
the velocity estimate at rest (weights atol/T ≈ 1e-6) chases the servo's force steps. Ask for
it (``error_on=``) where velocities matter more than that.

"Stiff" for a smooth tree: a spring or damper whose rate on the lightest part,
max(√(k/m), c/m) [1/s] (k/I, c/I for rotational ones), times the run's length exceeds
:data:`STIFF_CYCLES`: an explicit method would then take its steps for stability, not accuracy.

Options given to ``Auto`` (or as ``simulate(rtol=..., ...)``) go to the method chosen; an option
only the α-methods have (``jacobian_reuse``, ``max_newton``, ``lu_per_lane``, ``atol_p``,
``error_on``) selects them.

Tolerances that mean what they say
----------------------------------
Why the split on closed loops: the α-methods are second order, so their error falls only as
rtol^(2/3) (0.7 decade per decade); a user who asks for a tolerance gets Radau5, whose error
follows rtol (≥ 0.9 decade per decade). At the defaults the α-method's robustness and faster
first compile win.

Default tolerances: Tsit5 rtol = 1e-7, atol = 1e-8 (order 5). The rule: a smooth model's
global error over a run of a few tens of its periods stays within about 100× rtol, and the
error falls with rtol at about one decade per decade (bench/accuracy.py --defaults, --slopes):
the undamped double pendulum's energy error is 2.2e-7 over 10 s, the 8-link chain's drift
1.5e-8. A phase error grows with the run's length: the IFToMM A01 pendulum is 2.2e-4 m off
after 100 s (about 50 swings; its benchmark's target is 1e-3 m), so ask for a smaller rtol
for long runs whose phase matters. The α-methods keep
their own (rtol 1e-6, atol 1e-7: second order, error ∝ rtol^(2/3)); Radau5 runs at the rtol
asked for, atol = rtol/10. ``result.stats["integrator"]`` names the method and the reason.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from ..assembly.coordinates import floating_tree
from ..errors import ModelError

#: group kinds that are smooth functions of the state (no switching, no state of their own)
SMOOTH_KINDS = frozenset({"spring_damper", "rotational_spring_damper", "force", "torque"})
#: a smooth tree is stiff when its fastest spring/damper rate × the run's length exceeds this
STIFF_CYCLES = 2.0e4
#: what the α-method's error estimate covers on floating-base trees with contacts (module docstring)
FLOATING_ERROR_ON = "positions"
_ALPHA_ONLY = ("atol_p", "max_newton", "jacobian_reuse", "lu_per_lane", "error_on", "velocity_time_scale")


@dataclass(frozen=True)
class Auto:
    """Let :func:`proleg.simulate` choose the method (module docstring has the table).

    Parameters
    ----------
    rtol, atol : float, optional — tolerances for the method chosen (default: its own)
    dt_init, dt_min, dt_max, fixed_step : float [s], optional — step options, passed on
    atol_p, max_newton, jacobian_reuse, lu_per_lane, error_on, velocity_time_scale : options of
        the α-methods; giving one selects them
    """

    rtol: float | None = None
    atol: float | None = None
    dt_init: float | None = None
    dt_min: float | None = None
    dt_max: float | None = None
    fixed_step: float | None = None
    atol_p: float | None = None
    max_newton: int | None = None
    jacobian_reuse: bool | None = None
    lu_per_lane: bool | None = None
    error_on: str | None = None
    velocity_time_scale: float | None = None

    def given(self) -> dict:
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self) if getattr(self, f.name) is not None}

    def choose(self, system, t_span: float, coordinates: str = "auto"):
        """(integrator, reason) for ``system`` over a run of ``t_span`` [s]."""
        from .galpha import GeneralizedAlpha
        from .ode import Tsit5
        from .radau import Radau5

        opts = self.given()
        kind, why = classify(system, t_span)
        alpha_only = sorted(k for k in opts if k in _ALPHA_ONLY)
        if alpha_only:
            kind, why = "alpha", f"{why}; α-method options given ({', '.join(alpha_only)})"
        if kind == "tree" and coordinates not in ("auto", "joint"):
            kind, why = "alpha", f"{why}; coordinates='{coordinates}' asked for (the order-5 ODE runs on joint coordinates)"
        if kind == "tree":
            rtol = opts.get("rtol", 1e-7)
            atol = opts.get("atol", rtol / 10)
            ig = Tsit5(rtol=rtol, atol=atol, dt_max=opts.get("dt_max"), fixed_step=opts.get("fixed_step"))
            return ig, f"{why}: Tsit5 (explicit, order 5) on joint coordinates"
        if kind == "loops" and "rtol" in opts:
            rtol = opts["rtol"]
            keep = {k: v for k, v in opts.items() if k in ("dt_init", "dt_min", "dt_max", "fixed_step")}
            ig = Radau5(rtol=rtol, atol=opts.get("atol", rtol / 10), **keep)
            return ig, f"{why}, rtol {rtol:g} asked for: Radau5 (implicit, order 5, constraints held exactly)"
        if kind == "alpha" and coordinates in ("auto", "joint") and floating_tree(system)[0]:
            # A legged robot: contacts, servos and actuators on a loop-free floating-base tree, in
            # joint coordinates (assembly/coordinates.py auto_coordinates), with modified Newton
            # (the Newton matrix kept across steps): module docstring, bench/results/whole_robot.md.
            fast = {"jacobian_reuse": True, "error_on": FLOATING_ERROR_ON, **opts}
            ig = GeneralizedAlpha(**fast)
            return ig, (f"{why} on a loop-free floating-base tree: GeneralizedAlpha (index 3, ρ∞ = 0.8, error-controlled on "
                        f"{ig.error_on}, Newton matrix reused across steps) on joint coordinates")
        ig = GeneralizedAlpha(**opts)
        if kind == "loops":
            why += f", no tolerance asked for (rtol={ig.rtol:g}; give rtol= for Radau5)"
        return ig, f"{why}: GeneralizedAlpha (index 3, ρ∞ = 0.8, error-controlled)"


def classify(system, t_span: float):
    """("tree" | "loops" | "alpha", reason) from the assembled topology alone."""
    topo = system.topo
    if topo.flex is not None or getattr(topo, "n_eta", 0):
        return "alpha", "flexible bodies"
    kinds = sorted({g.kind for g in list(topo.groups) + list(topo.extensions) if _size(g)} - SMOOTH_KINDS)
    if kinds:
        return "alpha", f"non-smooth or stiff elements ({', '.join(kinds)})"
    try:
        from ..assembly.joint_coordinates import joint_set

        dyn = joint_set(system)
    except ModelError as exc:
        return "alpha", f"no joint-coordinate tree ({str(exc).splitlines()[0][:80]})"
    if dyn.tree.ct.n_rows:  # a floating base's quaternion normalisation alone is no loop (solvers/ode.py holds it)
        what = ", ".join(dyn.tree.cut) if getattr(dyn.tree, "cut", None) else "motions or couplers"
        return "loops", f"closed loops or constraints on the tree ({what})"
    rate = stiffest_rate(system)
    if rate * float(t_span) > STIFF_CYCLES:
        return "alpha", f"stiff springs (rate {rate:.3g} 1/s × {t_span:g} s > {STIFF_CYCLES:g})"
    return "tree", "loop-free tree with smooth forces"


def _size(group) -> int:
    try:
        return len(group)
    except TypeError:
        return len(getattr(group, "elements", ())) or 1


def stiffest_rate(system) -> float:
    """max over springs/dampers of √(k/m) and c/m [1/s] on the lightest part (k/I, c/I with the
    smallest principal inertia for rotational ones): an upper bound of the model's fast rates."""
    topo = system.topo
    parts = [p for p in getattr(topo.model, "parts", []) if not getattr(p, "is_flexible", False)]
    masses = [float(p.mass) for p in parts if float(p.mass) > 0]
    m_min = min(masses) if masses else 1.0
    inert = [float(np.max(np.abs(np.asarray(p.inertia, float)))) for p in parts]
    i_min = min([i for i in inert if i > 0], default=1.0)
    rate = 0.0
    for g in topo.groups:
        if not _size(g) or g.kind not in ("spring_damper", "rotational_spring_damper"):
            continue
        base = m_min if g.kind == "spring_damper" else max(i_min, 1e-300)
        for e in g.elements:
            k = abs(float(np.max(np.abs(np.asarray(getattr(e, "stiffness", 0.0), float)))))
            c = abs(float(np.max(np.abs(np.asarray(getattr(e, "damping", 0.0), float)))))
            rate = max(rate, np.sqrt(k / max(base, 1e-300)), c / max(base, 1e-300))
    return float(rate)
