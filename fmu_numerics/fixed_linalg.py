# cython: boundscheck=False, wraparound=False
"""Fixed-order linear algebra for the small symmetric problems of the SOTC critic (n = 10).

Every sum here runs in one written order over flat float64 buffers (``array('d')``; matrices row-major,
n * n), so a result does not depend on the CPU: no BLAS or LAPACK kernel, no SIMD reduction of numpy, whose
blocking and instruction choice change the last bits from one processor to the next (where that changed
which CL row the SOTC swapped: ``docs/paper-notes.md``; the bits are pinned by
``tests/orchestration/test_cpu_independence.py``). The ``.pxd`` beside this file types the buffers as C
arrays (memoryviews) and compiles the same loops to C (``-ffp-contract=off``), so the compiled and the
Python cores give the same bits. ``buffer(n)`` makes one, ``as_buffer`` turns a list into one.

This is the one home of the controllers' numerical kernels: dot products, Cholesky factorisation and
solves, the symmetric eigenvalue bisection. (The Riccati solver's Gaussian elimination on nested lists
stays in ``riccati``: it runs once per construction, on 16 x 16 Kronecker systems, with partial
pivoting the kernels here do not need; ``orchestration/run/metrics.py`` sums with numpy and
``math.fsum``, outside the FMUs. The z_v solver's bisections are in ``sotc_zv``: they bisect on a
nonlinear scalar function, not a matrix.)

- ``cholesky`` / ``cholesky_solve``: the weight update (I + dt alpha1 Gamma) W+ = rhs of (30)/(31)
  (symmetric positive definite) and the positive-definiteness test of the CL stack's swap rule;
- ``tridiagonalize`` + ``sturm_count`` + ``smallest_eigenvalue``: lambda_min and the numerical rank of
  a symmetric matrix by Householder reduction and bisection on the Sturm sequence (both textbook:
  Golub & Van Loan, Matrix Computations, 4th ed., 8.3.1 and 8.4.1), with a bounded number of halvings.
"""
from __future__ import annotations

import math
from array import array
from typing import Sequence

from fmu_numerics.elementary import INTERPRETED

EPS = 2.220446049250313e-16  # the unit roundoff of float64, 2^-52
if INTERPRETED:  # the Python build's eigenvalue paths (the same bits)
    from fmu_numerics import fixed_linalg_interpreted
MAX_HALVINGS = 200  # bisection never halves more often than this (a zero resolution: until the interval stops shrinking)


def buffer(n: int) -> array:
    """n zeros, float64, contiguous: what every function here takes as a vector or a flat matrix."""
    return array("d", bytes(8 * n))


def as_buffer(values) -> array:
    """``values`` as a float64 buffer: itself if it is one, else a copy (for callers holding lists)."""
    return values if type(values) is array else array("d", values)


def dot(a: array, b: array, n: int) -> float:
    """sum_k a_k b_k over the first n entries, left to right."""
    acc = 0.0
    for k in range(n):
        acc += a[k] * b[k]
    return acc


def dot_sequence(a: Sequence[float], b: Sequence[float]) -> float:
    """sum_k a_k b_k over the shorter of two sequences, left to right (``sum`` rounds differently from
    Python 3.12 on, numpy's ``dot`` per BLAS kernel)."""
    acc = 0.0
    for k in range(min(len(a), len(b))):
        acc += a[k] * b[k]
    return acc


def scale_into(out: array, a: float, x: array, n: int) -> None:
    """out_k = x_k a for the first n entries."""
    for k in range(n):
        out[k] = x[k] * a


def add_scaled(out: array, a: float, x: array, n: int) -> None:
    """out_k += a x_k for the first n entries."""
    for k in range(n):
        out[k] += a * x[k]


def trace(A: array, n: int) -> float:
    acc = 0.0
    for k in range(n):
        acc += A[k * n + k]
    return acc


def cholesky(A: array, n: int, L: array) -> bool:
    """L (flat, lower triangle filled, upper left as it was) with A = L L^T, reading A's lower
    triangle. False, with L unfinished, if a pivot is not positive (A not positive definite)."""
    for j in range(n):
        acc = A[j * n + j]
        for k in range(j):
            acc -= L[j * n + k] * L[j * n + k]
        if not acc > 0.0:
            return False
        djj = math.sqrt(acc)
        L[j * n + j] = djj
        for i in range(j + 1, n):
            acc = A[i * n + j]
            for k in range(j):
                acc -= L[i * n + k] * L[j * n + k]
            L[i * n + j] = acc / djj
    return True


def forward_substitute(L: array, b: array, n: int, y: array, o: int = 0) -> None:
    """y with L y = b[o:o + n] (L lower triangular, from ``cholesky``)."""
    for i in range(n):
        acc = b[o + i]
        for k in range(i):
            acc -= L[i * n + k] * y[k]
        y[i] = acc / L[i * n + i]


def cholesky_solve(L: array, b: array, n: int, x: array) -> None:
    """x with L L^T x = b."""
    forward_substitute(L, b, n, x)
    for i in range(n - 1, -1, -1):
        acc = x[i]
        for k in range(i + 1, n):
            acc -= L[k * n + i] * x[k]
        x[i] = acc / L[i * n + i]


def _reflect(A: array, n: int, k: int, v: array, p: array) -> float:
    """One Householder step on the work copy A: zero column k below its subdiagonal and return the
    new subdiagonal entry; v, p are scratch of length n."""
    m0 = k + 1
    scale = 0.0
    for i in range(m0, n):
        scale += A[i * n + k] * A[i * n + k]
    if scale == 0.0:
        return 0.0
    x0 = A[m0 * n + k]
    alpha = -math.sqrt(scale) if x0 >= 0.0 else math.sqrt(scale)
    for i in range(m0, n):
        v[i] = A[i * n + k]
    v[m0] = x0 - alpha
    vv = 0.0  # |v|^2
    for i in range(m0, n):
        vv += v[i] * v[i]
    for i in range(m0, n):  # p = 2 A22 v / |v|^2
        acc = 0.0
        for j in range(m0, n):
            acc += A[i * n + j] * v[j]
        p[i] = 2.0 * acc / vv
    kk = 0.0
    for i in range(m0, n):
        kk += v[i] * p[i]
    kk /= vv
    for i in range(m0, n):  # q = p - (v^T p / |v|^2) v, kept in p
        p[i] -= kk * v[i]
    for i in range(m0, n):  # A22 -= v q^T + q v^T
        for j in range(m0, n):
            A[i * n + j] -= v[i] * p[j] + p[i] * v[j]
    return alpha


def tridiagonalize(M: array, n: int, d: array, e: array, A: array, v: array, p: array) -> None:
    """Diagonal d (n) and subdiagonal e (n - 1) of a tridiagonal matrix similar to the symmetric M
    (Householder reflections; M is read, not changed; A (n * n), v, p (n) are scratch; the interpreted
    core reduces a list of row lists, ``fixed_linalg_interpreted``, to the same bits)."""
    if INTERPRETED:
        fixed_linalg_interpreted.tridiagonalize(M, n, d, e)
        return
    for k in range(n * n):
        A[k] = M[k]
    for k in range(n - 2):
        e[k] = _reflect(A, n, k, v, p)
        d[k] = A[k * n + k]
    if n >= 2:
        d[n - 2] = A[(n - 2) * n + n - 2]
        e[n - 2] = A[(n - 1) * n + n - 2]
    d[n - 1] = A[n * n - 1]


def sturm_count(d: array, e: array, n: int, x: float) -> int:
    """How many eigenvalues of the tridiagonal (d, e) are smaller than x (the negative terms of the
    Sturm sequence; an exact zero is replaced by a tiny negative number, so the count is defined)."""
    count = 0
    q = d[0] - x
    for i in range(n):
        if i:
            q = d[i] - x - e[i - 1] * e[i - 1] / q
        if q == 0.0:
            q = -EPS * (abs(x) + 1e-300)
        if q < 0.0:
            count += 1
    return count


def gershgorin(d: array, e: array, n: int) -> tuple[float, float]:
    """An interval [lo, hi] holding every eigenvalue of the tridiagonal (d, e)."""
    lo, hi = d[0], d[0]
    for i in range(n):
        r = (abs(e[i - 1]) if i else 0.0) + (abs(e[i]) if i < n - 1 else 0.0)
        lo = min(lo, d[i] - r)
        hi = max(hi, d[i] + r)
    return lo, hi


def halvings(width: float, resolution: float) -> int:
    """The least k with width / 2^k <= resolution, at most ``MAX_HALVINGS``: how often a bisection must
    halve an interval of ``width``. Counted by doubling ``resolution`` (exact in binary floating point), so
    no logarithm of the C library decides it."""
    k, span = 0, resolution
    while span < width and k < MAX_HALVINGS:
        span *= 2.0
        k += 1
    return k


def smallest_of_tridiagonal(d: array, e: array, n: int, resolution: float, k: int = 1) -> float:
    """The k-th smallest eigenvalue of the tridiagonal (d, e) (k = 1: lambda_min) by bisection, to within
    ``resolution`` (or one ulp), in at most ``halvings`` of the Gershgorin interval plus two (a midpoint's
    rounding can leave a half a little wider)."""
    lo, hi = gershgorin(d, e, n)
    if INTERPRETED:  # the same halvings, each count stopped once it reaches k (``fixed_linalg_interpreted``)
        return fixed_linalg_interpreted.bisect(d[:n].tolist(), [0.0] + [v * v for v in e[:n - 1]], lo, hi,
                                               halvings(hi - lo, resolution), resolution, k)
    for it in range(halvings(hi - lo, resolution) + 2):
        if hi - lo <= resolution:
            break
        mid = 0.5 * (lo + hi)
        if mid <= lo or mid >= hi:
            break
        if sturm_count(d, e, n, mid) >= k:
            hi = mid
        else:
            lo = mid
    return 0.5 * (lo + hi)


def smallest_eigenvalue(M: array, n: int, d: array, e: array, A: array, v: array, p: array, k: int = 1) -> float:
    """The k-th smallest eigenvalue of the symmetric M (k = 1: lambda_min), bisected to within
    eps trace(M) (the rounding level of its entries, far below the CL stack's swap margin,
    ``sotc_stack.SWAP_MARGIN``);
    d (n) and e (n - 1) receive M's tridiagonal form, for ``sturm_count``; A, v, p are scratch."""
    tridiagonalize(M, n, d, e, A, v, p)
    return smallest_of_tridiagonal(d, e, n, EPS * abs(trace(M, n)), k)
