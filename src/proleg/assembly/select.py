"""Static row selections (the "one-hot" matrices of the vectorised element groups).

``S = Select(idx, n)`` stands for the constant (len(idx), n) matrix with a single 1 per row at
column ``idx[k]``: ``S @ x`` is ``x[idx]`` (a gather with constant indices) and ``S.T @ y`` sums
the rows of y that pick each column: a gather of y through a padded (n, kmax) table of those
rows (out-of-range pads read 0) and a sum over kmax. That is a scatter-add written as a gather:
XLA-CPU scatters run element by element (22 µs for a (6, 8, 3) scatter-add of the tangents in
the Newton-matrix build of a 7-part chain), a gather + reduce fuses into one loop (~1 µs).
Measured on XLA-CPU (JAX 0.10, bench/README.md): a
gather plus scatter-add of 21 rows of (14, 3) costs 0.2 µs inside a compiled loop against
3.8 µs for the same selection done with dense one-hot matmuls, and the gap grows with the
model (the matmuls are O(rows × markers), the gather O(rows)). Under ``jax.vmap`` on CPU the
batched gathers are no faster per lane than single ones (bench/README.md, vmap_batch.py).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np


class Select:
    """Constant selection matrix (rows pick entries ``idx`` out of ``n``)."""

    __slots__ = ("idx", "n", "_table")

    def __init__(self, idx, n: int):
        self.idx = np.asarray(idx, dtype=np.int32).reshape(-1)
        self.n = int(n)
        if self.idx.size and (self.idx.min() < 0 or self.idx.max() >= self.n):
            raise IndexError(f"Select: indices must be in [0, {self.n}), got {self.idx.min()}..{self.idx.max()}.")
        self._table = None

    def _fingerprint_state(self):
        """What defines the selection (proleg.compile_cache): ``table`` is derived from it."""
        return self.idx, self.n

    @property
    def table(self) -> np.ndarray:
        """(n, kmax) rows k with idx[k] == column, padded with len(idx) (out of range: reads 0)."""
        if self._table is None:
            m = self.idx.size
            counts = np.bincount(self.idx, minlength=self.n) if m else np.zeros(self.n, int)
            kmax = max(int(counts.max()) if self.n else 0, 1)
            tab = np.full((self.n, kmax), m, np.int32)
            fill = np.zeros(self.n, int)
            for k, j in enumerate(self.idx):
                tab[j, fill[j]] = k
                fill[j] += 1
            self._table = tab
        return self._table

    @property
    def shape(self):
        return (self.idx.size, self.n)

    def __len__(self):
        return self.idx.size

    def __matmul__(self, x):
        # One gather with constant in-range indices (x[idx] would also trace the wrap-around of
        # negative indices: three more equations per selection, bench/trace_size.py).
        if isinstance(x, np.ndarray) or self.idx.size == 0:
            return x[self.idx]
        return _rows(jnp.asarray(x), self.idx)

    @property
    def T(self):
        return _Scatter(self)


class _Scatter:
    __slots__ = ("s",)

    def __init__(self, s: Select):
        self.s = s

    def __matmul__(self, y):
        if self.s.idx.size == 0:
            return jnp.zeros((self.s.n,) + y.shape[1:], y.dtype)
        return jnp.sum(_rows(jnp.asarray(y), self.s.table, fill=True), axis=1)


def _rows(x, idx, fill: bool = False):
    """x[idx] for constant indices (any shape) along axis 0 as one gather: in range (or, with
    ``fill``, 0 where out of range), without the wrap-around of negative indices that
    ``x[idx]`` / ``jnp.take`` trace (three to five more equations per call, bench/trace_size.py)."""
    dn = jax.lax.GatherDimensionNumbers(
        offset_dims=tuple(range(idx.ndim, idx.ndim + x.ndim - 1)), collapsed_slice_dims=(0,), start_index_map=(0,)
    )
    mode = jax.lax.GatherScatterMode.FILL_OR_DROP if fill else jax.lax.GatherScatterMode.PROMISE_IN_BOUNDS
    return jax.lax.gather(x, idx[..., None], dn, (1,) + x.shape[1:], mode=mode, fill_value=0 if fill else None)
