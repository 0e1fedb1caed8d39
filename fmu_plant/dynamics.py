"""Two-link arm dynamics of the SOTC paper, eq. (1) with the matrices of eq. (46).

    D(phi) ddphi + H(phi, dphi) dphi + G(dphi) = tau + d                       eq. (1)

Reference: N. D. Dien, N. T. Luy, L. K. Lai, T. T. Hai, "Optimal tracking control for robot
manipulators with input constraint based reinforcement learning", J. Computer Science and
Cybernetics, 2023 (``shared/reference/sotc-paper.md``), section 4, eq. (46); the model itself is
that of Modares, Lewis & Jiang (the paper's ref. [12]).

Symbols follow the paper: ``p1, p2, p3`` are its varrho_1..3 (kg m^2), ``f1, f2`` the Coulomb-like
friction gains of G, ``b1, b2`` optional viscous friction (not in the paper, default 0), ``d`` an
external disturbance torque added to tau.

Everything here is scalar float math on purpose: for 2x2 matrices, ``math`` on floats is about
ten times faster than numpy on tiny arrays, and the plant FMU evaluates the right-hand side four
times per RK4 substep. Matrix-valued helpers (``inertia_matrix`` ...) wrap the same scalar
formulas for the controllers and tests.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np

from fmu_plant.parameters import ParameterError, ParameterSpec, check_all, nonnegative, positive

ARM_PARAMETER_SPECS: tuple[ParameterSpec, ...] = (
    positive("p1", 3.473, "kg.m2", "Inertia parameter varrho_1 of D(phi), eq. (46)", high=1e3),
    positive("p2", 0.196, "kg.m2", "Inertia parameter varrho_2 of D(phi), eq. (46)", high=1e3),
    positive("p3", 0.242, "kg.m2", "Coupling inertia varrho_3 of D(phi) and H(phi, dphi), eq. (46)", high=1e3),
    nonnegative("f1", 8.45, "N.m", "Friction gain of joint 1: G1 = f1 tanh(dphi1), eq. (46)", high=1e3),
    nonnegative("f2", 2.35, "N.m", "Friction gain of joint 2: G2 = f2 tanh(dphi2), eq. (46)", high=1e3),
    nonnegative("b1", 0.0, "N.m.s/rad", "Viscous friction of joint 1 (not in the paper; 0 reproduces it)", high=1e3),
    nonnegative("b2", 0.0, "N.m.s/rad", "Viscous friction of joint 2 (not in the paper; 0 reproduces it)", high=1e3),
    positive("l1", 1.0, "m", "Length of link 1, eqs. (48)-(49)", high=100.0),
    positive("l2", 1.0, "m", "Length of link 2, eqs. (48)-(49)", high=100.0),
)


@dataclass(frozen=True)
class ArmParameters:
    """Physical constants of the arm; defaults are the paper's section 4 values.

    Construction validates every value (finite, in range) and that D(phi) is positive definite for
    every phi, i.e. p2 (p1 - p2) > p3^2 (det D = p2 (p1 - p2) - p3^2 cos^2 phi2).
    """

    p1: float = 3.473
    p2: float = 0.196
    p3: float = 0.242
    f1: float = 8.45
    f2: float = 2.35
    b1: float = 0.0
    b2: float = 0.0
    l1: float = 1.0
    l2: float = 1.0

    def __post_init__(self) -> None:
        checked = check_all(ARM_PARAMETER_SPECS, {f.name: getattr(self, f.name) for f in fields(self)})
        for name, value in checked.items():
            object.__setattr__(self, name, value)
        margin = self.p2 * (self.p1 - self.p2) - self.p3**2
        if not margin > 0.0:
            raise ParameterError(
                "p3",
                f"p2 (p1 - p2) = {self.p2 * (self.p1 - self.p2):g} must exceed p3^2 = {self.p3**2:g}, "
                "otherwise D(phi) is singular for some phi (valid range: p3 < sqrt(p2 (p1 - p2)))",
            )

    @classmethod
    def from_mapping(cls, values: dict[str, float]) -> "ArmParameters":
        known = {f.name for f in fields(cls)}
        for name in values:
            if name not in known:
                raise ParameterError(name, f"unknown arm parameter; known: {', '.join(sorted(known))}")
        return cls(**values)


def inertia_entries(phi2: float, p: ArmParameters) -> tuple[float, float, float]:
    """(d11, d12, d22) of the symmetric inertia matrix D(phi), eq. (46)."""
    c2 = math.cos(phi2)
    return p.p1 + 2.0 * p.p3 * c2, p.p2 + p.p3 * c2, p.p2


def coriolis_entries(phi2: float, dphi1: float, dphi2: float, p: ArmParameters) -> tuple[float, float, float]:
    """(h11, h12, h21) of H(phi, dphi), eq. (46); h22 = 0. H is the Christoffel form: dD/dt - 2H is skew."""
    k = p.p3 * math.sin(phi2)
    return -k * dphi2, -k * (dphi1 + dphi2), k * dphi1


def friction_torque(dphi1: float, dphi2: float, p: ArmParameters) -> tuple[float, float]:
    """G(dphi) of eq. (46), plus the optional viscous terms b_i dphi_i."""
    return (p.f1 * math.tanh(dphi1) + p.b1 * dphi1, p.f2 * math.tanh(dphi2) + p.b2 * dphi2)


def bias_torque(phi2: float, dphi1: float, dphi2: float, p: ArmParameters) -> tuple[float, float]:
    """H(phi, dphi) dphi + G(dphi): every torque term of eq. (1) that is not inertial."""
    h11, h12, h21 = coriolis_entries(phi2, dphi1, dphi2, p)
    g1, g2 = friction_torque(dphi1, dphi2, p)
    return h11 * dphi1 + h12 * dphi2 + g1, h21 * dphi1 + g2


def solve_inertia(phi2: float, r1: float, r2: float, p: ArmParameters) -> tuple[float, float]:
    """D(phi)^-1 [r1, r2] by the closed-form 2x2 inverse."""
    d11, d12, d22 = inertia_entries(phi2, p)
    det = d11 * d22 - d12 * d12
    return (d22 * r1 - d12 * r2) / det, (d11 * r2 - d12 * r1) / det


def forward_dynamics(
    phi2: float, dphi1: float, dphi2: float, tau1: float, tau2: float, p: ArmParameters
) -> tuple[float, float]:
    """ddphi from eq. (1): ddphi = D^-1 (tau - H dphi - G). (phi1 does not enter the dynamics.)"""
    c1, c2 = bias_torque(phi2, dphi1, dphi2, p)
    return solve_inertia(phi2, tau1 - c1, tau2 - c2, p)


def inverse_dynamics(
    phi2: float, dphi1: float, dphi2: float, ddphi1: float, ddphi2: float, p: ArmParameters
) -> tuple[float, float]:
    """tau = D ddphi + H dphi + G, eq. (1) solved for the torque."""
    d11, d12, d22 = inertia_entries(phi2, p)
    c1, c2 = bias_torque(phi2, dphi1, dphi2, p)
    return d11 * ddphi1 + d12 * ddphi2 + c1, d12 * ddphi1 + d22 * ddphi2 + c2


def rk4_step(
    state: tuple[float, float, float, float],
    tau1: float,
    tau2: float,
    dt: float,
    substeps: int,
    p: ArmParameters,
) -> tuple[float, float, float, float]:
    """Advance (phi1, phi2, dphi1, dphi2) by ``dt`` with the torque held constant (zero-order hold).

    Classic fixed-step RK4 with ``substeps`` equal substeps; the method and the default number of
    substeps were chosen by measurement against DOP853 (``docs/integration.md``).
    """
    q1, q2, w1, w2 = state
    h = dt / substeps
    half = 0.5 * h
    sixth = h / 6.0
    for _ in range(substeps):
        a1, a2 = forward_dynamics(q2, w1, w2, tau1, tau2, p)
        k2q2, k2w1, k2w2 = q2 + half * w2, w1 + half * a1, w2 + half * a2
        b1, b2 = forward_dynamics(k2q2, k2w1, k2w2, tau1, tau2, p)
        k3q2, k3w1, k3w2 = q2 + half * k2w2, w1 + half * b1, w2 + half * b2
        c1, c2 = forward_dynamics(k3q2, k3w1, k3w2, tau1, tau2, p)
        k4q2, k4w1, k4w2 = q2 + h * k3w2, w1 + h * c1, w2 + h * c2
        e1, e2 = forward_dynamics(k4q2, k4w1, k4w2, tau1, tau2, p)
        q1 += sixth * (w1 + 2.0 * k2w1 + 2.0 * k3w1 + k4w1)
        q2 += sixth * (w2 + 2.0 * k2w2 + 2.0 * k3w2 + k4w2)
        w1 += sixth * (a1 + 2.0 * b1 + 2.0 * c1 + e1)
        w2 += sixth * (a2 + 2.0 * b2 + 2.0 * c2 + e2)
    return q1, q2, w1, w2


# --- matrix views of the same formulas (controllers, tests) -------------------------------------


def inertia_matrix(phi2: float, p: ArmParameters) -> np.ndarray:
    """D(phi) of eq. (46) as a 2x2 array."""
    d11, d12, d22 = inertia_entries(phi2, p)
    return np.array([[d11, d12], [d12, d22]])


def coriolis_matrix(phi2: float, dphi1: float, dphi2: float, p: ArmParameters) -> np.ndarray:
    """H(phi, dphi) of eq. (46) as a 2x2 array."""
    h11, h12, h21 = coriolis_entries(phi2, dphi1, dphi2, p)
    return np.array([[h11, h12], [h21, 0.0]])
