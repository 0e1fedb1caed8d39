"""Closed-form maths of the SOTC paper: saturated cost, quadratic critic basis, probing signal, and
the guess-free solver of the implicit z_v (``solve_tanh_system``).

Reference: N. D. Dien, N. T. Luy, L. K. Lai, T. T. Hai, "Optimal tracking control for robot
manipulators with input constraint based reinforcement learning", J. Computer Science and
Cybernetics, 2023. Equation numbers below are the paper's.

Everything is plain float code on 4-vectors ``z = (z_phi1, z_phi2, z_v1, z_v2)``: for vectors this
small, ``math`` on floats is several times faster than numpy, and the controller calls these
functions 10,000 times per simulated run. Array versions for tests are thin wrappers.

Symbols: ``s`` is the saturation level of the optimal input (sigma in the chosen reading, see
``docs/paper-notes.md``), ``x`` the *pre-saturation argument* of the control law (28), i.e.
``mu = -s tanh(x)``.
"""
from __future__ import annotations

import math
from typing import Sequence

import numpy as np

LN2 = math.log(2.0)

# (i, j) of z_i z_j for each of the 10 basis terms of section 4, in the paper's order:
# zeta(z) = [zp1^2, zp1 zp2, zp1 zv1, zp1 zv2, zp2^2, zp2 zv1, zp2 zv2, zv1^2, zv1 zv2, zv2^2]
BASIS_PAIRS: tuple[tuple[int, int], ...] = (
    (0, 0), (0, 1), (0, 2), (0, 3), (1, 1), (1, 2), (1, 3), (2, 2), (2, 3), (3, 3),
)
N_BASIS = len(BASIS_PAIRS)


# --- saturated cost, eqs. (13)-(17) ---------------------------------------------------------------


def log_cosh(x: float) -> float:
    """ln cosh x without overflow or cancellation: ln(1 + 2 sinh^2(x/2)) for |x| < 1, else
    |x| + ln(1 + e^{-2|x|}) - ln 2 (finite for every finite x)."""
    a = abs(x)
    if a < 1.0:
        h = math.sinh(0.5 * a)
        return math.log1p(2.0 * h * h)
    return a + math.log1p(math.exp(-2.0 * a)) - LN2


def _x_tanh_minus_log_cosh(x: float) -> float:
    """x tanh x - ln cosh x (>= 0, even, -> ln 2 as |x| -> inf), accurate for every finite x: for
    |x| >= 1 it is rewritten with e = e^{-2|x|} as ln 2 - ln(1 + e) - 2|x| e / (1 + e), which avoids
    subtracting two numbers of size |x|."""
    a = abs(x)
    if a < 1.0:
        return a * math.tanh(a) - log_cosh(a)
    e = math.exp(-2.0 * a)
    return LN2 - math.log1p(e) - 2.0 * a * e / (1.0 + e)


def omega_term_of_arg(x: float, s: float, r: float) -> float:
    """One component of Omega, eq. (17), written in the pre-saturation argument x of mu = -s tanh x.

    With mu = -s tanh x, atanh(mu/s) = -x and ln(1 - mu^2/s^2) = ln(1 - tanh^2 x) = -2 ln cosh x, so
        2 s atanh(mu/s) r mu + s^2 r ln(1 - mu^2/s^2) = 2 s^2 r (x tanh x - ln cosh x)   eq. (17)
    which stays finite (-> 2 s^2 r ln 2) even where tanh x rounds to +-1.
    """
    return 2.0 * s * s * r * _x_tanh_minus_log_cosh(x)


def omega_of_arg(x: Sequence[float], s: float, r: Sequence[float]) -> float:
    """Omega(mu) of eq. (17) for mu = -s tanh(x) (componentwise), R = diag(r), summed in order."""
    return (omega_term_of_arg(x[0], s, r[0]) + omega_term_of_arg(x[1], s, r[1])
            + omega_term_of_arg(x[2], s, r[2]) + omega_term_of_arg(x[3], s, r[3]))


def reward(z: Sequence[float], x: Sequence[float], theta: Sequence[float], s: float,
           r: Sequence[float]) -> tuple[float, float]:
    """(r, Omega): the cost rate r = z^T Theta z + Omega(mu_hat) of eq. (12) with Omega of (17) at the
    pre-saturation arguments x of (28), Theta = diag(theta)."""
    zp1, zp2, zv1, zv2 = z
    omega = omega_of_arg(x, s, r)
    return (theta[0] * zp1 * zp1 + theta[1] * zp2 * zp2 + theta[2] * zv1 * zv1 + theta[3] * zv2 * zv2) + omega, omega


def omega_of_mu(mu: Sequence[float], s: float, r: Sequence[float]) -> float:
    """Omega(mu) of eq. (17) from mu itself; requires |mu_i| < s (else +inf, the cost's barrier).

        Omega(mu) = sum_i 2 s r_i mu_i atanh(mu_i / s) + s^2 r_i ln(1 - mu_i^2 / s^2)      eq. (17)
    """
    total = 0.0
    for m, ri in zip(mu, r):
        q = m / s
        if not abs(q) < 1.0:
            return math.inf
        total += 2.0 * s * ri * m * math.atanh(q) + s * s * ri * math.log1p(-q * q)
    return total


def omega_integrand(u: float, s: float, r: float) -> float:
    """Integrand of eq. (13) for one component: 2 s r atanh(u / s). (For quadrature in tests.)"""
    return 2.0 * s * r * math.atanh(u / s)


# --- critic basis of section 4, eq. (27) ----------------------------------------------------------


def basis(z: Sequence[float]) -> list[float]:
    """zeta(z): the 10 quadratic terms of section 4 (Kronecker-product basis, zeta(0) = 0)."""
    a, b, c, d = z
    return [a * a, a * b, a * c, a * d, b * b, b * c, b * d, c * c, c * d, d * d]


def basis_jacobian(z: Sequence[float]) -> np.ndarray:
    """d zeta / d z as a 10 x 4 array (row k = gradient of zeta_k). The controller uses the
    contracted forms below instead; this is for tests and offline analysis."""
    a, b, c, d = z
    return np.array([
        [2 * a, 0, 0, 0],
        [b, a, 0, 0],
        [c, 0, a, 0],
        [d, 0, 0, a],
        [0, 2 * b, 0, 0],
        [0, c, b, 0],
        [0, d, 0, b],
        [0, 0, 2 * c, 0],
        [0, 0, d, c],
        [0, 0, 0, 2 * d],
    ], dtype=float)


def basis_directional(z: Sequence[float], v: Sequence[float]) -> list[float]:
    """(d zeta / d z) v: the 10-vector eta = grad(zeta) zdot of eqs. (29)-(31) when v = zdot, and
    the stabilising direction grad(zeta) G z of eq. (31) when v = G z."""
    a, b, c, d = z
    p, q, u, w = v
    return [
        2.0 * a * p,
        a * q + b * p,
        a * u + c * p,
        a * w + d * p,
        2.0 * b * q,
        b * u + c * q,
        b * w + d * q,
        2.0 * c * u,
        c * w + d * u,
        2.0 * d * w,
    ]


def value_gradient(z: Sequence[float], W: Sequence[float]) -> tuple[float, float, float, float]:
    """grad J_hat(z) = (d zeta / d z)^T W for the critic J_hat = W^T zeta(z) of eq. (27)."""
    a, b, c, d = z
    w1, w2, w3, w4, w5, w6, w7, w8, w9, w10 = W
    return (
        2.0 * a * w1 + b * w2 + c * w3 + d * w4,
        a * w2 + 2.0 * b * w5 + c * w6 + d * w7,
        a * w3 + b * w6 + 2.0 * c * w8 + d * w9,
        a * w4 + b * w7 + c * w9 + 2.0 * d * w10,
    )


def policy_arguments(z: Sequence[float], W: Sequence[float], dinv: Sequence[float], s: float,
                     r: Sequence[float]) -> tuple[float, float, float, float]:
    """The arguments x of the saturated law (28), mu_hat = -s tanh(x) with
    x = R^-1 g^T grad(zeta)^T W / (2 s), g = diag(I, D^-1); dinv = (D^-1_11, D^-1_12, D^-1_22)."""
    i11, i12, i22 = dinv
    g1, g2, g3, g4 = value_gradient(z, W)
    return (g1 / (2.0 * s * r[0]), g2 / (2.0 * s * r[1]),
            (i11 * g3 + i12 * g4) / (2.0 * s * r[2]), (i12 * g3 + i22 * g4) / (2.0 * s * r[3]))


def tanh_law(x: Sequence[float], s: float) -> tuple[float, float, float, float]:
    """The saturated law (28): mu_hat = -s tanh(x) componentwise."""
    return -s * math.tanh(x[0]), -s * math.tanh(x[1]), -s * math.tanh(x[2]), -s * math.tanh(x[3])


def error_rate(z: Sequence[float], mu: Sequence[float], fe: Sequence[float], dinv: Sequence[float],
               lam1: Sequence[float], lam2: Sequence[float], backstepping: bool) -> tuple[float, float, float, float]:
    """zdot = F_bar(z) + g mu of eqs. (6)/(7) with the coupling terms +z_v, -z_phi of (6):
    mu = (chi_vd*_1, chi_vd*_2, tau_1, tau_2), fe = F_v(z_phi, z_v), g_v = D^-1 (dinv as above);
    ``backstepping``: chi_vd^a = dphi_d - Lambda1 z_phi (else dphi_d + Lambda1 z_v, as printed)."""
    zp1, zp2, zv1, zv2 = z
    i11, i12, i22 = dinv
    if backstepping:
        zd1 = -lam1[0] * zp1 + mu[0] + zv1
        zd2 = -lam1[1] * zp2 + mu[1] + zv2
    else:
        zd1 = lam1[0] * zv1 + mu[0] + zv1
        zd2 = lam1[1] * zv2 + mu[1] + zv2
    return (zd1, zd2, fe[0] - lam2[0] * zv1 - zp1 + i11 * mu[2] + i12 * mu[3],
            fe[1] - lam2[1] * zv2 - zp2 + i12 * mu[2] + i22 * mu[3])


def printed_rate(z: Sequence[float], zd: Sequence[float]) -> tuple[float, float, float, float]:
    """F_bar of (7) as printed: zdot of (6) without the coupling terms +z_v and -z_phi."""
    return zd[0] - z[2], zd[1] - z[3], zd[2] + z[0], zd[3] + z[1]


def value_hessian(W: Sequence[float]) -> tuple[tuple[float, ...], ...]:
    """d^2 J_hat / d z^2 = 2 S(W) (constant for the quadratic basis), as a 4x4 tuple of rows."""
    w1, w2, w3, w4, w5, w6, w7, w8, w9, w10 = W
    return (
        (2.0 * w1, w2, w3, w4),
        (w2, 2.0 * w5, w6, w7),
        (w3, w6, 2.0 * w8, w9),
        (w4, w7, w9, 2.0 * w10),
    )


def weights_to_matrix(W: Sequence[float]) -> np.ndarray:
    """The symmetric S with W^T zeta(z) = z^T S z (so a critic is a valid value only if S >= 0)."""
    S = np.zeros((4, 4))
    for w, (i, j) in zip(W, BASIS_PAIRS):
        if i == j:
            S[i, i] = w
        else:
            S[i, j] = S[j, i] = 0.5 * w
    return S


def matrix_to_weights(S: np.ndarray) -> np.ndarray:
    """Inverse of ``weights_to_matrix`` for a symmetric S (e.g. an LQR Riccati solution)."""
    S = 0.5 * (np.asarray(S, dtype=float) + np.asarray(S, dtype=float).T)
    return np.array([S[i, i] if i == j else 2.0 * S[i, j] for i, j in BASIS_PAIRS])


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
    return _bisect(lambda x: x - k * math.tanh(x) - c, -b, b, -1.0)


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
        return x - a0 - kaa * math.tanh(x)

    def t_b(x: float) -> float:
        return min(1.0, max(-1.0, h(x) / kab))

    def phi(x: float) -> float:
        tb = t_b(x)
        return tb - math.tanh(b0 + kba * math.tanh(x) + kbb * tb)

    L = abs(a0) + abs(kaa) + K + 1.0  # |h(x)| > K for |x| >= L
    if kaa > 1.0:
        xs = math.atanh(math.sqrt(1.0 - 1.0 / kaa))
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
            return math.tanh(lo), t_b(lo)
        if f_hi == 0.0:
            return math.tanh(hi), t_b(hi)
        if (f_lo < 0.0) != (f_hi < 0.0):
            x = _bisect(phi, lo, hi, f_lo)
            return math.tanh(x), t_b(x)
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
        t1 = math.tanh(_solve_tanh_1d(x01 + k12 * t2, k11))
        t2 = math.tanh(_solve_tanh_1d(x02 + k21 * t1, k22))
    return t1, t2


# --- probing signal of section 4 ------------------------------------------------------------------


def probing_signal(t: float, amplitude: float = 0.5) -> float:
    """The PE noise of section 4 (the paper's factor 0.5 is ``amplitude``):

    PE = 0.5 (sin^2 t cos t + sin^2(2t) cos(0.1t) + sin^2(1.2t) cos(0.5t) + sin^5 t
              + sin^2(1.12t) + cos(2.4t) sin^3(2.4t))
    """
    s1 = math.sin(t)
    s2 = math.sin(2.0 * t)
    s12 = math.sin(1.2 * t)
    s112 = math.sin(1.12 * t)
    s24 = math.sin(2.4 * t)
    return amplitude * (
        s1 * s1 * math.cos(t)
        + s2 * s2 * math.cos(0.1 * t)
        + s12 * s12 * math.cos(0.5 * t)
        + s1 ** 5
        + s112 * s112
        + math.cos(2.4 * t) * s24 ** 3
    )


def implicit_system(W: list, wdot: list, xi: list, eta: list, M: list, with_cl: bool, dt: float, c: float,
                    G: list, rhs: list) -> None:
    """The linear system (I + c Gamma) W+ = W + dt dW/dt + c Gamma W of ``advance``, c = dt alpha1,
    Gamma = xi eta^T (+ M, the CL matrix, when the CL sum entered dW/dt); G (flat) and rhs receive it."""
    N = N_BASIS
    for a in range(N):
        for k in range(a + 1):
            g = xi[a] * eta[k] + M[a * N + k] if with_cl else xi[a] * eta[k]
            G[a * N + k] = c * g
            G[k * N + a] = c * g
    for a in range(N):
        acc = 0.0
        for k in range(N):
            acc += G[a * N + k] * W[k]
        rhs[a] = W[a] + dt * wdot[a] + acc
    for a in range(N):
        G[a * N + a] += 1.0


def dot_sequence(a: Sequence[float], b: Sequence[float]) -> float:
    """sum_k a_k b_k over the shorter of the two, left to right (``sum`` rounds differently from
    Python 3.12 on, numpy's ``dot`` per BLAS kernel)."""
    acc = 0.0
    for k in range(min(len(a), len(b))):
        acc += a[k] * b[k]
    return acc
