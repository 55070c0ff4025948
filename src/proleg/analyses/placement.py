"""Where a single analysis runs: the CPU, even where JAX's default device is a GPU.

One simulation step is a few hundred microsecond-sized kernels, which a GPU launches one at a
time: on an H100 host a single 1 s run of the 2-link bench model took 227.7 ms on the GPU
against 28.7 ms on the host's CPU (bench/README.md), while batches (``sweep``, the user's
``vmap``) belong on the GPU. :func:`placed` gives ``simulate``, ``solve_equilibrium`` and
``linearize`` a ``device=`` keyword for that choice.
"""

from __future__ import annotations

import functools
import inspect

import jax


def is_traced(x) -> bool:
    return isinstance(x, jax.core.Tracer)


def _any_traced(tree) -> bool:
    return any(is_traced(x) for x in jax.tree_util.tree_leaves(tree))


def run_device(device, traced: bool, who: str = "simulate"):
    """The device an analysis is placed on, or None for JAX's own placement.

    ``device`` None ("auto"): the CPU when JAX's default backend is another one (a GPU) and the
    call is not inside the user's ``jit``/``vmap`` (``traced``). A platform name ("cpu", "gpu",
    "cuda", ...) or a ``jax.Device`` picks one; "default" leaves JAX's placement.
    """
    if device is None:
        if traced or jax.default_backend() == "cpu":
            return None
        try:
            return jax.devices("cpu")[0]
        except RuntimeError:  # no CPU backend in this process
            return None
    if isinstance(device, str):
        if device == "default":
            return None
        try:
            return jax.devices(device)[0]
        except RuntimeError as exc:
            raise ValueError(
                f"{who}: device={device!r} is not available here ({exc}). Expected None (automatic: the CPU for a "
                f"single run), 'default', a platform JAX has ({jax.default_backend()!r} here) or a jax.Device."
            ) from None
    if isinstance(device, jax.Device):
        return device
    raise TypeError(f"{who}: device must be None, a platform name or a jax.Device, got {type(device).__name__}.")


def placed(fn):
    """Add ``device=None`` to ``fn(system, ...)`` and run it under
    ``jax.default_device(run_device(device, ...))``. Whether the call is traced is read from
    the system's parameters and the array arguments."""

    @functools.wraps(fn)
    def wrapper(system, *args, device=None, **kw):
        traced = _any_traced((getattr(system, "params", None), args, kw))
        dev = run_device(device, traced, fn.__name__)
        if dev is None:
            return fn(system, *args, **kw)
        with jax.default_device(dev):
            return fn(system, *args, **kw)

    sig = inspect.signature(fn)
    extra = inspect.Parameter("device", inspect.Parameter.KEYWORD_ONLY, default=None)
    params = list(sig.parameters.values())
    at = next((k for k, p in enumerate(params) if p.kind == inspect.Parameter.VAR_KEYWORD), len(params))
    wrapper.__signature__ = sig.replace(parameters=[*params[:at], extra, *params[at:]])
    return wrapper
