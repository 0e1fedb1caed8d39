"""``elementary``'s exp, log1p, tanh, sinh and hypot on float64 arrays, each element to the scalar function's bits.

Why: in the Python build (the cores not compiled) the CL replay evaluates the saturated cost (17) of
every stored row, a few hundred scalar calls per step; numpy runs each step of an algorithm as one
operation on all elements. Only the interpreted cores call this module (``sotc_stack_interpreted``; and the run
summary's torque norms, ``orchestration.run.metrics``, where ``elementary`` is not compiled); the compiled
build keeps ``elementary``'s C functions.

How the bits stay the same: every element goes through exactly the scalar function's sequence of
IEEE-754 operations (numpy's +, -, *, / on float64 are correctly rounded, elementwise, with no fused
multiply-add; no reduction, and none of numpy's own exp, tanh, log ..., which are libm's or SIMD code
and differ by CPU). ``elementary``'s helpers that are arithmetic alone (``_tanh_poly``, ``_sinh_poly``,
``_two_prod``, ``_exp_parts``, ``_log_reduced``) run on the arrays as they are. A branch of the scalar function
becomes a mask (``by_branch``): the main branch, where a run's arguments nearly all fall, is computed
on every element and kept where it applies; the few other elements go through the scalar function
itself, or, when there are many, through every branch as masks (``np.where``). Array code runs under
``np.errstate(all="ignore")``, as the scalar code raises no floating-point exception. Powers of two
are ``np.ldexp`` and the exponent of ``_normalize`` is ``np.frexp``'s, both exact: m = u 2^-k in
[sqrt(1/2), sqrt(2)) with k an integer has one solution, the one the scalar loop of halvings finds.
``tests/unit/test_elementary_interpreted.py`` compares every function with the scalar one bit for bit on
hypothesis-drawn arguments (signed zeros, inf, nan, tiny and huge arguments, the branch boundaries).
"""
from __future__ import annotations

import numpy as np

from fmu_numerics import elementary as el
from fmu_numerics.elementary import (EXP_OVER, EXP_UNDER, INF, NAN, P2_60, P2_500, P2_M54, P2_M500, SINH_OVER,
                                       SINH_POLY_MAX, SQRT_HALF, TANH_POLY_MAX, TINY, _corrected_root, _exp_parts,
                                       _log_reduced, _sinh_poly, _sum_of_squares, _tanh_poly, _two_prod)

FEW = 8  # elements outside a function's main branch computed one by one (cheaper than its other branches as arrays)


def by_branch(x: np.ndarray, main: np.ndarray, on_main, on_all, scalar) -> np.ndarray:
    """A function's values at x: where ``main`` holds from ``on_main`` (computed on all of x, the other
    elements discarded); the others from the scalar function one by one while they are at most ``FEW``,
    else from ``on_all`` (every branch, masks) on them alone."""
    rest = np.flatnonzero(~main)
    if rest.size == x.size:
        return on_all(x)
    out = on_main(x)
    if rest.size:
        others = x[rest]
        out[rest] = [scalar(v) for v in others.tolist()] if rest.size <= FEW else on_all(others)
    return out


def _pow2(k: np.ndarray) -> np.ndarray:
    """``elementary._pow2``: 2^k for integer-valued k (ldexp, exact); an element not finite gives a value
    its caller discards (the cast's invalid flag is ignored with the others)."""
    return np.ldexp(1.0, k.astype(np.int64))


def _scale(y: np.ndarray, k: np.ndarray) -> np.ndarray:
    """``elementary._scale``: y 2^k in two exact factors beyond |k| = 1000, as there."""
    v = y * _pow2(k)
    if (np.abs(k) > 1000.0).any():
        v = np.where(k > 1000.0, y * _pow2(k - 1000.0) * _pow2(np.full_like(k, 1000.0)),
                     np.where(k < -1000.0, y * _pow2(k + 1000.0) * _pow2(np.full_like(k, -1000.0)), v))
    return v


def exp(x: np.ndarray) -> np.ndarray:
    """``elementary.exp`` elementwise; the main branch 2^-54 <= |x| <= 690 (one exact scaling) as arrays."""
    with np.errstate(all="ignore"):
        a = np.abs(x)
        return by_branch(x, (a >= P2_M54) & (a <= 690.0), _exp_main, _exp_all, el.exp)


def _exp_main(x: np.ndarray) -> np.ndarray:
    k, hi, _ = _exp_parts(x)
    return hi * _pow2(k)


def _exp_all(x: np.ndarray) -> np.ndarray:
    k, hi, _ = _exp_parts(x)
    v = np.where(np.abs(x) < P2_M54, 1.0 + x, _scale(hi, k))
    return np.where(x != x, x, np.where(x > EXP_OVER, INF, np.where(x < EXP_UNDER, 0.0, v)))


def _normalized(u: np.ndarray) -> tuple:
    """``elementary._normalize`` for u > 0 (finite): (k, m), u = 2^k m, m in [sqrt(1/2), sqrt(2)), from frexp."""
    m, e = np.frexp(u)  # u = m 2^e, m in [1/2, 1)
    low = m < SQRT_HALF
    return e.astype(np.float64) - np.where(low, 1.0, 0.0), np.where(low, m * 2.0, m)


def log1p(x: np.ndarray) -> np.ndarray:
    """``elementary.log1p`` elementwise (``_log1p_parts`` with xl = 0); the main branch, x itself as f in
    ``_log_reduced`` (2^-54 <= |x|, -0.29 <= x < 0.41), as arrays."""
    with np.errstate(all="ignore"):
        main = (-0.2928932188134524 <= x) & (x < 0.41421356237309503) & (np.abs(x) >= P2_M54)
        return by_branch(x, main, _log1p_main, _log1p_all, el.log1p)


def _log1p_main(x: np.ndarray) -> np.ndarray:
    return _log_reduced(0.0, x, 0.0 / (1.0 + x))


def _log1p_all(x: np.ndarray) -> np.ndarray:
    """Every branch: the two of ``_log1p_parts`` as one ``_log_reduced`` on the chosen k, f and correction."""
    near = (-0.2928932188134524 <= x) & (x < 0.41421356237309503)
    u = 1.0 + x
    err = np.where(x < 1.0, x - (u - 1.0), 1.0 - (u - x))
    ku, m = _normalized(np.where(u > 0.0, u, 1.0))
    k, f, c = np.where(near, 0.0, ku), np.where(near, x, m - 1.0), np.where(near, 0.0 / u, (err + 0.0) / u)
    v = np.where((x == INF) | (np.abs(x) < P2_M54), x, _log_reduced(k, f, c))
    return np.where(x > -1.0, v, np.where(x == -1.0, -INF, np.where(x == x, NAN, x)))


def tanh(x: np.ndarray) -> np.ndarray:
    """``elementary.tanh`` elementwise; the main branch, x + x^3 T(x^2) for TINY < |x| <= TANH_POLY_MAX, as arrays."""
    with np.errstate(all="ignore"):
        a = np.abs(x)
        return by_branch(x, (a > TINY) & (a <= TANH_POLY_MAX), _tanh_poly, _tanh_all, el.tanh)


def _tanh_all(x: np.ndarray) -> np.ndarray:
    """Every branch: x + x^3 T(x^2) up to TANH_POLY_MAX, 1 - 2 / (e^{2|x|} + 1) with its errors kept up to
    22, +-1 beyond."""
    a = np.abs(x)
    big = np.where(a > 22.0, 1.0, _tanh_exp(a))
    t = np.where(a <= TANH_POLY_MAX, _tanh_poly(x), np.where(x > 0.0, big, -big))
    return np.where(a > TINY, t, x)


def _tanh_exp(a: np.ndarray) -> np.ndarray:
    k, hi, lo = _exp_parts(a + a)
    scale = _pow2(k)
    d = scale * hi + 1.0
    dl = ((scale * hi - d) + 1.0) + scale * lo
    q = 2.0 / d
    p, pl = _two_prod(q, d)
    ql = (((2.0 - p) - pl) - q * dl) / d
    t = 1.0 - q
    return t + (((1.0 - t) - q) - ql)


def sinh(x: np.ndarray) -> np.ndarray:
    """``elementary.sinh`` elementwise; the main branch, x + x^3 S(x^2) for TINY < |x| <= SINH_POLY_MAX, as arrays."""
    with np.errstate(all="ignore"):
        a = np.abs(x)
        return by_branch(x, (a > TINY) & (a <= SINH_POLY_MAX), _sinh_poly, _sinh_all, el.sinh)


def _sinh_all(x: np.ndarray) -> np.ndarray:
    """Every branch: the polynomial up to SINH_POLY_MAX, else (e^|x| - e^-|x|) / 2 (``_exp_pair``)."""
    a = np.abs(x)
    k, hi, lo = _exp_parts(a)
    inv = np.where(k < 500.0, _pow2(-k - k) / (hi + lo), 0.0)
    pair = np.where(a <= SINH_OVER, _scale(hi + (lo + -1.0 * inv), k - 1.0), INF)
    h = np.where(a <= SINH_POLY_MAX, _sinh_poly(x), np.where(x > 0.0, pair, -pair))
    return np.where((a > TINY) & (a != INF), h, x)


def hypot(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """``elementary.hypot`` elementwise. Its main branch (both finite, the larger in [2^-500, 2^500], the
    smaller neither 0 nor below 2^-60 of it: no scaling, no shortcut) is computed on all elements; numpy's
    sqrt is correctly rounded, as ``math.sqrt``; the others go through the scalar function."""
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    with np.errstate(all="ignore"):
        a, b = np.abs(x), np.abs(y)
        a, b = np.maximum(a, b), np.minimum(a, b)
        main = (a >= P2_M500) & (a <= P2_500) & (b * P2_60 >= a) & (b != 0.0)
        t, tl = _sum_of_squares(a, b)
        out = _corrected_root(np.sqrt(t), t, tl)
    rest = np.flatnonzero(~main)
    if rest.size:
        out[rest] = [el.hypot(u, v) for u, v in zip(x[rest].tolist(), y[rest].tolist())]
    return out
