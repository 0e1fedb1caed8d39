"""``fixed_linalg.smallest_eigenvalue`` for the interpreted core, to its bits: the same Householder
reduction and Sturm bisection (Golub & Van Loan, Matrix Computations, 4th ed., 8.3.1 and 8.4.1), the
same operations in the same order, on Python lists.

Why: compiled, ``fixed_linalg``'s loops are C over C arrays; run as Python, every ``A[i * n + j]`` of a
float64 buffer computes an offset and makes a new float object, and the bisection counted the whole
Sturm sequence at each of its fifty or so halvings. Here the block still to reduce is a list of row
lists, one row and column shorter after each reflection (an entry is read without arithmetic or a new
object, no row is sliced twice; numpy was slower on blocks of 9 x 9 and less), the squares
e_i^2 of the Sturm recurrence are computed once (the products ``sturm_count`` forms at every count), and
the count of a halving stops as soon as it reaches k: the bisection only asks whether at least k
eigenvalues lie below the midpoint, and the later terms decide nothing. The interpreted ``fixed_linalg``
imports this module (the other twins take ``in_order`` from it);
``tests/unit/test_elementary_interpreted.py`` compares the two on hypothesis-drawn matrices.
"""
from __future__ import annotations

import math
from array import array

import numpy as np

EPS = 2.220446049250313e-16  # fixed_linalg.EPS (this module must not import the compiled one's C constants)


def _reflect_block(B: list) -> tuple:
    """``fixed_linalg._reflect`` on the trailing block B (rows and columns k .. n-1 as row lists): zero its
    first column below the subdiagonal; return the new subdiagonal entry and the reflected block of rows and
    columns k+1 .. n-1 (the next step's B)."""
    A22 = [row[1:] for row in B[1:]]
    col = [row[0] for row in B[1:]]
    scale = 0.0
    for x in col:
        scale += x * x
    if scale == 0.0:
        return 0.0, A22
    x0 = col[0]
    alpha = -math.sqrt(scale) if x0 >= 0.0 else math.sqrt(scale)
    v = col
    v[0] = x0 - alpha
    vv = 0.0
    for x in v:
        vv += x * x
    p = []
    for row in A22:  # p = 2 A22 v / |v|^2
        acc = 0.0
        for a, x in zip(row, v):
            acc += a * x
        p.append(2.0 * acc / vv)
    kk = 0.0
    for x, y in zip(v, p):
        kk += x * y
    kk /= vv
    p = [y - kk * x for x, y in zip(v, p)]  # q = p - (v^T p / |v|^2) v
    return alpha, [[a - (vi * pj + pi * vj) for a, pj, vj in zip(row, p, v)]  # A22 -= v q^T + q v^T
                   for row, vi, pi in zip(A22, v, p)]


def tridiagonalize(M: array, n: int, d: array, e: array) -> None:
    """``fixed_linalg.tridiagonalize``: M's tridiagonal form into d (n) and e (n - 1)."""
    B = [list(M[i * n:(i + 1) * n]) for i in range(n)]
    for k in range(n - 2):
        d[k] = B[0][0]
        e[k], B = _reflect_block(B)
    if n >= 2:
        d[n - 2] = B[0][0]
        e[n - 2] = B[1][0]
    d[n - 1] = B[-1][-1]


def count_reaches(d: list, e2: list, x: float, k: int) -> bool:
    """``fixed_linalg.sturm_count(d, e, n, x) >= k`` for e2 = [0.0, e_0 e_0, e_1 e_1, ...], stopping at the k-th
    negative term (the leading 0.0 makes the first term d_0 - x - 0.0 / 1.0, which is d_0 - x to the bit)."""
    count = 0
    q = 1.0
    for di, ei2 in zip(d, e2):
        q = di - x - ei2 / q
        if q == 0.0:
            q = -EPS * (abs(x) + 1e-300)
        if q < 0.0:
            count += 1
            if count >= k:
                return True
    return False


def bisect(d: list, e2: list, lo: float, hi: float, halvings: int, resolution: float, k: int) -> float:
    """``fixed_linalg.smallest_of_tridiagonal``'s bisection from its Gershgorin interval [lo, hi], at most
    ``halvings`` + 2 halvings, on the lists d (n) and e2 (n, ``count_reaches``)."""
    for _ in range(halvings + 2):
        if hi - lo <= resolution:
            break
        mid = 0.5 * (lo + hi)
        if mid <= lo or mid >= hi:
            break
        if count_reaches(d, e2, mid, k):
            hi = mid
        else:
            lo = mid
    return 0.5 * (lo + hi)


def in_order(terms: np.ndarray, axis: int) -> np.ndarray:
    """The sums over ``axis`` as a loop forms them, acc = 0.0, then acc += each term in order: ``np.cumsum``
    adds in order by definition (no pairwise blocks, unlike ``np.sum``); it starts at the first term, and
    + 0.0 turns the -0.0 it leaves where every term is -0.0 into the loop's +0.0 (no other value changes).
    Zeros where there is no term."""
    if terms.shape[axis] == 0:
        return np.zeros(np.delete(terms.shape, axis))
    return np.cumsum(terms, axis=axis).take(-1, axis=axis) + 0.0
