"""The continuous-time algebraic Riccati equation in fixed-order arithmetic (no scipy, no LAPACK).

    A'P + PA - P B R^-1 B' P + Q = 0,   P = P' >= 0 stabilising                       (CARE)

Newton-Kleinman iteration (Kleinman 1968) from a stabilising gain K_0 the caller knows: with
A_K = A - B K, solve the Lyapunov equation A_K'P + P A_K = -(Q + K'RK) for P, then K = R^-1 B'P, until
P repeats (quadratic convergence; at most MAX_STEPS, else RiccatiError unless the
last iterates differ only at the rounding level, ``CONVERGED``). The controllers here solve 4 x 4 problems once
at construction, so each Lyapunov equation is solved through its Kronecker form by Gaussian
elimination with partial pivoting, written out: every operation runs in one order on every CPU (a
LAPACK eigen-solver rounds differently per BLAS kernel, and the OTC's initial weights with it).
``tests/unit/test_riccati.py`` checks the result against scipy's Schur-based solver.
"""
from __future__ import annotations

import math
from array import array
from typing import Sequence

import numpy as np

from fmu_numerics.fixed_linalg import buffer, cholesky

MAX_STEPS = 60
CONVERGED = 1e-12  # relative change of P between the last two iterates that still counts as converged


class RiccatiError(ValueError):
    pass


Matrix = list[list[float]]


def _rows(x) -> Matrix:
    return [[float(v) for v in row] for row in np.asarray(x, dtype=float).tolist()]


def _mul(x: Matrix, y: Matrix) -> Matrix:
    out = []
    for i in range(len(x)):
        row = []
        for j in range(len(y[0])):
            acc = 0.0
            for k in range(len(y)):
                acc += x[i][k] * y[k][j]
            row.append(acc)
        out.append(row)
    return out


def _t(x: Matrix) -> Matrix:
    return [list(col) for col in zip(*x)]


def solve_linear(m: Matrix, rhs: Sequence[float]) -> list[float]:
    """x with M x = rhs: Gaussian elimination, partial pivoting (first largest pivot), in fixed order."""
    n = len(m)
    a = [list(row) + [float(v)] for row, v in zip(m, rhs)]
    for col in range(n):
        piv = col
        for i in range(col + 1, n):
            if abs(a[i][col]) > abs(a[piv][col]):
                piv = i
        if a[piv][col] == 0.0:
            raise RiccatiError("a singular linear system: the problem has no stabilising solution")
        a[col], a[piv] = a[piv], a[col]
        for i in range(col + 1, n):
            f = a[i][col] / a[col][col]
            for j in range(col, n + 1):
                a[i][j] -= f * a[col][j]
    x = [0.0] * n
    for i in range(n - 1, -1, -1):
        acc = a[i][n]
        for j in range(i + 1, n):
            acc -= a[i][j] * x[j]
        x[i] = acc / a[i][i]
    return x


def lyapunov(a: Matrix, c: Matrix) -> Matrix:
    """X with A'X + XA = -C (its Kronecker form, (I (x) A' + A' (x) I) vec X = -vec C), symmetrised."""
    n = len(a)
    system = [[0.0] * (n * n) for _ in range(n * n)]
    for i in range(n):
        for j in range(n):
            for k in range(n):  # row (i, j) of vec X, column-major: (A'X)_ij + (XA)_ij
                system[j * n + i][j * n + k] += a[k][i]
                system[j * n + i][k * n + i] += a[k][j]
    x = solve_linear(system, [-c[i][j] for j in range(n) for i in range(n)])
    return [[0.5 * (x[j * n + i] + x[i * n + j]) for j in range(n)] for i in range(n)]


def _positive_definite(p: Matrix) -> bool:
    """Cholesky succeeds (``fixed_linalg.cholesky``: every pivot positive) with finite pivots."""
    n = len(p)
    low = buffer(n * n)
    return cholesky(array("d", [v for row in p for v in row]), n, low) and all(
        math.isfinite(low[j * n + j]) for j in range(n))


def solve_care(a, b, q, r, k0) -> np.ndarray:
    """The stabilising solution P of (CARE), from a gain ``k0`` with A - B k0 stable; RiccatiError if
    an iterate is not positive definite (k0 not stabilising, or no stabilising solution)."""
    A, B, Q, R, K = _rows(a), _rows(b), _rows(q), _rows(r), _rows(k0)
    r_inv_bt = _r_inv_bt(B, R)
    previous = before = None
    for _ in range(MAX_STEPS):
        bk = _mul(B, K)
        ak = [[A[i][j] - bk[i][j] for j in range(len(A))] for i in range(len(A))]
        krk = _mul(_t(K), _mul(R, K))
        p = lyapunov(ak, [[Q[i][j] + krk[i][j] for j in range(len(A))] for i in range(len(A))])
        if not _positive_definite(p):
            raise RiccatiError("no stabilising solution: a Newton-Kleinman iterate is not positive definite")
        if p == previous:
            return np.array(previous)
        before, previous, K = previous, p, _mul(r_inv_bt, p)
    change = _relative_change(before, previous)
    if not change <= CONVERGED:
        raise RiccatiError(f"the Newton-Kleinman iteration did not converge in {MAX_STEPS} steps: its last step "
                           f"changed P by {change:.3g} (relative; converged means <= {CONVERGED:g})")
    return np.array(previous)  # the iterates alternate at the rounding level


def _relative_change(before: Matrix | None, p: Matrix) -> float:
    """max |p - before| / max |p| (inf without a previous iterate)."""
    if before is None:
        return float("inf")
    scale = max(abs(v) for row in p for v in row)
    return max(abs(x - y) for rx, ry in zip(p, before) for x, y in zip(rx, ry)) / scale


def _r_inv_bt(B: Matrix, R: Matrix) -> Matrix:
    """R^-1 B' (m x n), column by column of B'."""
    return _t([solve_linear(R, row) for row in B])


def gain(b, r, p) -> np.ndarray:
    """K = R^-1 B'P, the optimal feedback of (CARE)'s solution P, in fixed order."""
    return np.array(_mul(_r_inv_bt(_rows(b), _rows(r)), _rows(p)))
