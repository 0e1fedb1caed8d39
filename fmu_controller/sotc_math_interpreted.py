"""The interpreted build's twin of ``sotc_math``: its loops as numpy operations over whole arrays, to the
bits of the loops (the same elementwise products, no fused multiply-add, every sum in the loops' order).
Only the interpreted ``sotc_math`` imports it; ``tests/unit/test_interpreted_paths.py`` compares the two."""
from __future__ import annotations

from array import array
from functools import lru_cache

import numpy as np

from fmu_numerics.fixed_linalg_interpreted import in_order


@lru_cache(maxsize=None)
def lower_masks(n: int) -> tuple[np.ndarray, np.ndarray]:
    """The entries (a, k), k <= a, of an n x n matrix, and its diagonal, as boolean masks (made once per n)."""
    return np.tril(np.ones((n, n), dtype=bool)), np.eye(n, dtype=bool)


def implicit_system_array(W: array, wdot: array, xi: array, eta: array, M: array, with_cl: bool, dt: float,
                          c: float, G: array, rhs: array) -> None:
    """``implicit_system``'s loops as numpy operations, the same bits: the same elementwise products and
    sums (no fused multiply-add), G's lower triangle mirrored as there, and (G W)_a summed over k in order
    (``fixed_linalg_interpreted.in_order``). N, the basis size, is rhs's length (one entry per basis term;
    the other buffers may be longer, and only their first N or N * N entries are read or written)."""
    N = len(rhs)
    lower, diagonal = lower_masks(N)
    with np.errstate(all="ignore"):  # an overflow gives inf silently, as the loops do
        g = np.multiply.outer(np.frombuffer(xi, count=N), np.frombuffer(eta, count=N))
        if with_cl:
            g = g + np.frombuffer(M, count=N * N).reshape(N, N)
        g = c * g
        Gv = np.where(lower, g, g.T)
        Wv = np.frombuffer(W, count=N)
        np.frombuffer(rhs, count=N)[:] = Wv + dt * np.frombuffer(wdot, count=N) + in_order(Gv * Wv, 1)
        Gv[diagonal] += 1.0
        np.frombuffer(G, count=N * N)[:] = Gv.ravel()
