"""The implicit z_v of the SOTC (Dien et al. 2023, section 2.1): z_v = dphi - chi_vd* - chi_vd^a, where
chi_vd* = -s tanh(grad_phi J_hat(z) / (2 s r)) of eq. (28) depends on z_v itself (the basis has
z_phi z_v terms). Each controller solves a_i z_vi + chi_vd*_i(z_phi, z_v) = c_i for z_v here."""
from __future__ import annotations

import math
from typing import Sequence

from fmu_controller.sotc_math import solve_tanh_system, value_gradient

# the implicit z_v (``SotcCore._solve_zv``): plain and damped Newton iterations, step halvings, and
# the residual (relative to 1 + |c| + s, rad/s) above which the next method is tried
ZV_PLAIN_ITERATIONS = 30
ZV_NEWTON_ITERATIONS = 50
ZV_BACKTRACKS = 40
ZV_TOLERANCE = 1e-12


def zv_residual(s: float, r: Sequence[float], zp1: float, zp2: float, zv1: float, zv2: float, c1: float,
                c2: float, a1: float, a2: float, W: Sequence[float]) -> tuple[float, float, float, float]:
    """(tanh x_1, tanh x_2, f_1, f_2) at z_v: f_i = a_i z_vi - s tanh(x_i) - c_i, the residual of the
    equation for z_v, with x_i = grad_phi_i J_hat / (2 s r_i) the tanh argument of eq. (28)."""
    g1, g2, _, _ = value_gradient((zp1, zp2, zv1, zv2), W)
    t1 = math.tanh(g1 / (2.0 * s * r[0]))
    t2 = math.tanh(g2 / (2.0 * s * r[1]))
    return t1, t2, a1 * zv1 - s * t1 - c1, a2 * zv2 - s * t2 - c2


def newton_zv(s: float, r: Sequence[float], zp1: float, zp2: float, c1: float, c2: float, a1: float, a2: float,
              W: Sequence[float], hess: tuple[tuple[float, ...], ...], zv1: float, zv2: float,
              damped: bool) -> tuple[float, float, float, float]:
    """Newton for f(z_v) = a z_v + chi_vd*(z_phi, z_v) - c = 0 from (zv1, zv2). ``damped``: a full
    step when it lowers ||f|| enough (Armijo), otherwise halved, and the iteration stops when no
    step along the Newton direction lowers ||f||; else plain full steps. Returns (zv1, zv2, f1, f2),
    f at the returned point."""
    h13, h14, h23, h24 = hess[0][2], hess[0][3], hess[1][2], hess[1][3]
    t1, t2, f1, f2 = zv_residual(s, r, zp1, zp2, zv1, zv2, c1, c2, a1, a2, W)
    n2 = f1 * f1 + f2 * f2
    for _ in range(ZV_NEWTON_ITERATIONS if damped else ZV_PLAIN_ITERATIONS):
        if n2 == 0.0:
            break
        k1 = (1.0 - t1 * t1) / (2.0 * r[0])  # d(-s tanh x_i)/dz_vj = -(1 - t_i^2) H_{i,2+j} / (2 r_i)
        k2 = (1.0 - t2 * t2) / (2.0 * r[1])
        j11, j12 = a1 - k1 * h13, -k1 * h14
        j21, j22 = -k2 * h23, a2 - k2 * h24
        det = j11 * j22 - j12 * j21
        if det == 0.0 or not math.isfinite(det):
            break
        d1 = (j22 * f1 - j12 * f2) / det
        d2 = (j11 * f2 - j21 * f1) / det
        tiny = abs(d1) + abs(d2) <= 1e-14 * (1.0 + abs(zv1) + abs(zv2))  # at rounding level: take it
        step = 1.0
        for _ in range(ZV_BACKTRACKS):
            y1, y2 = zv1 - step * d1, zv2 - step * d2
            u1, u2, e1, e2 = zv_residual(s, r, zp1, zp2, y1, y2, c1, c2, a1, a2, W)
            m2 = e1 * e1 + e2 * e2
            if tiny or not damped or m2 <= (1.0 - 1e-4 * step) * n2:
                break
            step *= 0.5
        else:
            break  # no descent along the Newton direction (a fold of f): the caller falls back
        zv1, zv2, t1, t2, f1, f2, n2 = y1, y2, u1, u2, e1, e2, m2
        if abs(step * d1) + abs(step * d2) <= 1e-14 * (1.0 + abs(zv1) + abs(zv2)):
            break
    return zv1, zv2, f1, f2

def solve_zv(s: float, r: Sequence[float], zp1: float, zp2: float, c1: float, c2: float, a1: float, a2: float,
              W: Sequence[float], hess: tuple[tuple[float, ...], ...]) -> tuple[float, float, float]:
    """Solve a_i z_vi + chi_vd*_i(z_phi, z_v) = c_i for z_v; returns (z_v1, z_v2, residual), the
    residual max_i |a_i z_vi + chi_vd*_i - c_i| in rad/s (the ``zv_residual`` output).

    z_v = dphi - chi_vd* - chi_vd^a, but chi_vd* = -s tanh(grad_phi J_hat(z) / (2 s r)) of (28)
    depends on z_v (the basis has z_phi z_v terms), so z_v is defined implicitly; the paper is
    silent on this. A solution always exists (``solve_tanh_system``); it is unique while the map is
    a contraction (moderate W), where Newton from z_v = c / a converges in 2-4 steps. For large W
    Newton can stall on a fold of the residual or jump between roots; then damped Newton is tried
    from the same start and, if that stalls too, the system is solved without a starting guess by
    bisection along its saturation (``solve_tanh_system``) and polished by damped Newton. The
    best answer is kept. (Plain Newton first: wherever it converges, the result is what it was
    before the fallbacks existed, bit for bit.)"""
    zv1, zv2, f1, f2 = newton_zv(s, r, zp1, zp2, c1, c2, a1, a2, W, hess, c1 / a1, c2 / a2, False)
    res = max(abs(f1), abs(f2))
    tol = ZV_TOLERANCE * (1.0 + abs(c1) + abs(c2) + s)
    if res <= tol:
        return zv1, zv2, res
    y1, y2, e1, e2 = newton_zv(s, r, zp1, zp2, c1, c2, a1, a2, W, hess, c1 / a1, c2 / a2, True)
    if max(abs(e1), abs(e2)) < res or not math.isfinite(res):
        zv1, zv2, res = y1, y2, max(abs(e1), abs(e2))
    if res <= tol:
        return zv1, zv2, res
    # x = x0 + K tanh(x) in the tanh arguments x_i = grad_phi_i J_hat / (2 s r_i), with
    # z_v = (c + s tanh x) / a: x0 = x(z_v = c / a), K_ij = H_{i,2+j} / (2 r_i a_j)
    g1, g2, _, _ = value_gradient((zp1, zp2, c1 / a1, c2 / a2), W)
    t1, t2 = solve_tanh_system(
        g1 / (2.0 * s * r[0]), g2 / (2.0 * s * r[1]),
        hess[0][2] / (2.0 * r[0] * a1), hess[0][3] / (2.0 * r[0] * a2),
        hess[1][2] / (2.0 * r[1] * a1), hess[1][3] / (2.0 * r[1] * a2))
    y1, y2, e1, e2 = newton_zv(s, r, zp1, zp2, c1, c2, a1, a2, W, hess,
                                     (c1 + s * t1) / a1, (c2 + s * t2) / a2, True)
    if max(abs(e1), abs(e2)) < res or not math.isfinite(res):
        zv1, zv2, res = y1, y2, max(abs(e1), abs(e2))
    return zv1, zv2, res
