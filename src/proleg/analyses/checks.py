"""Checks of the arguments of the analyses, in plain Python before anything is traced.

Every public analysis (``simulate``, ``sweep``, ``linearize``, ``solve_equilibrium``) calls one
function of this module on its first line. A wrong argument is a :class:`~proleg.errors.ModelError`
that names the argument, its value, what was expected and the fix; a legal but suspicious one
(``dt_output`` > ``t_end``, a ``fixed_step`` that does not divide the output interval, an element
stiffer than the step can follow) is a :class:`~proleg.errors.ProlegWarning`. Values that are
traced (inside ``jax.vmap``/``jit``/``grad``) are checked for shape only.
"""

from __future__ import annotations

import math
import os
import uuid
import warnings
from pathlib import Path

import numpy as np

from ..errors import DataError, ModelError, ProlegWarning
from ..model._validate import inertia_problem
from .placement import is_traced

# A stiffness warning is given when an element's period is below STIFF_PERIOD_RATIO · dt_max:
# the error control then needs steps ~ period / 20 while the element is excited, thousands of
# times below dt_max (the "stiff bushings → rigid joint" tests run at ratios of ~1e-2).
STIFF_PERIOD_RATIO = 1e-3
STEPS_PER_PERIOD = 20
# ... or below 1 µs whatever dt_max: a legged robot's stiffest real contact (steel on steel,
# Hertz 4/3 E* √R ≈ 1e10 N/m^1.5 on a 1 kg part) has a period of ~1e-4 s.
STIFF_PERIOD_MIN = 1e-6


_PACKAGE = str(Path(__file__).resolve().parents[1])


def warn(message: str) -> None:
    """Emit a one-line :class:`ProlegWarning` attributed to the first caller outside proleg."""
    import sys

    level, f = 2, sys._getframe(1)
    while f is not None and str(Path(f.f_code.co_filename).resolve()).startswith(_PACKAGE):
        f, level = f.f_back, level + 1
    warnings.warn(message, ProlegWarning, stacklevel=level)


def _scalar(who: str, name: str, value, *, unit: str = "", positive=False, allow_none=False, example=""):
    """A finite real scalar (float) or None; ModelError naming ``who``'s ``name`` otherwise."""
    if value is None:
        if allow_none:
            return None
        raise ModelError(f"{who}: {name} is required{(' [' + unit + ']') if unit else ''}.")
    if is_traced(value):
        return value
    u = f" [{unit}]" if unit else ""
    if isinstance(value, bool | str | bytes) or np.ndim(value) != 0:
        raise ModelError(f"{who}: {name} must be a number{u}, got {value!r}.{(' E.g. ' + example) if example else ''}")
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ModelError(f"{who}: {name} must be a number{u}, got {value!r}.") from None
    if not math.isfinite(v):
        raise ModelError(f"{who}: {name} = {v} is not a finite number{u}.{(' E.g. ' + example) if example else ''}")
    if positive and not v > 0:
        raise ModelError(f"{who}: {name} must be positive{u}, got {v:g}.{(' E.g. ' + example) if example else ''}")
    return v


def _count(who: str, name: str, value, minimum: int = 1) -> int:
    if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < minimum:
        raise ModelError(f"{who}: {name} must be an integer ≥ {minimum}, got {value!r}.")
    return int(value)


def check_state(system, who: str, name: str, value, what: str = "q"):
    """``q``-shaped (nq,) vector: shape always, finiteness when concrete."""
    if value is None:
        return None
    topo = system.topo
    nq = topo.nq
    layout = f"7 per part × {topo.nbody} part(s) {topo.body_names[:4]}{'...' if topo.nbody > 4 else ''}"
    if topo.n_eta:
        layout += f" + {topo.n_eta} modal"
    start = "system.params['q_init']" if what == "q" else "system.params['v_init']"
    if not hasattr(value, "shape"):
        try:
            value = np.asarray(value, dtype=float)
        except (TypeError, ValueError):
            raise ModelError(f"{who}: {name} must be a numeric vector of {nq} coordinates, got {value!r}.") from None
    if tuple(value.shape) != (nq,):
        raise ModelError(
            f"{who}: {name} has shape {tuple(value.shape)}; expected ({nq},) = {layout} coordinates "
            f"(position [m] and Euler parameters per part; {'their rates' if what == 'v' else 'not joint angles'}). "
            f"Start from {start}."
        )
    if not is_traced(value):
        arr = np.asarray(value, dtype=float)
        if not np.all(np.isfinite(arr)):
            k = int(np.flatnonzero(~np.isfinite(arr))[0])
            part = topo.body_names[k // 7] if k < 7 * topo.nbody else "modal coordinates"
            raise ModelError(f"{who}: {name}[{k}] is {arr[k]} (part '{part}'); every coordinate must be finite.")
    return value


def output_times(who: str, t_end, dt_output, t0, times):
    """Check the time arguments; returns nothing (simulate builds its own grid)."""
    t0 = _scalar(who, "t0", t0, unit="s")
    if times is not None:
        try:
            arr = np.asarray(times, dtype=float)
        except (TypeError, ValueError):
            raise ModelError(f"{who}: output_times must be a 1-D array of times [s], got {times!r}.") from None
        if arr.ndim != 1 or arr.size == 0:
            raise ModelError(f"{who}: output_times must be a non-empty 1-D array of times [s], got shape {arr.shape}.")
        if not np.all(np.isfinite(arr)):
            raise ModelError(f"{who}: output_times contains NaN or inf; give finite times [s].")
        if arr.size > 1 and np.any(np.diff(arr) <= 0):
            k = int(np.flatnonzero(np.diff(arr) <= 0)[0])
            raise ModelError(f"{who}: output_times must be strictly increasing; output_times[{k + 1}] = {arr[k + 1]:g} s "
                             f"follows {arr[k]:g} s. Sort them (np.unique).")
        if t0 != 0.0 and arr[0] < t0:
            raise ModelError(f"{who}: output_times[0] = {arr[0]:g} s is before t0 = {t0:g} s.")
        return
    t_end = _scalar(who, "t_end", t_end, unit="s", example="t_end=1.0")
    if not t_end > t0:
        raise ModelError(f"{who}: t_end = {t_end:g} s must be greater than t0 = {t0:g} s (the run goes from t0 to t_end).")
    if dt_output is None:
        return
    dt = _scalar(who, "dt_output", dt_output, unit="s", positive=True, example=f"dt_output={(t_end - t0) / 100:g}")
    if dt > (t_end - t0) * (1 + 1e-9):
        warn(f"{who}: dt_output = {dt:g} s is longer than the run ({t_end - t0:g} s): only t0 and t_end are "
             f"output. Give dt_output ≤ t_end − t0, e.g. {(t_end - t0) / 100:g}.")


def check_simulate(system, args: dict, who: str = "simulate"):
    """All of :func:`proleg.simulate`'s arguments; ``args`` is its ``locals()`` on entry (keys that
    are absent are not checked, so the signature may change without touching this)."""
    _check_system(system, who)
    g = args.get
    output_times(who, g("t_end"), g("dt_output"), g("t0", 0.0), g("output_times"))
    for name in ("rtol", "atol", "atol_p"):
        if name in args:
            _scalar(who, name, g(name), positive=True, allow_none=True, example=f"{name}=1e-6")
    dt_min = _scalar(who, "dt_min", g("dt_min"), unit="s", positive=True, allow_none=True)
    dt_max = _scalar(who, "dt_max", g("dt_max"), unit="s", positive=True, allow_none=True)
    _scalar(who, "dt_init", g("dt_init"), unit="s", positive=True, allow_none=True)
    if dt_min is not None and dt_max is not None and not is_traced(dt_max) and dt_min > dt_max:
        raise ModelError(f"{who}: dt_min = {dt_min:g} s is above dt_max = {dt_max:g} s; give dt_min ≪ dt_max.")
    _scalar(who, "fixed_step", g("fixed_step"), unit="s", positive=True, allow_none=True)
    for name in ("max_newton", "chunk"):
        if name in args and g(name) is not None:
            _count(who, name, g(name))
    check_state(system, who, "q0", g("q0"), "q")
    check_state(system, who, "v0", g("v0"), "v")
    if g("store") is not None:
        if _any_traced_params(system) or is_traced(g("q0")) or is_traced(g("v0")):
            raise ModelError(f"{who}: store= streams chunks from Python and is not available under jax.vmap/jit/grad; "
                             "use proleg.sweep or proleg.study (its store) for batches.")
        writable(g("store"), f"{who}(store=...)", folder=True)
    span = _span(g("t_end"), g("dt_output"), g("t0", 0.0), g("output_times"))
    if span is None:
        return
    t_span, dt_out = span
    # A fixed_step need not divide the output interval: outputs come from the steps' dense output
    # (solvers/driver.py), so steps are never shortened to output times.
    if not _any_traced_params(system):
        dt_max_eff = dt_max if dt_max is not None else min(t_span, 1e-2)  # simulate's default
        stiffness_warnings(system, dt_max_eff, dt_min if dt_min is not None else 1e-10, who)
        # Once per run: a sweep or study checks here before its batches, whose own simulate
        # calls see traced parameters and stay quiet (one warning, not one per batch).
        contact_warnings(system, g("q0"), who)


def _span(t_end, dt_output, t0, times):
    try:
        if times is not None:
            arr = np.asarray(times, float)
            if arr.size < 2:
                return None
            return float(arr[-1] - arr[0]), float(np.min(np.diff(arr)))
        span = float(t_end) - float(t0)
        return span, float(dt_output) if dt_output is not None else span / 500.0
    except (TypeError, ValueError):  # traced times: nothing more to check
        return None


def _any_traced_params(system) -> bool:
    return any(is_traced(v) for v in system.params.values())


def _check_system(system, who: str):
    import jax

    from ..assembly.system import System

    if not jax.config.jax_enable_x64:
        raise ModelError(
            f"{who}: JAX's float64 mode (jax_enable_x64) was switched off after `import proleg`; proleg's "
            "solvers need float64 (tolerances near 1e-10 and constraint drift near 1e-12 are below float32's "
            "resolution). Leave jax_enable_x64 on; give your own arrays dtype=jnp.float32 where you want float32 "
            "(docs/global-settings.md)."
        )

    if not isinstance(system, System):
        hint = " Assemble it first: system = proleg.assemble(model)." if type(system).__name__ == "Model" else ""
        raise ModelError(f"{who}: expected a System (proleg.assemble(model)), got {type(system).__name__}.{hint}")


def check_linearize(system, state, t, who: str = "linearize"):
    _check_system(system, who)
    _scalar(who, "t", t, unit="s")
    if state is not None and not hasattr(state, "lam"):
        check_state(system, who, "state", state, "q")


def check_equilibrium(system, q_guess, t, tol, max_iter, who: str = "solve_equilibrium"):
    _check_system(system, who)
    _scalar(who, "t", t, unit="s")
    _scalar(who, "tol", tol, positive=True, example="tol=1e-10")
    _count(who, "max_iter", max_iter)
    check_state(system, who, "q_guess", q_guess, "q")


# ---------------------------------------------------------------------------------------------
# element stiffness against the step
# ---------------------------------------------------------------------------------------------
def element_periods(system) -> list[tuple[str, float, str]]:
    """(element description, natural period [s], part) of each spring, bushing and contact,
    each on its lightest attached part (the other end held: ground counts as infinite mass).

    Contacts are linearised at their static sag under the part's weight, δ = (m g / k)^(1/e),
    k_lin = e k δ^(e−1). Read from the model (plain numbers; a sweep's traced values are not seen).
    """
    model = system.topo.model
    if model is None:
        return []
    g = float(np.linalg.norm(np.asarray(model.gravity, float))) or 9.81

    def mass(part):
        if part is None or part is model.ground or getattr(part, "is_flexible", False):
            return math.inf, math.inf
        J = np.asarray(getattr(part, "inertia", np.eye(3)))
        return float(part.mass), float(np.min(np.linalg.eigvalsh(J)))

    def reduced(a, b):
        return 1.0 / (1.0 / a + 1.0 / b) if math.isfinite(a) or math.isfinite(b) else math.inf

    out = []
    for e in model.forces:
        k = getattr(e, "stiffness", None)
        i, j = getattr(e, "i", None), getattr(e, "j", None)
        if (i is None or j is None) and getattr(e, "joint", None) is not None:
            i, j = getattr(e.joint, "marker_i", None), getattr(e.joint, "marker_j", None)
        if k is None or i is None or j is None or not hasattr(i, "part"):
            continue
        (m1, I1), (m2, I2) = mass(i.part), mass(j.part)
        K = np.asarray(k, float)
        lighter = i.part if m1 <= m2 else j.part
        if e.kind == "spring_damper":
            pairs = [(float(K), reduced(m1, m2), "N/m")]
        elif e.kind == "bushing":
            Kd = np.abs(np.diag(K)) if K.ndim == 2 else np.abs(K)
            pairs = [(float(Kd[:3].max()), reduced(m1, m2), "N/m"), (float(Kd[3:].max()), reduced(I1, I2), "N m/rad")]
        elif e.kind in ("rotational_spring_damper", "rotational_backlash"):
            pairs = [(float(K), reduced(I1, I2), "N m/rad")]
        else:
            continue
        for kk, mm, unit in pairs:
            if kk > 0 and math.isfinite(mm) and mm > 0:
                out.append((f"{type(e).__name__} '{e.name}' stiffness {kk:.3g} {unit}", 2 * math.pi / math.sqrt(kk / mm), lighter.name))
    for c in getattr(model, "contacts", []):
        part = c.marker.part
        other = c.plane.part if getattr(c, "plane", None) is not None else None
        m = reduced(mass(part)[0], mass(other)[0])
        if not (math.isfinite(m) and m > 0 and c.stiffness > 0):
            continue
        e = float(c.exponent)
        delta = (m * g / c.stiffness) ** (1.0 / e)
        k_lin = e * c.stiffness * delta ** (e - 1.0)
        out.append((f"{type(c).__name__} '{c.name}' stiffness {c.stiffness:.3g} N/m^{e:g}", 2 * math.pi / math.sqrt(k_lin / m), part.name))
    return out


def stiffness_warnings(system, dt_max: float, dt_min: float, who: str = "simulate"):
    """A ProlegWarning for each element whose natural period is below STIFF_PERIOD_RATIO · dt_max
    (the step will collapse while it is excited) or whose resolving step is below dt_min."""
    for what, T, part in element_periods(system):
        h = T / STEPS_PER_PERIOD
        if h < dt_min:
            warn(f"{who}: {what} on part '{part}' has a natural period of {T:.3g} s; resolving it needs steps near "
                 f"{h:.2g} s, below dt_min = {dt_min:g} s, so the run will stop (step too small). Check its units, or "
                 "lower dt_min.")
        elif T < STIFF_PERIOD_RATIO * dt_max or T < STIFF_PERIOD_MIN:
            warn(f"{who}: {what} on part '{part}' has a natural period of {T:.3g} s ({dt_max / T:.3g}× below "
                 f"dt_max = {dt_max:g} s): while it is excited the step collapses to ~{h:.2g} s. Check its units "
                 "(N/m, N m/rad), or soften it.")


# ---------------------------------------------------------------------------------------------
# contacts that start inside their plane
# ---------------------------------------------------------------------------------------------
def initial_penetrations(system, q0=None) -> list[tuple[str, float, float, float]]:
    """(contact description, depth [m], its ``penetration`` [m], elastic force k·depth^e [N]) of
    every contact that starts inside its plane (depth > 0), at ``q0`` (absolute coordinates,
    (nq,)) or else the system's initial coordinates.

    The gap is the contact law's own (assembly/extensions.py ``ContactGroup._law``), evaluated in
    NumPy from the parts' positions and quaternions: depth = −n·(p − o), p the sphere's (or
    cylinder's) point nearest the plane, o and n the plane marker's origin and z axis. A flexible
    part's markers are taken at zero modal coordinates. Contact constants are the model's (a
    sweep's traced values are not seen); traced coordinates are not checked.
    """
    from ..spatial.rotation import A_of_p

    topo = system.topo
    model = topo.model
    contacts = list(getattr(model, "contacts", []) or [])
    if model is None or not contacts:
        return []
    q = q0 if q0 is not None else system.params.get("q_init")
    if q is None or is_traced(q):
        return []
    q = np.asarray(q, float)
    nb = topo.nbody
    if q.ndim != 1 or q.size < 7 * nb:
        return []
    index = {name: k for k, name in enumerate(topo.body_names)}

    def frame(marker):
        k = index.get(marker.part.name)
        if k is None:  # ground
            return np.asarray(marker.position, float), np.asarray(marker.orientation, float)
        r, p = q[7 * k : 7 * k + 3], q[7 * k + 3 : 7 * k + 7]
        A = np.asarray(A_of_p(p / np.linalg.norm(p)), float)
        return r + A @ np.asarray(marker.local_position, float), A @ np.asarray(marker.local_orientation, float)

    out = []
    for c in contacts:
        (pc, RI), (o, RP) = frame(c.marker), frame(c.plane)
        n = RP[:, 2]
        if c.kind == "cylinder":
            a = RI[:, 2]
            u = n - (n @ a) * a
            dirn = u / np.sqrt(u @ u + 1e-300)
        else:
            dirn = n
        depth = float(-(n @ (pc - float(c.radius) * dirn - o)))
        if depth > 0:
            out.append((f"{type(c).__name__} '{c.name}'", depth, float(c.penetration), float(c.stiffness) * depth ** float(c.exponent)))
    return out


# A contact resting under the model's weight sits at its static sag, which may exceed its
# `penetration` (a 1 kg block on 1e5 N/m^1.5 corners: 0.18 mm against 0.1 mm); it is not warned
# unless its elastic force exceeds this multiple of the whole model's weight.
BURIED_WEIGHTS = 2.0


def contact_warnings(system, q0=None, who: str = "simulate"):
    """A ProlegWarning for each contact that starts deeper in its plane than its ``penetration``
    (the depth of full damping) and pushes with more than BURIED_WEIGHTS times the model's weight
    (k·depth^e at t = 0): the sign of a model placed in the ground (a URDF base at the origin, a
    foot below z = 0), not on it. A model resting at its static sag is not warned."""
    model = system.topo.model
    weight = 0.0
    if model is not None:
        g = float(np.linalg.norm(np.asarray(model.gravity, float)))
        weight = g * sum(float(getattr(p, "mass", 0.0)) for p in model.parts)
    for what, depth, pen, force in initial_penetrations(system, q0):
        if depth > pen and force > BURIED_WEIGHTS * weight:
            share = f" ({force / weight:.3g}× the model's weight)" if weight > 0 else ""
            warn(f"{who}: {what} starts {depth:.4g} m inside its plane, deeper than its penetration depth "
                 f"{pen:.3g} m: at t = 0 it pushes with {force:.3g} N{share}. Place the part on the plane (move it up by "
                 f"{depth:.4g} m; load_urdf places a floating base on its feet unless base_position/base_height is given).")


# ---------------------------------------------------------------------------------------------
# files
# ---------------------------------------------------------------------------------------------
def writable(path, who: str = "to_parquet", folder: bool = False) -> Path:
    """Create the parent folder of ``path`` and check that a file can be written there (before
    any compute); DataError naming the path and the reason otherwise. ``folder=True``: ``path``
    is a folder to hold files (``simulate``'s store); returns its first file's path."""
    try:
        path = Path(os.fspath(path))
    except TypeError:
        raise DataError(f"{who}: the output path must be a str or os.PathLike, got {path!r}.") from None
    if folder:
        path = path / "part-00000.parquet"
    if path.is_dir():
        raise DataError(f"{who}: '{path}' is a folder; give a file name such as '{path / 'result.parquet'}'.")
    if path.exists() and not os.access(path, os.W_OK):
        raise DataError(f"{who}: '{path}' exists and is read-only. Choose another name or make it writable.")
    parent = path.parent
    blocker = next((a for a in [parent, *parent.parents] if a.exists() and not a.is_dir()), None)
    if blocker is not None:
        raise DataError(f"{who}: cannot write to '{path}': '{blocker}' is a file, not a folder. Choose another path.")
    try:
        parent.mkdir(parents=True, exist_ok=True)
        probe = parent / f".proleg-probe-{uuid.uuid4().hex[:8]}"
        probe.write_bytes(b"")
        probe.unlink()
    except OSError as exc:
        raise DataError(f"{who}: cannot write to '{path}' ({exc.strerror or exc}). Choose a writable folder.") from None
    return path


# ---------------------------------------------------------------------------------------------
# parameter values of sweeps (the constructors' physical checks, per variant)
# ---------------------------------------------------------------------------------------------
# (suffix of the parameter array, rule, unit): "positive" > 0, "nonnegative" ≥ 0 (the diagonal of
# a matrix), "inertia" a physical inertia tensor.
_RULES = [
    ("body_mass", "positive", "kg"),
    ("body_inertia", "inertia", "kg m^2"),
    ("contact_stiffness", "positive", "N/m^e"),
    ("contact_penetration", "positive", "m"),
    ("_period", "positive", "s"),
    ("_stiffness", "nonnegative", ""),
    ("_damping", "nonnegative", ""),
    ("_free_length", "nonnegative", "m"),
    ("_radius", "nonnegative", "m"),
    ("_mu_static", "nonnegative", "-"),
    ("_mu_dynamic", "nonnegative", "-"),
    ("_half_gap", "nonnegative", "rad"),
]


def _violation(rule: str, x: np.ndarray) -> str | None:
    if rule == "inertia":
        J = x.reshape(-1, 3, 3) if x.shape[-2:] == (3, 3) else np.stack([np.diag(r) for r in x.reshape(-1, 3)])
        return next((p for p in map(inertia_problem, J) if p is not None), None)
    d = np.diagonal(x, axis1=-2, axis2=-1) if x.ndim >= 2 and x.shape[-1] == x.shape[-2] == 6 else x
    bad = (d <= 0) if rule == "positive" else (d < 0)
    if np.any(bad):
        v = float(np.asarray(d)[bad].ravel()[0])
        return f"has {v:g}; it must be {'positive' if rule == 'positive' else 'non-negative'}"
    return None


def check_sweep_values(system, values: dict, who: str = "sweep"):
    """The model's physical checks on every variant's values; ModelError naming the variant index,
    the parameter and the rule (e.g. a negative mass in variant 3)."""
    for name, arr in values.items():
        pname, _ = system._locate(name)
        rule = next(((r, u) for suffix, r, u in _RULES if pname.endswith(suffix)), None)
        if rule is None:
            continue
        for i in range(arr.shape[0]):
            why = _violation(rule[0], np.asarray(arr[i], float))
            if why is not None:
                unit = f" [{rule[1]}]" if rule[1] else ""
                raise ModelError(f"{who}: variant {i}: '{name}'{unit} {why}. Fix or drop variant {i}.")
