"""A model's structure and the numbers its compiled functions read (issue 42).

A new design should cost a run, not a compile. :mod:`proleg.compile_cache` keys every compiled
function twice: by everything it depends on, and by the model's *structure* alone — counts and
kinds of parts, joints, elements, contacts, actuators and controllers, connectivity, modal
counts, the integrator and coordinates chosen, the output grid's size, and the few numbers that
shape the computation itself (a controller's sample period, a one-hot selector, the plane of a
planar model, a user function's code and closure). Every other number (masses, inertias, marker
positions, joint axes and limits, stiffnesses, gains, set points, contact geometry, gravity) is
data: it reaches the computation as an element of ``System.params``, so two assemblies of one
structure with other numbers share their executables.

That a trace reads no model number is checked, not assumed: the first model with a second set of
numbers of a structure is traced twice, as it is and with every number of its topology changed
(sign, scale and offset), and the executables are shared only if the two traces are equal,
equation for equation and constant for constant. :func:`numbers_read` runs the same check on
demand, as the tests do for every built-in robot, a URDF robot and the docs' examples.
"""

from __future__ import annotations

from collections import Counter

import numpy as np

from ..assembly.system import System, _jit_constraints_and_jacobian
from ..compile_cache import reads_numbers, structure_key
from ..solvers.initial import _ic, initial_z


def _ic_args(system: System):
    return (system, system.params["q_init"], system.params["v_init"], np.asarray(0.0), 8, initial_z(system))


def numbers_read(system: System) -> dict[str, str]:
    """What tracing the model's physics reads of its numbers outside ``params``, per function: the
    initial-conditions analysis (mass matrix, every force element, contact, actuator and
    controller sample, constraints and their Jacobian, accelerations) and the constraint
    Jacobian. An empty dict: the model shares its compiled functions with every model of its
    structure. Otherwise each entry names the first equation or constant that changed when the
    numbers did; the fix is to move that number into ``params`` (an element's ``params()``) or,
    if it must shape the computation, to declare it structure (``_structure_fields``)."""
    out = {}
    for name, fn, args in (
        ("initial conditions and forces", _ic, _ic_args(system)),
        ("constraints and Jacobian", _jit_constraints_and_jacobian, (system, system.params["q_init"], np.asarray(0.0))),
    ):
        why = reads_numbers(fn, *args)
        if why:
            out[name] = why
    return out


def same_structure(a: System, b: System) -> bool:
    """Whether two assemblies have one structure key (their compiled functions are shared once
    :func:`numbers_read` of either is empty)."""
    return structure_key(_ic, *_ic_args(a)) == structure_key(_ic, *_ic_args(b))


def structure_summary(system: System) -> dict:
    """The parts of the structure key a designer can read (``proleg info``): counts and kinds of
    parts, joints, elements, contacts, actuators and controllers, modal coordinates, the numbers
    declared structure, the parameters that are data, and the key itself (short)."""
    topo = system.topo
    model = topo.model
    kinds = Counter()
    for g in list(topo.groups) + list(topo.extensions):
        try:
            n = len(g)
        except TypeError:
            n = len(getattr(g, "elements", ())) or 1
        if n:
            kinds[g.kind] += n
    fixed = {}
    for g in list(topo.groups) + list(topo.extensions):
        for e in getattr(g, "elements", ()):
            for f in getattr(type(e), "_structure_fields", ()):
                fixed[f"{e.name}.{f}"] = getattr(e, f, None)
    return {
        "parts": topo.nbody,
        "joints": dict(Counter(getattr(j, "kind", type(j).__name__) for j in topo.joints)),
        "elements": dict(kinds),
        "motions": len(getattr(model, "motions", []) or []),
        "modal coordinates": int(topo.n_eta),
        "planar": topo.planar[0] is not None,
        "structure numbers": fixed,
        "data parameters": len(system.params),
        "key": structure_key(_ic, *_ic_args(system))[:16],
    }


def design_gradient(build, design: dict, metric, names=None, *, rel_step: float = 1e-6, **simulate_kw):
    """(metric, {name: ∂metric/∂name}) for a builder's design arguments (a link length, a
    cylinder attachment point), through the simulation.

    ``build(**design)`` returns a Model; ``metric(result)`` a scalar (a peak force, a final
    height, ...); ``simulate_kw`` go to :func:`proleg.simulate`. A builder is plain Python, so its
    map from design numbers to ``System.params`` is differentiated by central differences of
    ``assemble`` (step ``rel_step`` × max(1, |x|): the map is smooth and usually affine, so the
    error is round-off); the simulation by forward mode (``jax.jvp``) along that direction, one
    compiled pass for every name. A design argument that changes the structure (a count, a
    kind, a branch) has no derivative: ModelError."""
    import jax
    import jax.numpy as jnp

    from ..assembly.assemble import assemble
    from ..errors import ModelError
    from .simulate import simulate

    names = list(design) if names is None else list(names)
    s0 = assemble(build(**design))

    def f(P):
        return metric(simulate(s0.with_params(P), **simulate_kw))

    jvp = jax.jit(lambda P, dP: jax.jvp(f, (P,), (dP,)))
    value, out = None, {}
    for name in names:
        x = float(design[name])
        h = rel_step * max(1.0, abs(x))
        sp, sm = assemble(build(**{**design, name: x + h})), assemble(build(**{**design, name: x - h}))
        if not (same_structure(s0, sp) and same_structure(s0, sm)):
            raise ModelError(
                f"design_gradient: '{name}' changes the structure of model '{s0.topo.name}' (structure_summary "
                "differs), so the metric has no derivative with respect to it. Give only continuous numbers."
            )
        dP = {k: (jnp.asarray(sp.params[k]) - jnp.asarray(sm.params[k])) / (2.0 * h) for k in s0.params}
        value, d = jvp(s0.params, dP)
        out[name] = float(d)
    return (float(value) if value is not None else float(f(s0.params))), out


_SIMULATION_VERDICTS: dict[str, bool] = {}


def simulation_key(system: System, run) -> str | None:
    """A key shared by every System whose ``run(system)`` (a simulation and what it returns) is
    one computation with its ``params`` as the arguments, or None where that does not hold.

    The key is the structure fingerprint of the System's pytree structure and of ``run`` (its
    code and closure, hashed exactly); the first System of a key decides, once per process: its
    trace is compared with the traces of copies whose every topology number is changed
    (:func:`proleg.compile_cache.perturbed`). A builder study groups its designs by this key at
    the cost of a hash per design instead of a trace (issue 42). None when the run reads a
    number of the topology, or cannot be keyed or traced."""
    import jax

    from .. import compile_cache as cc

    leaves, td = jax.tree_util.tree_flatten(system)
    try:
        key = cc.structure_fingerprint(cc._environment_key(), td, tuple(cc._aval(x) for x in leaves), run)
    except (cc.Unkeyable, TypeError):
        return None
    free = _SIMULATION_VERDICTS.get(key)
    if free is None:
        free = _run_reads_no_numbers(system, run)
        _SIMULATION_VERDICTS[key] = free
    return key if free else None


def _run_reads_no_numbers(system: System, run) -> bool:
    import warnings

    import jax

    from .. import compile_cache as cc

    leaves, td = jax.tree_util.tree_flatten(system)

    def traced(treedef):
        return jax.make_jaxpr(lambda lv: run(jax.tree_util.tree_unflatten(treedef, lv)))(leaves)

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            j1 = traced(td)
        except Exception:  # noqa: BLE001 (not traceable here)
            return False
        return not cc.numbers_difference(j1, lambda _static, treedef: traced(treedef), (), td)
