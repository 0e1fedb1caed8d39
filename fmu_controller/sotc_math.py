# cython: boundscheck=False, wraparound=False, cdivision=True
"""Closed-form maths of the SOTC paper: saturated cost, quadratic critic basis, the critic's sample
(error rate, eta, reward; ``critic_row``), probing signal.

Reference: N. D. Dien, N. T. Luy, L. K. Lai, T. T. Hai, "Optimal tracking control for robot
manipulators with input constraint based reinforcement learning", J. Computer Science and
Cybernetics, 2023. Equation numbers below are the paper's.

Everything is plain float code on 4-vectors ``z = (z_phi1, z_phi2, z_v1, z_v2)``: for vectors this
small, ``math`` on floats is several times faster than numpy, and the controller calls these
functions 10,000 times per simulated run. The kernels take scalars and float64 buffers (typed as C
doubles by ``sotc_math.pxd`` when compiled, so a sample creates no Python object); the versions on
sequences (``basis_directional``, ``value_gradient``, ``omega_of_arg``) are thin wrappers for tests and
the other controllers. exp, log, tanh, sin ... are ``elementary``'s, not libm's, so every machine gives the
same bits (docs/paper-notes.md, section 2.10b).

Compiled, the kernels index their buffers without bounds checks and divide without a zero test (the
directive on the first line, inert in Python): every index is a fixed offset below the sizes the
controller and its CL stack allocate (N_BASIS weights, rows of N_BASIS), weights given as a sequence
have their number checked (``weights_buffer``), and every denominator is positive (1 + e^{-2|x|}; 2 s r_i,
which ``CriticConstants`` checks once). So the kernels that call neither sin nor cos (whose reduction of
huge arguments uses Python integers) nor the interpreted paths have no path that raises.

Symbols: ``s`` is the saturation level of the optimal input (sigma in the chosen reading, see
``docs/paper-notes.md``), ``x`` the *pre-saturation argument* of the control law (28), i.e.
``mu = -s tanh(x)``.
"""
from __future__ import annotations

import math
from array import array
from typing import Sequence

import numpy as np

from fmu_numerics.elementary import INTERPRETED, atanh, cos, exp, log, log1p, sin, sinh, tanh
from fmu_numerics.fixed_linalg import as_buffer, buffer

if INTERPRETED:  # the Python build's numpy path of the weight step (the same bits)
    from fmu_controller.sotc_math_interpreted import implicit_system_array

LN2 = log(2.0)

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
        h = sinh(0.5 * a)
        return log1p(2.0 * h * h)
    return a + log1p(exp(-2.0 * a)) - LN2


def _x_tanh_minus_log_cosh(x: float, t: float) -> float:
    """x tanh x - ln cosh x (>= 0, even, -> ln 2 as |x| -> inf) for t = tanh x, which the policy (28) has
    computed already: ``elementary.tanh`` is odd to the bit, so |t| is tanh |x|. Accurate for every finite x:
    for |x| >= 1 it is rewritten with e = e^{-2|x|} as ln 2 - ln(1 + e) - 2|x| e / (1 + e), which avoids
    subtracting two numbers of size |x|."""
    a = abs(x)
    if a < 1.0:
        return a * abs(t) - log_cosh(a)
    e = exp(-2.0 * a)
    return LN2 - log1p(e) - 2.0 * a * e / (1.0 + e)


def omega_term(x: float, t: float, s: float, r: float) -> float:
    """One component of Omega, eq. (17), written in the pre-saturation argument x of mu = -s tanh x
    (t = tanh x).

    With mu = -s tanh x, atanh(mu/s) = -x and ln(1 - mu^2/s^2) = ln(1 - tanh^2 x) = -2 ln cosh x, so
        2 s atanh(mu/s) r mu + s^2 r ln(1 - mu^2/s^2) = 2 s^2 r (x tanh x - ln cosh x)   eq. (17)
    which stays finite (-> 2 s^2 r ln 2) even where tanh x rounds to +-1.
    """
    return 2.0 * s * s * r * _x_tanh_minus_log_cosh(x, t)


def omega_term_of_arg(x: float, s: float, r: float) -> float:
    """``omega_term`` of x alone."""
    return omega_term(x, tanh(x), s, r)


def omega4(x1: float, x2: float, x3: float, x4: float, t1: float, t2: float, t3: float, t4: float, s: float,
           r1: float, r2: float, r3: float, r4: float) -> float:
    """Omega(mu) of eq. (17) for mu = -s tanh(x) (componentwise, t = tanh(x)), R = diag(r), summed in order."""
    return (omega_term(x1, t1, s, r1) + omega_term(x2, t2, s, r2)
            + omega_term(x3, t3, s, r3) + omega_term(x4, t4, s, r4))


def omega_of_arg(x: Sequence[float], s: float, r: Sequence[float]) -> float:
    """``omega4`` on sequences."""
    return omega4(x[0], x[1], x[2], x[3], tanh(x[0]), tanh(x[1]), tanh(x[2]), tanh(x[3]), s, r[0], r[1], r[2], r[3])


def reward(K: CriticConstants, zp1: float, zp2: float, zv1: float, zv2: float, x1: float, x2: float, x3: float,
           x4: float, t1: float, t2: float, t3: float, t4: float) -> tuple[float, float]:
    """(r, Omega): the cost rate r = z^T Theta z + Omega(mu_hat) of eq. (12) with Omega of (17) at the
    pre-saturation arguments x of (28) (t = tanh(x)), Theta = diag(theta)."""
    omega = omega4(x1, x2, x3, x4, t1, t2, t3, t4, K.s, K.r1, K.r2, K.r3, K.r4)
    return (K.theta1 * zp1 * zp1 + K.theta2 * zp2 * zp2 + K.theta3 * zv1 * zv1 + K.theta4 * zv2 * zv2) + omega, omega


def omega_of_mu(mu: Sequence[float], s: float, r: Sequence[float]) -> float:
    """Omega(mu) of eq. (17) from mu itself; requires |mu_i| < s (else +inf, the cost's barrier).

        Omega(mu) = sum_i 2 s r_i mu_i atanh(mu_i / s) + s^2 r_i ln(1 - mu_i^2 / s^2)      eq. (17)
    """
    total = 0.0
    for m, ri in zip(mu, r):
        q = m / s
        if not abs(q) < 1.0:
            return math.inf
        total += 2.0 * s * ri * m * atanh(q) + s * s * ri * log1p(-q * q)
    return total


def omega_integrand(u: float, s: float, r: float) -> float:
    """Integrand of eq. (13) for one component: 2 s r atanh(u / s). (For quadrature in tests.)"""
    return 2.0 * s * r * atanh(u / s)


# --- critic basis of section 4, eq. (27) ----------------------------------------------------------


def basis_into(out, a: float, b: float, c: float, d: float) -> None:
    """out[0:10] = zeta(z) at z = (a, b, c, d): the 10 quadratic terms of section 4 (Kronecker-product
    basis, zeta(0) = 0); ``out`` is a float64 buffer."""
    out[0], out[1], out[2], out[3], out[4] = a * a, a * b, a * c, a * d, b * b
    out[5], out[6], out[7], out[8], out[9] = b * c, b * d, c * c, c * d, d * d


def basis(z: Sequence[float]) -> list[float]:
    """zeta(z) of ``basis_into`` on a sequence, as a list."""
    out = buffer(N_BASIS)
    basis_into(out, z[0], z[1], z[2], z[3])
    return out.tolist()


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


def directional_into(out, o: int, a: float, b: float, c: float, d: float, p: float, q: float, u: float,
                     w: float) -> None:
    """out[o:o + 10] = (d zeta / d z) v at z = (a, b, c, d), v = (p, q, u, w): the 10-vector
    eta = grad(zeta) zdot of eqs. (29)-(31) when v = zdot, and the stabilising direction grad(zeta) G z
    of eq. (31) when v = G z; ``out`` is a float64 buffer (``fixed_linalg.buffer``)."""
    out[o] = 2.0 * a * p
    out[o + 1] = a * q + b * p
    out[o + 2] = a * u + c * p
    out[o + 3] = a * w + d * p
    out[o + 4] = 2.0 * b * q
    out[o + 5] = b * u + c * q
    out[o + 6] = b * w + d * q
    out[o + 7] = 2.0 * c * u
    out[o + 8] = c * w + d * u
    out[o + 9] = 2.0 * d * w


def basis_directional(z: Sequence[float], v: Sequence[float]) -> list[float]:
    """``directional_into`` on sequences, as a list."""
    out = buffer(N_BASIS)
    directional_into(out, 0, z[0], z[1], z[2], z[3], v[0], v[1], v[2], v[3])
    return out.tolist()


def gradient(a: float, b: float, c: float, d: float, W: array) -> tuple[float, float, float, float]:
    """grad J_hat(z) = (d zeta / d z)^T W at z = (a, b, c, d) for the critic J_hat = W^T zeta(z) of
    eq. (27); W is a float64 buffer."""
    return (
        2.0 * a * W[0] + b * W[1] + c * W[2] + d * W[3],
        a * W[1] + 2.0 * b * W[4] + c * W[5] + d * W[6],
        a * W[2] + b * W[5] + 2.0 * c * W[7] + d * W[8],
        a * W[3] + b * W[6] + c * W[8] + 2.0 * d * W[9],
    )


def value_gradient(z: Sequence[float], W: Sequence[float]) -> tuple[float, float, float, float]:
    """``gradient`` on sequences (W: the N_BASIS weights)."""
    return gradient(z[0], z[1], z[2], z[3], weights_buffer(W))


def weights_buffer(W: Sequence[float]) -> array:
    """The critic's weights given as any sequence, as a float64 buffer, their number checked: compiled, the
    kernels read them without bounds checks."""
    if len(W) != N_BASIS:
        raise ValueError(f"W has {len(W)} weights, the critic {N_BASIS}")
    return as_buffer(W)


class CriticConstants:
    """The SOTC's constants that its critic formulas read, in one place (the controller and its CL
    replay share one instance): saturation level s, R = diag(r1..r4) of (13), Theta = diag(theta1..theta4)
    of (12), Lambda_1, Lambda_2 of (4), the reading of chi_vd^a (``backstepping``) and the form of zdot
    in eta (``coupled``: with the coupling terms +z_v, -z_phi of (6), else F_bar of (7) as printed)."""

    def __init__(self, s: float, r: Sequence[float], theta: Sequence[float], lam1: Sequence[float],
                 lam2: Sequence[float], backstepping: bool, coupled: bool):
        if not all(2.0 * s * r_i > 0.0 for r_i in r):  # the denominators of ``policy_arguments``
            raise ValueError(f"s = {s!r} and r = {tuple(r)!r} must be positive, with 2 s r_i > 0")
        self.s = s
        self.r1, self.r2, self.r3, self.r4 = r
        self.theta1, self.theta2, self.theta3, self.theta4 = theta
        self.lam11, self.lam12 = lam1
        self.lam21, self.lam22 = lam2
        self.backstepping, self.coupled = backstepping, coupled


def policy_arguments(K: CriticConstants, zp1: float, zp2: float, zv1: float, zv2: float, W: array, i11: float,
                     i12: float, i22: float) -> tuple[float, float, float, float]:
    """The arguments x of the saturated law (28), mu_hat = -s tanh(x) with
    x = R^-1 g^T grad(zeta)^T W / (2 s), g = diag(I, D^-1); (i11, i12, i22) = (D^-1_11, D^-1_12, D^-1_22)."""
    s = K.s
    g1, g2, g3, g4 = gradient(zp1, zp2, zv1, zv2, W)
    return (g1 / (2.0 * s * K.r1), g2 / (2.0 * s * K.r2),
            (i11 * g3 + i12 * g4) / (2.0 * s * K.r3), (i12 * g3 + i22 * g4) / (2.0 * s * K.r4))


def error_rate(K: CriticConstants, zp1: float, zp2: float, zv1: float, zv2: float, mu1: float, mu2: float,
               mu3: float, mu4: float, fe1: float, fe2: float, i11: float, i12: float,
               i22: float) -> tuple[float, float, float, float]:
    """zdot = F_bar(z) + g mu of eqs. (6)/(7) with the coupling terms +z_v, -z_phi of (6):
    mu = (chi_vd*_1, chi_vd*_2, tau_1, tau_2), fe = F_v(z_phi, z_v), g_v = D^-1 (entries as above);
    ``K.backstepping``: chi_vd^a = dphi_d - Lambda1 z_phi (else dphi_d + Lambda1 z_v, as printed)."""
    if K.backstepping:
        zd1 = -K.lam11 * zp1 + mu1 + zv1
        zd2 = -K.lam12 * zp2 + mu2 + zv2
    else:
        zd1 = K.lam11 * zv1 + mu1 + zv1
        zd2 = K.lam12 * zv2 + mu2 + zv2
    return (zd1, zd2, fe1 - K.lam21 * zv1 - zp1 + i11 * mu3 + i12 * mu4,
            fe2 - K.lam22 * zv2 - zp2 + i12 * mu3 + i22 * mu4)


def critic_row(K: CriticConstants, zp1: float, zp2: float, zv1: float, zv2: float, x1: float, x2: float,
               x3: float, x4: float, t1: float, t2: float, t3: float, t4: float, mu1: float, mu2: float, mu3: float,
               mu4: float, fe1: float, fe2: float, i11: float, i12: float, i22: float, eta,
               o: int) -> tuple[float, float, float, float, float, float]:
    """One sample of the critic, for the controller and for each row of its CL replay alike: the error
    rate zdot of (6)/(7) (``error_rate``), eta = grad(zeta) zdot of (29) into eta[o:o + 10] (with zdot as
    ``K.coupled`` says: (6), or F_bar of (7) as printed, without +z_v, -z_phi), and the reward of (12)/(17)
    at the tanh arguments x of (28), t = tanh(x). Returns (zdot_1..4, r, Omega)."""
    zd1, zd2, zd3, zd4 = error_rate(K, zp1, zp2, zv1, zv2, mu1, mu2, mu3, mu4, fe1, fe2, i11, i12, i22)
    if K.coupled:
        directional_into(eta, o, zp1, zp2, zv1, zv2, zd1, zd2, zd3, zd4)
    else:  # F_bar of (7) as printed: zdot of (6) without the coupling terms +z_v and -z_phi
        directional_into(eta, o, zp1, zp2, zv1, zv2, zd1 - zv1, zd2 - zv2, zd3 + zp1, zd4 + zp2)
    rew, omega = reward(K, zp1, zp2, zv1, zv2, x1, x2, x3, x4, t1, t2, t3, t4)
    return zd1, zd2, zd3, zd4, rew, omega


def normalisation(ee: float) -> float:
    """(1 + eta^T eta)^2 for ee = eta^T eta: the normaliser of the tuning laws (30)/(31),
    xi = eta / (1 + eta^T eta)^2 (and of each CL row)."""
    return (ee + 1.0) * (ee + 1.0)


def value_hessian(W: Sequence[float]) -> tuple[tuple[float, ...], ...]:
    """d^2 J_hat / d z^2 = 2 S(W) (constant for the quadratic basis), as a 4x4 tuple of rows."""
    w1, w2, w3, w4, w5, w6, w7, w8, w9, w10 = W
    return (
        (2.0 * w1, w2, w3, w4),
        (w2, 2.0 * w5, w6, w7),
        (w3, w6, 2.0 * w8, w9),
        (w4, w7, w9, 2.0 * w10),
    )


def hessian_phi_times(W: array, v1: float, v2: float, v3: float, v4: float) -> tuple[float, float]:
    """The z_phi rows of value_hessian(W) v, summed left to right (the chain rule of chi_vd* in ``sotc``)."""
    return (2.0 * W[0] * v1 + W[1] * v2 + W[2] * v3 + W[3] * v4,
            W[1] * v1 + 2.0 * W[4] * v2 + W[5] * v3 + W[6] * v4)


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


# --- probing signal of section 4 ------------------------------------------------------------------


def probing_signal(t: float, amplitude: float = 0.5) -> float:
    """The PE noise of section 4 (the paper's factor 0.5 is ``amplitude``):

    PE = 0.5 (sin^2 t cos t + sin^2(2t) cos(0.1t) + sin^2(1.2t) cos(0.5t) + sin^5 t
              + sin^2(1.12t) + cos(2.4t) sin^3(2.4t))
    """
    s1 = sin(t)
    s2 = sin(2.0 * t)
    s12 = sin(1.2 * t)
    s112 = sin(1.12 * t)
    s24 = sin(2.4 * t)
    return amplitude * (
        s1 * s1 * cos(t)
        + s2 * s2 * cos(0.1 * t)
        + s12 * s12 * cos(0.5 * t)
        + s1 * s1 * s1 * s1 * s1
        + s112 * s112
        + cos(2.4 * t) * (s24 * s24 * s24)
    )


def implicit_system(W: array, wdot: array, xi: array, eta: array, M: array, with_cl: bool, dt: float, c: float,
                    G: array, rhs: array) -> None:
    """The linear system (I + c Gamma) W+ = W + dt dW/dt + c Gamma W of ``advance``, c = dt alpha1,
    Gamma = xi eta^T (+ M, the CL matrix, when the CL sum entered dW/dt); G (flat) and rhs receive it.
    The interpreted core takes ``sotc_math_interpreted.implicit_system_array`` (the same bits)."""
    if INTERPRETED:
        implicit_system_array(W, wdot, xi, eta, M, with_cl, dt, c, G, rhs)
        return
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
