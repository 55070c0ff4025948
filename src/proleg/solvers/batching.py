"""Batch-wide decisions inside ``jax.vmap``.

Under ``jax.vmap`` a ``lax.cond`` whose predicate differs between lanes becomes a ``select``:
both branches run for every lane on every call. For work that is only worth doing now and then
(rebuilding the Newton matrix) that defeats the purpose. :func:`any_lane` returns its boolean
argument unchanged outside ``vmap``; inside, it returns one unbatched value, "true in any lane",
so the ``lax.cond`` it feeds stays a real branch and all lanes take it together (a lane that
did not need a fresh Newton matrix gets one anyway, which is never wrong).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp


@jax.custom_batching.custom_vmap
def any_lane(pred):
    """``pred`` itself; under ``jax.vmap`` the OR over the batch, unbatched."""
    return pred


@any_lane.def_vmap
def _any_lane_vmap(axis_size, in_batched, pred):
    (batched,) = in_batched
    return (jnp.any(pred) if batched else pred), False
