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
closed loops, motions or couplers, smooth             ``Radau5``, order 5, index-2, on joint
                                                      coordinates (constraints held at every
                                                      step; error follows rtol); rtol 1e-6,
                                                      atol 1e-7 unless asked for
anything else: contacts, stops, backlash, friction,   ``GeneralizedAlpha`` (ρ∞ = 0.8), index 3,
bushings, flexible bodies, controllers, actuators,    error-controlled, numerically damped
stiff springs; closed loops with planar or absolute
coordinates named and no tolerance asked for
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
Why Radau5 for smooth closed loops, with or without a tolerance asked for: the α-methods are
second order, so their error falls only as rtol^(2/3) (0.7 decade per decade) and their phase
error grows with the run. At their defaults (rtol 1e-6, auto's choice for loops before issue 43)
a planar ladder of 6 identical parallelogram loops ends 4.8e-3 m from its exact motion after
30 s (27 periods: 48× the 100 × rtol rule below), a crank-rocker's crank tip (0.1 m) is 4.0e-2 m
off after 20 turns, Andrews' squeezer 1.8e-3 rad off its reference at 0.03 s. A tighter rtol
does not rescue it: at 3e-9 the ladder is 1.0e-4 m off (3.6× the time) but the crank-rocker
still 8.2e-4 m. Radau5 (error ∝ rtol or faster) at rtol 1e-6 on joint coordinates: 3.0e-7 m,
3.4e-6 m and 5.2e-7 rad, in 1.6×, 1.3× and 2.0× the α-method's warm time
(bench/closed_loops_defaults.py, bench/results/closed_loops_defaults.md). Joint coordinates,
not the planar ones ``coordinates="auto"`` gives a named Radau5: the ladder took 3.6 s on joint
coordinates and 94 s on planar ones (same error), the crank-rocker 0.48 s and 0.86 s, the
squeezer 0.13 s and 0.24 s. The price: the first run compiles
longer (13–15 s against 3.4–5.4 s for the α-method on these three), and outputs between steps
come from the collocation polynomial, so the constraints hold there only to its error (round-off
at the steps): 2.9e-8 on the crank-rocker (tests/test_core_fourbar.py), 9e-9 on a geared
four-bar, 2.8e-7 on a screw turned by a torque (37 steps in 1 s), where the α-method projects
each output to 5e-9 (tests/tolerances.py). Name ``GeneralizedAlpha()`` for short runs where
compile time dominates, or where closure at every output matters.

Default tolerances: Tsit5 rtol = 1e-7, atol = 1e-8 (order 5). The rule: a smooth model's
global error over a run of a few tens of its periods stays within about 100× rtol, and the
error falls with rtol at about one decade per decade (bench/accuracy.py --defaults, --slopes):
the undamped double pendulum's energy error is 2.2e-7 over 10 s, the 8-link chain's drift
1.5e-8. A phase error grows with the run's length: the IFToMM A01 pendulum is 2.2e-4 m off
after 100 s (about 50 swings; its benchmark's target is 1e-3 m), so ask for a smaller rtol
for long runs whose phase matters. Closed loops: Radau5 at rtol 1e-6, atol 1e-7 (its error
falls faster than rtol: 3e-7 m on the 6-loop ladder over 27 periods), or at the rtol asked for,
atol = rtol/10. The α-methods keep their own (rtol 1e-6, atol 1e-7: second order, error ∝
rtol^(2/3), and it grows with the run: the rule does not hold for them over tens of periods).
``result.stats["integrator"]`` names the method and the reason.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from ..assembly.coordinates import floating_tree
from ..errors import ModelError
from .radau import Radau5

#: group kinds that are smooth functions of the state (no switching, no state of their own)
SMOOTH_KINDS = frozenset({"spring_damper", "rotational_spring_damper", "force", "torque"})
#: a smooth tree is stiff when its fastest spring/damper rate × the run's length exceeds this
STIFF_CYCLES = 2.0e4
#: what the α-method's error estimate covers on floating-base trees with contacts (module docstring)
FLOATING_ERROR_ON = "positions"
#: rtol of smooth closed loops with no tolerance asked for (Radau5 on joint coordinates; atol = rtol/10):
#: bench/results/closed_loops_defaults.md
LOOPS_RTOL = 1e-6
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
        if kind == "loops" and ("rtol" in opts or coordinates in ("auto", "joint")):
            # Radau5 on joint coordinates (the module docstring's "Tolerances that mean what they say",
            # bench/results/closed_loops_defaults.md); on the coordinates asked for only with a tolerance.
            asked = "rtol" in opts
            rtol = opts.get("rtol", LOOPS_RTOL)
            keep = {k: v for k, v in opts.items() if k in ("dt_init", "dt_min", "dt_max", "fixed_step")}
            joint = coordinates in ("auto", "joint")
            ig = (JointRadau5 if joint else Radau5)(rtol=rtol, atol=opts.get("atol", rtol / 10), **keep)
            told = (f"rtol {rtol:g} asked for" if asked else
                    f"no tolerance asked for (rtol {rtol:g}, atol {ig.atol:g}; the α-method's phase error grows with the run)")
            return ig, (f"{why}, {told}: Radau5 (implicit, order 5, constraints held at every step)"
                        + (" on joint coordinates" if joint else ""))
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
            why += (f", coordinates='{coordinates}' asked for and no tolerance (give rtol= for Radau5 on them; this method's "
                    "phase error grows with the run: module docstring)")
        return ig, f"{why}: GeneralizedAlpha (index 3, ρ∞ = 0.8, error-controlled)"


@dataclass(frozen=True)
class JointRadau5(Radau5):
    """:class:`Radau5` on joint coordinates where the caller left ``coordinates="auto"``: what
    ``Auto`` runs for smooth closed loops (module docstring). Joint coordinates because they were
    the faster at equal error (bench/results/closed_loops_defaults.md): at rtol 1e-6 the 6-loop
    ladder took 3.6 s on joint coordinates and 94 s on planar ones, Andrews' squeezer 0.13 s and
    0.24 s."""

    def run(self, system, request):
        if request.coordinates == "auto":
            request = dataclasses.replace(request, coordinates="joint")
        return super().run(system, request)

    def describe(self) -> str:
        return "Radau5" + super().describe()[len(type(self).__name__):] + " on joint coordinates"


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
