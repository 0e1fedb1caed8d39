"""The interpreted build's twin of ``sotc_stack``: the CL sums (``cl_matrix_numpy``) and the ``current`` CL
replay over all stored rows at once, to the bits of ``sotc_stack``'s loops over rows.

Per step the replay re-evaluates every stored row of the concurrent-learning sum of (30)/(31) at the
current weights: the arguments x of the saturated law (28), mu = -s tanh x, the error rate of
(6)/(7), eta = grad(zeta) zdot of (29) and the reward of (12) with the saturated cost (17). In the
Python build that loop over 20 rows (16 tanh, 4 sinh or exp and 4 log1p a row) was most of the
controller's time. Here every quantity is one float64 array with an element per row, and the loop
body runs once on those arrays:

- ``sotc_math``'s own ``policy_arguments``, ``error_rate`` and ``directional_into`` on arrays (their
  +, -, *, / apply elementwise in the order written there, so each element is the scalar result);
- the elementary functions of ``elementary_interpreted`` (each element the bits of ``elementary``'s);
- the saturated cost (17) of the 4 n components at once (``x_tanh_minus_log_cosh``), summed per row in
  ``omega4``'s order.

Only the interpreted ``sotc_stack`` imports this module (sotc_math's compiled functions take doubles);
``tests/unit/test_elementary_interpreted.py`` compares the replay, and ``tests/unit/test_interpreted_paths.py``
the CL sums, with the loops on hypothesis-drawn rows.
"""
from __future__ import annotations

from array import array

import numpy as np

from fmu_numerics import elementary_interpreted as ea
from fmu_numerics.elementary import tanh
from fmu_numerics.fixed_linalg_interpreted import in_order
from fmu_controller.sotc_math import (LN2, N_BASIS, CriticConstants, _x_tanh_minus_log_cosh, directional_into,
                                     error_rate, normalisation, policy_arguments)
from fmu_controller.sotc_math_interpreted import lower_masks


def x_tanh_minus_log_cosh(x: np.ndarray, t: np.ndarray) -> np.ndarray:
    """``sotc_math._x_tanh_minus_log_cosh`` elementwise, given t = tanh x (``elementary_interpreted.tanh``):
    a tanh a - ln(1 + 2 sinh^2(a/2)) for a = |x| < 1 (the main branch, as arrays), where tanh a = |tanh x|
    to the bit (``elementary``'s tanh is odd to the bit: every step of it is); else
    ln 2 - ln(1 + e) - 2 a e / (1 + e), e = e^{-2a} (``_large``; one by one while few, as
    ``elementary_interpreted.by_branch``)."""
    with np.errstate(all="ignore"):
        a = np.abs(x)
        small = a < 1.0

        def main(_):
            h = ea.sinh(0.5 * np.where(small, a, 0.0))
            return a * np.abs(t) - ea.log1p(2.0 * h * h)

        return ea.by_branch(x, small, main, _large, _scalar)


def _scalar(x: float) -> float:
    """The scalar function at one element off the main branch (its tanh computed again: only a few are)."""
    return _x_tanh_minus_log_cosh(x, tanh(x))


def _large(x: np.ndarray) -> np.ndarray:
    """The branch |x| >= 1 (and nan) of ``_x_tanh_minus_log_cosh``, elementwise."""
    a = np.abs(x)
    e = ea.exp(-2.0 * a)
    return LN2 - ea.log1p(e) - 2.0 * a * e / (1.0 + e)


def replay_current_array(K: CriticConstants, n: int, W: array, z: array, dinv: array, fe: array, E: array,
                         rew: array) -> None:
    """``sotc_stack.replay_current`` (eta_i into E, r_i into rew for the first n rows) on arrays over rows."""
    if n <= 0:
        return
    Z = np.frombuffer(z, count=4 * n).reshape(n, 4).T
    D = np.frombuffer(dinv, count=3 * n).reshape(n, 3).T
    F = np.frombuffer(fe, count=2 * n).reshape(n, 2).T
    zp1, zp2, zv1, zv2 = Z
    i11, i12, i22 = D
    s = K.s
    with np.errstate(all="ignore"):  # an overflow gives inf silently, as the scalar code does
        X = np.array(policy_arguments(K, zp1, zp2, zv1, zv2, W, i11, i12, i22))  # (4, n)
        T = ea.tanh(X.ravel()).reshape(4, n)
        mu = -s * T
        zd1, zd2, zd3, zd4 = error_rate(K, zp1, zp2, zv1, zv2, mu[0], mu[1], mu[2], mu[3], F[0], F[1], i11, i12, i22)
        eta = np.empty((N_BASIS, n))
        if K.coupled:
            directional_into(eta, 0, zp1, zp2, zv1, zv2, zd1, zd2, zd3, zd4)
        else:  # as critic_row: F_bar of (7) without the coupling terms
            directional_into(eta, 0, zp1, zp2, zv1, zv2, zd1 - zv1, zd2 - zv2, zd3 + zp1, zd4 + zp2)
        f = x_tanh_minus_log_cosh(X.ravel(), T.ravel()).reshape(4, n)
        omega = (2.0 * s * s * K.r1 * f[0] + 2.0 * s * s * K.r2 * f[1]
                 + 2.0 * s * s * K.r3 * f[2] + 2.0 * s * s * K.r4 * f[3])
        quad = K.theta1 * zp1 * zp1 + K.theta2 * zp2 * zp2 + K.theta3 * zv1 * zv1 + K.theta4 * zv2 * zv2
        np.frombuffer(E, count=N_BASIS * n).reshape(n, N_BASIS)[:] = eta.T
        np.frombuffer(rew, count=n)[:] = quad + omega


def cl_matrix_numpy(n: int, E, rew, M, b, sc) -> None:
    """``cl_matrix`` for the interpreted core, the same bits: every product is the same elementwise
    product (numpy rounds each one as Python does, no FMA), and every sum runs in the same order:
    ``in_order`` over the rows, and over k for eta_i^T eta_i; only the loops over the entries of a row
    become vector operations."""
    N = N_BASIS
    Ev = np.frombuffer(E, count=n * N).reshape(n, N)
    with np.errstate(all="ignore"):  # an overflow gives inf silently, as the loops do
        ee = in_order(Ev * Ev, 1)  # eta_i^T eta_i over k in order, for all rows at once
        scv = np.array([1.0 / normalisation(v) for v in ee.tolist()])
        np.frombuffer(sc, count=n)[:] = scv
        xa = Ev * scv[:, None]
        Mv = in_order(xa[:, :, None] * Ev[:, None, :], 0)  # xa_a eta_c of each row, summed over the rows
        bv = in_order(xa * np.frombuffer(rew, count=n)[:, None], 0)
    np.frombuffer(M).reshape(N, N)[:] = np.where(lower_masks(N)[0], Mv, Mv.T)
    np.frombuffer(b)[:] = bv
