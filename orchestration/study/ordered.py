"""Linear algebra for the numbers the docs, the README and the stored results print, in one fixed order.

numpy's ``@``, ``dot``, ``linalg.norm`` and ``linalg.eigvalsh`` and scipy's ``linalg`` go to BLAS and
LAPACK, whose kernels (chosen per CPU, or by ``OPENBLAS_CORETYPE``) block, vectorise and fuse
differently, so their last bits differ from one machine to the next; a stored figure computed through
them once differed in 1-3 ulps between two kernels of the same machine (``docs/perturbed.json``, the
value study's LQR row). Every function here runs the textbook loop in one written order on
``fmu_numerics.fixed_linalg``'s kernels (the controllers' own, compiled or not, with the same bits):
the same result on every CPU. ``tests/unit/test_ordered.py`` checks them against numpy to rounding, and
``tests/docs/test_no_blas.py`` that nothing else in ``orchestration/`` calls BLAS or LAPACK.
"""
from __future__ import annotations

import math
from typing import Sequence

import numpy as np

from fmu_numerics.fixed_linalg import EPS, buffer, dot_sequence, smallest_eigenvalue


def norm(x: Sequence[float]) -> float:
    """The Euclidean norm sqrt(sum_k x_k^2), summed left to right."""
    v = [float(a) for a in np.ravel(x)]
    return math.sqrt(dot_sequence(v, v))


def weighted_squares(z: np.ndarray, weights: Sequence[float]) -> np.ndarray:
    """sum_j w_j z_ij^2 for every row i of z, over j left to right (``z ** 2 @ w`` without BLAS)."""
    z = np.asarray(z, dtype=float)
    out = np.zeros(z.shape[0])
    for j, w in enumerate(weights):  # elementwise numpy: one rounding per operation, in this order
        out += z[:, j] * z[:, j] * float(w)
    return out


def product(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The matrix product a b, each entry a left-to-right sum of products."""
    a, b = np.atleast_2d(np.asarray(a, dtype=float)), np.atleast_2d(np.asarray(b, dtype=float))
    if a.shape[1] != b.shape[0]:
        raise ValueError(f"product: shapes {a.shape} and {b.shape} do not chain")
    cols = [b[:, j].tolist() for j in range(b.shape[1])]
    return np.array([[dot_sequence(row, col) for col in cols] for row in a.tolist()]).reshape(a.shape[0], b.shape[1])


def eigvalsh(m: np.ndarray) -> np.ndarray:
    """Every eigenvalue of the symmetric m, ascending: Householder tridiagonalisation and Sturm
    bisection (``fixed_linalg.smallest_eigenvalue``), each to within eps trace(m) (the rounding level)."""
    m = np.asarray(m, dtype=float)
    n = m.shape[0]
    if m.shape != (n, n) or n == 0:
        raise ValueError(f"eigvalsh: a square matrix, not of shape {m.shape}")
    flat = buffer(n * n)
    for k, v in enumerate(m.ravel().tolist()):
        flat[k] = v
    d, e, work, v, p = buffer(n), buffer(max(n - 1, 1)), buffer(n * n), buffer(n), buffer(n)
    return np.array([smallest_eigenvalue(flat, n, d, e, work, v, p, k) for k in range(1, n + 1)])


def _gram(m: np.ndarray) -> np.ndarray:
    """m^T m or m m^T, whichever is smaller."""
    m = np.atleast_2d(np.asarray(m, dtype=float))
    return product(m.T, m) if m.shape[0] >= m.shape[1] else product(m, m.T)


def singular_values(m: np.ndarray) -> np.ndarray:
    """The singular values of m, descending: the square roots of the eigenvalues of m^T m (``eigvalsh``),
    those below zero by rounding read as 0."""
    return np.array([math.sqrt(max(v, 0.0)) for v in eigvalsh(_gram(m))[::-1]])


def rank(m: np.ndarray) -> int:
    """The numerical rank: the eigenvalues of the Gram matrix (m^T m or m m^T) above max(shape) eps times
    the largest, i.e. singular values above sqrt(max(shape) eps) sigma_max (numpy's ``matrix_rank`` takes
    max(shape) eps sigma_max from an SVD; through the Gram matrix the squares set the rounding level)."""
    lam = eigvalsh(_gram(m))
    return int(sum(1 for v in lam if v > max(np.shape(np.atleast_2d(m))) * EPS * lam[-1]))
