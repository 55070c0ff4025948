"""Static row selections (the "one-hot" matrices of the vectorised element groups).

``S = Select(idx, n)`` stands for the constant (len(idx), n) matrix with a single 1 per row at
column ``idx[k]``: ``S @ x`` is ``x[idx]`` (a gather with constant indices) and ``S.T @ y`` is the
scatter-add ``segment_sum(y, idx, n)``. Measured on XLA-CPU (JAX 0.10, bench/README.md): a
gather plus scatter-add of 21 rows of (14, 3) costs 0.2 µs inside a compiled loop against
3.8 µs for the same selection done with dense one-hot matmuls, and the gap grows with the
model (the matmuls are O(rows × markers), the gather O(rows)). Under ``jax.vmap`` on CPU the
batched gathers are no faster per lane than single ones (bench/README.md, vmap_batch.py).
"""

from __future__ import annotations

import jax
import numpy as np


class Select:
    """Constant selection matrix (rows pick entries ``idx`` out of ``n``)."""

    __slots__ = ("idx", "n")

    def __init__(self, idx, n: int):
        self.idx = np.asarray(idx, dtype=np.int32).reshape(-1)
        self.n = int(n)
        if self.idx.size and (self.idx.min() < 0 or self.idx.max() >= self.n):
            raise IndexError(f"Select: indices must be in [0, {self.n}), got {self.idx.min()}..{self.idx.max()}.")

    @property
    def shape(self):
        return (self.idx.size, self.n)

    def __len__(self):
        return self.idx.size

    def __matmul__(self, x):
        return x[self.idx]

    @property
    def T(self):
        return _Scatter(self)


class _Scatter:
    __slots__ = ("s",)

    def __init__(self, s: Select):
        self.s = s

    def __matmul__(self, y):
        return jax.ops.segment_sum(y, self.s.idx, num_segments=self.s.n, indices_are_sorted=False)
