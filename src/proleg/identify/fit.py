"""Parameter identification through the differentiable simulator.

Fit chosen parameters of an assembled :class:`~proleg.System` (actuator k and c, bushing or
contact stiffness, masses, ...) to measured time series by Levenberg–Marquardt
(``scipy.optimize.least_squares``) with the Jacobian from ``jax.jacfwd`` through the whole
simulation. Positive parameters are fitted in log scale; standard errors and correlations come
from the Jacobian at the optimum (s² (JᵀJ)⁻¹, s² = SSR / (m − n)).
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

import jax
import jax.numpy as jnp
import numpy as np

from ..errors import DataError, ModelError


def signal(spec: str):
    """A function Result → (n,) from a short spec.

    ``part.x|y|z`` (COM position [m]), ``part.vx|vy|vz`` [m/s], ``joint.angle`` [rad],
    ``joint.translation`` [m], ``joint.Fx|Fy|Fz`` [N], ``element.output`` or
    ``element.output[k]`` (any force-element / contact / actuator output, e.g.
    ``foot.normal_force``, ``hip_actuator.axial_force``).
    """
    m = re.fullmatch(r"(.+)\.([A-Za-z_]+)(?:\[(\d+)\])?", spec.strip())
    if not m:
        raise ModelError(f"Signal '{spec}': expected 'element.quantity' (e.g. 'mass.z', 'knee.angle', 'foot.normal_force').")
    name, qty, idx = m.group(1), m.group(2), m.group(3)
    axes = {"x": 0, "y": 1, "z": 2}

    def f(res):
        topo = res.system.topo
        if name in topo.body_names:
            pr = res.part(name)
            if qty in axes:
                return pr.position[:, axes[qty]]
            if qty[0] == "v" and qty[1:] in axes:
                return pr.velocity[:, axes[qty[1:]]]
            raise ModelError(f"Signal '{spec}': parts have x, y, z, vx, vy, vz.")
        owners = [o.name for o in topo.ct.owners]
        if name in owners:
            jr = res.joint(name)
            if qty in ("angle", "translation"):
                return getattr(jr, qty)
            if qty[0] in "FT" and qty[1:] in axes:
                return (jr.force if qty[0] == "F" else jr.torque)[:, axes[qty[1:]]]
            raise ModelError(f"Signal '{spec}': joints have angle, translation, Fx..Fz, Tx..Tz.")
        out = res.element(name)[qty]
        return out if idx is None else out[:, int(idx)]

    f.spec = spec
    return f


@dataclass
class FitResult:
    """Outcome of :func:`fit`: values, standard errors, correlations, convergence report."""

    names: list
    values: np.ndarray
    stderr: np.ndarray
    correlation: np.ndarray
    initial: np.ndarray
    cost: float
    rms: float
    iterations: int
    success: bool
    message: str
    residuals: np.ndarray
    system: object = None
    history: list = field(default_factory=list)

    def table(self):
        import pandas as pd

        return pd.DataFrame({"parameter": self.names, "initial": self.initial, "value": self.values, "stderr": self.stderr, "rel. stderr [%]": 100 * self.stderr / np.abs(self.values)})

    def __repr__(self):
        rows = ", ".join(f"{n} = {v:.6g} ± {s:.2g}" for n, v, s in zip(self.names, self.values, self.stderr))
        return f"FitResult({rows}; rms {self.rms:.3g}, {self.iterations} evaluations, {self.message})"


def fit(
    system,
    params: list[str],
    times,
    measured: dict,
    *,
    initial: dict | None = None,
    bounds: dict | None = None,
    log_scale: bool | list = True,
    weights: dict | None = None,
    simulate_kw: dict | None = None,
    max_nfev: int = 50,
    verbose: bool = False,
) -> FitResult:
    """Fit ``params`` of ``system`` so that simulated signals match ``measured`` at ``times``.

    Parameters
    ----------
    params : names accepted by ``System.with_params`` (e.g. ``"spring.stiffness"``)
    times : (m,) [s] measurement times (the simulation outputs exactly there; times[0] = start)
    measured : dict signal spec (see :func:`signal`) or callable(Result) → (m,) array of measurements
    initial : starting values (default: the system's current values)
    bounds : dict name → (lo, hi) in physical units
    log_scale : fit log(p) for positive parameters (True for all, or a list of names)
    weights : dict signal → 1/σ scale (default 1 / RMS of that measured signal)
    """
    from ..analyses.simulate import simulate, simulate_kwargs

    times = np.asarray(times, float)
    if times.ndim != 1 or len(times) < 2 or np.any(np.diff(times) <= 0):
        raise DataError("fit: times must be a strictly increasing 1D array with at least 2 samples.")
    sigs, meas, w = [], [], []
    for key, y in measured.items():
        fn = key if callable(key) else signal(key)
        y = np.asarray(y, float)
        if y.shape != times.shape:
            raise DataError(f"fit: measured signal '{getattr(fn, 'spec', key)}' has shape {y.shape}; expected {times.shape} (one value per time).")
        if not np.all(np.isfinite(y)):
            row = int(np.argmax(~np.isfinite(y)))
            raise DataError(f"fit: measured signal '{getattr(fn, 'spec', key)}' has NaN/inf at sample {row + 1}.")
        sigs.append(fn)
        meas.append(y)
        scale = (weights or {}).get(key)
        w.append(float(scale) if scale is not None else 1.0 / max(np.sqrt(np.mean(y**2)), 1e-300))
    p0 = np.array([float((initial or {}).get(n, system.get(n))) for n in params])
    logs = np.array([(log_scale is True or (isinstance(log_scale, list) and n in log_scale)) and p0[k] > 0 for k, n in enumerate(params)])
    to_phys = lambda th: jnp.where(logs, jnp.exp(th), th)
    th0 = np.where(logs, np.log(np.abs(p0) + 1e-300), p0)
    lo = np.full(len(params), -np.inf)
    hi = np.full(len(params), np.inf)
    for k, n in enumerate(params):
        if bounds and n in bounds:
            a, b = bounds[n]
            lo[k] = np.log(a) if logs[k] and a > 0 else (a if not logs[k] else -np.inf)
            hi[k] = np.log(b) if logs[k] else b
    skw = dict(t_end=float(times[-1]), output_times=times, progress=False)
    skw = simulate_kwargs({**skw, **(simulate_kw or {})})
    meas_j = [jnp.asarray(y) for y in meas]

    def residual(th):
        p = to_phys(th)
        s = system.with_params({n: p[k] for k, n in enumerate(params)})
        res = simulate(s, **skw)
        return jnp.concatenate([wk * (f(res) - y) for f, y, wk in zip(sigs, meas_j, w)])

    # One compilation each for the residual and its Jacobian (the simulation is traced through).
    jac = jax.jit(jax.jacfwd(residual))
    residual = jax.jit(residual)
    history = []

    def fun(th):
        r = np.asarray(residual(jnp.asarray(th)))
        history.append((np.asarray(to_phys(jnp.asarray(th))), float(0.5 * r @ r)))
        if verbose:
            print(f"  eval {len(history)}: {dict(zip(params, history[-1][0]))} cost {history[-1][1]:.6g}")
        return r

    def jfun(th):
        return np.asarray(jac(jnp.asarray(th)))

    import scipy.optimize

    sol = scipy.optimize.least_squares(fun, th0, jac=jfun, bounds=(lo, hi), method="trf", x_scale="jac", max_nfev=max_nfev, xtol=1e-10, ftol=1e-12, gtol=1e-12)
    p = np.asarray(to_phys(jnp.asarray(sol.x)))
    J = sol.jac * np.where(logs, 1.0 / p, 1.0)[None, :]  # d r / d p
    m, n = J.shape
    s2 = 2 * sol.cost / max(m - n, 1)
    try:
        cov = s2 * np.linalg.inv(J.T @ J)
    except np.linalg.LinAlgError:
        cov = np.full((n, n), np.nan)
    se = np.sqrt(np.clip(np.diag(cov), 0, None))
    corr = cov / np.outer(se, se) if np.all(se > 0) else np.full((n, n), np.nan)
    return FitResult(
        names=list(params), values=p, stderr=se, correlation=corr, initial=p0, cost=float(sol.cost),
        rms=float(np.sqrt(2 * sol.cost / m)), iterations=int(sol.nfev), success=bool(sol.success), message=str(sol.message),
        residuals=sol.fun, system=system.with_params({nm: p[k] for k, nm in enumerate(params)}), history=history,
    )


def plot_fit(fit_result: FitResult, times, measured: dict, simulate_kw: dict | None = None):
    """Overlay of measured and fitted signals (matplotlib Figure)."""
    from matplotlib.figure import Figure

    from ..analyses.simulate import simulate, simulate_kwargs

    times = np.asarray(times, float)
    res = simulate(fit_result.system, t_end=float(times[-1]), output_times=times, progress=False, **simulate_kwargs(simulate_kw or {}))
    fig = Figure(figsize=(7, 2.4 * len(measured)))
    for k, (key, y) in enumerate(measured.items()):
        ax = fig.add_subplot(len(measured), 1, k + 1)
        fn = key if callable(key) else signal(key)
        ax.plot(times, y, ".", ms=2, label="measured")
        ax.plot(times, np.asarray(fn(res)), "-", label="fitted")
        ax.set_ylabel(getattr(fn, "spec", str(key)))
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    fig.axes[-1].set_xlabel("time [s]")
    return fig
