"""The implicit z_v of the SOTC (Dien et al. 2023, section 2.1): z_v = dphi - chi_vd* - chi_vd^a, where
chi_vd* = -s tanh(grad_phi J_hat(z) / (2 s r)) of eq. (28) depends on z_v itself (the basis has
z_phi z_v terms). Each controller solves a_i z_vi + chi_vd*_i(z_phi, z_v) = c_i for z_v here: Newton's
method from a guess (``newton_zv``), and the guess-free bisection of the same system written in the tanh
arguments (``solve_tanh_system``) where Newton stalls; ``solve_zv`` combines them."""
from __future__ import annotations

import math
from array import array

from fmu_numerics.elementary import atanh, tanh
from fmu_controller.sotc_math import CriticConstants, gradient

# the implicit z_v (``solve_zv``): plain and damped Newton iterations, step halvings, and
# the residual (relative to 1 + |c| + s, rad/s) above which the next method is tried
ZV_PLAIN_ITERATIONS = 30
ZV_NEWTON_ITERATIONS = 50
ZV_BACKTRACKS = 40
ZV_TOLERANCE = 1e-12


def zv_residual(K: CriticConstants, zp1: float, zp2: float, zv1: float, zv2: float, c1: float, c2: float,
                a1: float, a2: float, W: array) -> tuple[float, float, float, float]:
    """(tanh x_1, tanh x_2, f_1, f_2) at z_v: f_i = a_i z_vi - s tanh(x_i) - c_i, the residual of the
    equation for z_v, with x_i = grad_phi_i J_hat / (2 s r_i) the tanh argument of eq. (28)."""
    s = K.s
    g1, g2, _, _ = gradient(zp1, zp2, zv1, zv2, W)
    t1 = tanh(g1 / (2.0 * s * K.r1))
    t2 = tanh(g2 / (2.0 * s * K.r2))
    return t1, t2, a1 * zv1 - s * t1 - c1, a2 * zv2 - s * t2 - c2


def newton_zv(K: CriticConstants, zp1: float, zp2: float, c1: float, c2: float, a1: float, a2: float, W: array,
              h13: float, h14: float, h23: float, h24: float, zv1: float, zv2: float,
              damped: bool) -> tuple[float, float, float, float]:
    """Newton for f(z_v) = a z_v + chi_vd*(z_phi, z_v) - c = 0 from (zv1, zv2); h13 .. h24 are the entries
    (1, 3), (1, 4), (2, 3), (2, 4) of the critic's Hessian d^2 J_hat / dz^2. ``damped``: a full
    step when it lowers ||f|| enough (Armijo), otherwise halved, and the iteration stops when no
    step along the Newton direction lowers ||f||; else plain full steps. Returns (zv1, zv2, f1, f2),
    f at the returned point."""
    r1, r2 = K.r1, K.r2
    t1, t2, f1, f2 = zv_residual(K, zp1, zp2, zv1, zv2, c1, c2, a1, a2, W)
    n2 = f1 * f1 + f2 * f2
    for _ in range(ZV_NEWTON_ITERATIONS if damped else ZV_PLAIN_ITERATIONS):
        if n2 == 0.0:
            break
        k1 = (1.0 - t1 * t1) / (2.0 * r1)  # d(-s tanh x_i)/dz_vj = -(1 - t_i^2) H_{i,2+j} / (2 r_i)
        k2 = (1.0 - t2 * t2) / (2.0 * r2)
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
            u1, u2, e1, e2 = zv_residual(K, zp1, zp2, y1, y2, c1, c2, a1, a2, W)
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


def solve_zv(K: CriticConstants, zp1: float, zp2: float, c1: float, c2: float, a1: float, a2: float, W: array,
             h13: float, h14: float, h23: float, h24: float) -> tuple[float, float, float]:
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
    s, r1, r2 = K.s, K.r1, K.r2
    zv1, zv2, f1, f2 = newton_zv(K, zp1, zp2, c1, c2, a1, a2, W, h13, h14, h23, h24, c1 / a1, c2 / a2, False)
    res = max(abs(f1), abs(f2))
    tol = ZV_TOLERANCE * (1.0 + abs(c1) + abs(c2) + s)
    if res <= tol:
        return zv1, zv2, res
    y1, y2, e1, e2 = newton_zv(K, zp1, zp2, c1, c2, a1, a2, W, h13, h14, h23, h24, c1 / a1, c2 / a2, True)
    if max(abs(e1), abs(e2)) < res or not math.isfinite(res):
        zv1, zv2, res = y1, y2, max(abs(e1), abs(e2))
    if res <= tol:
        return zv1, zv2, res
    # x = x0 + K tanh(x) in the tanh arguments x_i = grad_phi_i J_hat / (2 s r_i), with
    # z_v = (c + s tanh x) / a: x0 = x(z_v = c / a), K_ij = H_{i,2+j} / (2 r_i a_j)
    g1, g2, _, _ = gradient(zp1, zp2, c1 / a1, c2 / a2, W)
    t1, t2 = solve_tanh_system(
        g1 / (2.0 * s * r1), g2 / (2.0 * s * r2),
        h13 / (2.0 * r1 * a1), h14 / (2.0 * r1 * a2), h23 / (2.0 * r2 * a1), h24 / (2.0 * r2 * a2))
    y1, y2, e1, e2 = newton_zv(K, zp1, zp2, c1, c2, a1, a2, W, h13, h14, h23, h24, (c1 + s * t1) / a1,
                               (c2 + s * t2) / a2, True)
    if max(abs(e1), abs(e2)) < res or not math.isfinite(res):
        zv1, zv2, res = y1, y2, max(abs(e1), abs(e2))
    return zv1, zv2, res


# --- the implicit z_v of (6)/(28): x = x0 + K tanh(x) without a starting guess ---------------------------


def _bisect(f, lo: float, hi: float, f_lo: float) -> float:
    """A point of [lo, hi] where the continuous f changes sign (f(lo) = f_lo and f(hi) of opposite
    signs, zeros allowed), to about one ulp; at most 200 halvings, so it ends for any input."""
    neg = f_lo < 0.0
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if not lo < mid < hi or hi - lo <= 1e-16 * (abs(lo) + abs(hi)) + 1e-300:
            break
        f_mid = f(mid)
        if f_mid == 0.0:
            return mid
        if (f_mid < 0.0) == neg:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def _solve_tanh_1d(c: float, k: float) -> float:
    """A root of x - k tanh(x) - c (one exists: the sign changes on [-b, b], b = |c| + |k| + 1)."""
    b = abs(c) + abs(k) + 1.0
    return _bisect(lambda x: x - k * tanh(x) - c, -b, b, -1.0)


def _along_curve(a0: float, b0: float, kaa: float, kab: float, kba: float, kbb: float) -> tuple[float, float] | None:
    """(tanh x_a, tanh x_b) solving x_a = a0 + kaa tanh x_a + kab tanh x_b and x_b = b0 + kba tanh x_a +
    kbb tanh x_b, kab != 0, found on the curve where the first equation holds.

    On that curve tanh x_b = h(x_a) / kab with h(x) = x - a0 - kaa tanh x, and the second equation becomes
    phi(x_a) = t_b - tanh(b0 + kba tanh x_a + kbb t_b) = 0 with t_b in [-1, 1]. h is monotone on at
    most three pieces (split where h' = 1 - kaa (1 - tanh^2 x) changes sign), so on each piece the part
    of the curve inside |t_b| <= 1 is one interval, found by bisection. phi <= 0 where t_b = -1 and
    phi >= 0 where t_b = +1, and the first stretch of the curve from t_b = -1 to t_b = +1 (it exists:
    h runs from -inf to +inf) is a chain of such intervals, so one of them has a sign change of phi:
    bisection on it gives a solution. None if rounding hides every sign change."""
    K = abs(kab)

    def h(x: float) -> float:
        return x - a0 - kaa * tanh(x)

    def t_b(x: float) -> float:
        return min(1.0, max(-1.0, h(x) / kab))

    def phi(x: float) -> float:
        tb = t_b(x)
        return tb - tanh(b0 + kba * tanh(x) + kbb * tb)

    L = abs(a0) + abs(kaa) + K + 1.0  # |h(x)| > K for |x| >= L
    if kaa > 1.0:
        xs = atanh(math.sqrt(1.0 - 1.0 / kaa))
        pieces = ((-L, -xs, 1.0), (-xs, xs, -1.0), (xs, L, 1.0))  # (from, to, direction of h)
    else:
        pieces = ((-L, L, 1.0),)
    for p, q, direction in pieces:
        hp, hq = direction * h(p), direction * h(q)  # increasing after the sign flip
        if hp > K or hq < -K:
            continue  # the curve leaves the box on this whole piece
        lo = p if hp >= -K else _bisect(lambda x: direction * h(x) + K, p, q, hp + K)
        hi = q if hq <= K else _bisect(lambda x: direction * h(x) - K, p, q, hp - K)
        f_lo, f_hi = phi(lo), phi(hi)
        if f_lo == 0.0:
            return tanh(lo), t_b(lo)
        if f_hi == 0.0:
            return tanh(hi), t_b(hi)
        if (f_lo < 0.0) != (f_hi < 0.0):
            x = _bisect(phi, lo, hi, f_lo)
            return tanh(x), t_b(x)
    return None


def solve_tanh_system(x01: float, x02: float, k11: float, k12: float, k21: float, k22: float) -> tuple[float, float]:
    """(tanh x1, tanh x2) for a solution x of the 2x2 system x = x0 + K tanh(x), K = [[k11, k12], [k21, k22]].

    This is the implicit definition of z_v in (6)/(28) written in the tanh arguments x of chi_vd*. A
    solution exists for every x0 and K (u -> tanh(x0 + K u) maps [-1, 1]^2 into itself: Brouwer), but it
    need not be unique, and Newton's method can stall for large K. This finds one without a starting
    guess by bisection (``_along_curve``, eliminating the unknown with the larger coupling); for a
    negligible coupling it solves the two equations one after the other, twice. Accuracy is that of
    bisection (the elimination divides by the coupling): polish the result with Newton's method."""
    scale = abs(x01) + abs(x02) + abs(k11) + abs(k22) + 1.0
    if abs(k12) >= abs(k21) and abs(k12) > 1e-9 * scale:
        sol = _along_curve(x01, x02, k11, k12, k21, k22)
        if sol is not None:
            return sol
    elif abs(k21) > 1e-9 * scale:
        sol = _along_curve(x02, x01, k22, k21, k12, k11)
        if sol is not None:
            return sol[1], sol[0]
    t1 = t2 = 0.0
    for _ in range(2):  # nearly decoupled: one equation at a time (Gauss-Seidel)
        t1 = tanh(_solve_tanh_1d(x01 + k12 * t2, k11))
        t2 = tanh(_solve_tanh_1d(x02 + k21 * t1, k22))
    return t1, t2
