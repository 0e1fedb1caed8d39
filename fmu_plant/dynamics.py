"""Two-link arm dynamics of the SOTC paper, eq. (1) with the matrices of eq. (46).

    D(phi) ddphi + H(phi, dphi) dphi + G(dphi) = tau + d                       eq. (1)

Reference: N. D. Dien, N. T. Luy, L. K. Lai, T. T. Hai, "Optimal tracking control for robot
manipulators with input constraint based reinforcement learning", J. Computer Science and
Cybernetics, 2023, section 4, eq. (46); the model itself is
that of Modares, Lewis & Jiang (the paper's ref. [12]).

Symbols follow the paper: ``p1, p2, p3`` are its varrho_1..3 (kg m^2), ``f1, f2`` the Coulomb-like
friction gains of G, ``b1, b2`` optional viscous friction (not in the paper, default 0), ``d`` an
external disturbance torque added to tau.

Everything here is scalar float math on purpose: for 2x2 matrices, float arithmetic is about ten times
faster than numpy on tiny arrays, and the plant FMU evaluates the right-hand side four times per RK4
substep. cos, sin, sincos, tanh and hypot are ``fmu_numerics.elementary``'s (the same bits on every machine,
unlike libm's; docs/paper-notes.md, section 2.10b). Matrix-valued helpers (``inertia_matrix`` ...) wrap the same scalar
formulas for the controllers and tests.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np

from fmi_slave.parameters import (
    ParameterError,
    ParameterSpec,
    check_all,
    nonnegative,
    positive,
)
from fmu_numerics.elementary import cos, hypot, sin, sincos, tanh

# T and rho, re-exported: the arm model is what a controller imports from fmu_plant
from fmu_plant.paper_setting import STEP_SIZE as STEP_SIZE
from fmu_plant.paper_setting import TORQUE_LIMIT as TORQUE_LIMIT

Coefficients = tuple[float, float, float, float, float, float, float]  # (p1, p2, p3, f1, f2, b1, b2)
MAX_SUBSTEPS = 1000  # RK4 substeps per communication step, at most (a bound independent of the input)
SUBSTEP_STIFFNESS = 1.0  # h L kept at or below this per substep (RK4's real stability limit is 2.785)
MAX_INVERSE_INERTIA = 1e6  # 1/(kg m^2): lambda_min(D(phi)) >= 1e-6 kg m^2 for every phi

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
        margin = self.p2 * (self.p1 - self.p2) - self.p3 * self.p3
        if not margin > 0.0:
            raise ParameterError(
                "p3",
                f"p2 (p1 - p2) = {self.p2 * (self.p1 - self.p2):g} must exceed p3^2 = {self.p3 * self.p3:g}, "
                "otherwise D(phi) is singular for some phi (valid range: p3 < sqrt(p2 (p1 - p2)))",
            )
        # ||D(phi)^-1|| <= tr D / det D <= (p1 + p2 + 2 p3) / margin for every phi (lambda_min >= det / tr)
        inv = (self.p1 + self.p2 + 2.0 * self.p3) / margin
        object.__setattr__(self, "inv_inertia", inv)
        object.__setattr__(self, "coefficients", (self.p1, self.p2, self.p3, self.f1, self.f2, self.b1, self.b2))
        if not inv <= MAX_INVERSE_INERTIA:
            raise ParameterError(
                "p2", f"D(phi) is nearly singular: its smallest eigenvalue can be {1.0 / inv:.3g} kg.m2, below "
                f"{1.0 / MAX_INVERSE_INERTIA:g} (raise p2, or p1 - p2, or lower p3)")
        needed = substeps_needed(0.0, 0.0, 0.0, STEP_SIZE, self)
        if needed > MAX_SUBSTEPS:
            worst = "1" if self.f1 + self.b1 >= self.f2 + self.b2 else "2"
            name = f"b{worst}" if getattr(self, f"b{worst}") > 0.0 else f"f{worst}"
            raise ParameterError(
                name, f"friction {getattr(self, 'f' + worst) + getattr(self, 'b' + worst):g} N.m.s/rad against "
                f"inertia down to {1.0 / inv:.3g} kg.m2 makes the arm too stiff: one {STEP_SIZE} s step would "
                f"need {needed} RK4 substeps (at most {MAX_SUBSTEPS}); lower f{worst}/b{worst} or raise the inertias")

    @classmethod
    def from_mapping(cls, values: dict[str, float]) -> "ArmParameters":
        known = {f.name for f in fields(cls)}
        for name in values:
            if name not in known:
                raise ParameterError(name, f"unknown arm parameter; known: {', '.join(sorted(known))}")
        return cls(**values)


def inertia_entries(phi2: float, p: ArmParameters) -> tuple[float, float, float]:
    """(d11, d12, d22) of the symmetric inertia matrix D(phi), eq. (46)."""
    return _inertia(cos(phi2), p.coefficients)


def coriolis_entries(phi2: float, dphi1: float, dphi2: float, p: ArmParameters) -> tuple[float, float, float]:
    """(h11, h12, h21) of H(phi, dphi), eq. (46); h22 = 0. H is the Christoffel form: dD/dt - 2H is skew."""
    return _coriolis(sin(phi2), dphi1, dphi2, p.coefficients)


def friction_torque(dphi1: float, dphi2: float, p: ArmParameters) -> tuple[float, float]:
    """G(dphi) of eq. (46), plus the optional viscous terms b_i dphi_i."""
    return _friction(dphi1, dphi2, p.coefficients)


def bias_torque(phi2: float, dphi1: float, dphi2: float, p: ArmParameters) -> tuple[float, float]:
    """H(phi, dphi) dphi + G(dphi): every torque term of eq. (1) that is not inertial."""
    return _bias(sin(phi2), dphi1, dphi2, p.coefficients)


def solve_inertia(phi2: float, r1: float, r2: float, p: ArmParameters) -> tuple[float, float]:
    """D(phi)^-1 [r1, r2] by the closed-form 2x2 inverse."""
    return _solve_inertia(cos(phi2), r1, r2, p.coefficients)


def forward_dynamics(
    phi2: float, dphi1: float, dphi2: float, tau1: float, tau2: float, p: ArmParameters
) -> tuple[float, float]:
    """ddphi from eq. (1): ddphi = D^-1 (tau - H dphi - G). (phi1 does not enter the dynamics.)"""
    return _accel(phi2, dphi1, dphi2, tau1, tau2, p.coefficients)


# The formulas, on k = ArmParameters.coefficients = (p1, p2, p3, f1, f2, b1, b2): read once per step by
# the integrator instead of once per term (dynamics.pxd types them when the cores are compiled), and on
# s2 = sin phi2, c2 = cos phi2, which ``_accel`` takes from one reduction of phi2 (``sincos``).

def _inertia(c2: float, k: Coefficients) -> tuple[float, float, float]:
    return k[0] + 2.0 * k[2] * c2, k[1] + k[2] * c2, k[1]  # eq. (46)


def _coriolis(s2: float, dphi1: float, dphi2: float, k: Coefficients) -> tuple[float, float, float]:
    s = k[2] * s2
    return -s * dphi2, -s * (dphi1 + dphi2), s * dphi1  # eq. (46)


def _friction(dphi1: float, dphi2: float, k: Coefficients) -> tuple[float, float]:
    return k[3] * tanh(dphi1) + k[5] * dphi1, k[4] * tanh(dphi2) + k[6] * dphi2  # eq. (46)


def _bias(s2: float, dphi1: float, dphi2: float, k: Coefficients) -> tuple[float, float]:
    h11, h12, h21 = _coriolis(s2, dphi1, dphi2, k)
    g1, g2 = _friction(dphi1, dphi2, k)
    return h11 * dphi1 + h12 * dphi2 + g1, h21 * dphi1 + g2


def _solve_inertia(c2: float, r1: float, r2: float, k: Coefficients) -> tuple[float, float]:
    d11, d12, d22 = _inertia(c2, k)
    det = d11 * d22 - d12 * d12
    return (d22 * r1 - d12 * r2) / det, (d11 * r2 - d12 * r1) / det


def _accel(phi2: float, dphi1: float, dphi2: float, tau1: float, tau2: float, k: Coefficients) -> tuple[float, float]:
    s2, c2 = sincos(phi2)
    b1, b2 = _bias(s2, dphi1, dphi2, k)
    return _solve_inertia(c2, tau1 - b1, tau2 - b2, k)


def inverse_dynamics(
    phi2: float, dphi1: float, dphi2: float, ddphi1: float, ddphi2: float, p: ArmParameters
) -> tuple[float, float]:
    """tau = D ddphi + H dphi + G, eq. (1) solved for the torque."""
    d11, d12, d22 = inertia_entries(phi2, p)
    c1, c2 = bias_torque(phi2, dphi1, dphi2, p)
    return d11 * ddphi1 + d12 * ddphi2 + c1, d12 * ddphi1 + d22 * ddphi2 + c2


class IntegrationError(ValueError):
    """A step the integrator refuses: too stiff for MAX_SUBSTEPS, or the result is not physical."""


def substeps_needed(phi2: float, dphi1: float, dphi2: float, dt: float, p: ArmParameters,
                    tau_norm: float = 0.0) -> int:
    """RK4 substeps that keep h L <= SUBSTEP_STIFFNESS over a step of ``dt`` (RK4 is stable for real
    h L up to 2.785), where L (1/s) bounds the Jacobian of eq. (1) near this state:

    - damping: ||D^-1|| (max_i f_i + b_i + 4 p3 (|dphi1| + |dphi2|)): friction slopes (tanh' <= 1) and the
      Coriolis terms of H(phi, dphi) dphi, whose velocity Jacobian has entries up to 2 p3 |dphi|;
    - position coupling: sqrt(J) with J bounding d ddphi / d phi2 (D and H vary with phi2 through p3).

    ``p.inv_inertia`` bounds ||D(phi)^-1|` for every phi. Returns a count (possibly > MAX_SUBSTEPS)."""
    c, k, w = p.coefficients, p.inv_inertia, abs(dphi1) + abs(dphi2)  # c = (p1, p2, p3, f1, f2, b1, b2)
    p3 = c[2]
    friction = max(c[3] + c[5], c[4] + c[6])
    damping = k * (friction + 4.0 * p3 * w)
    bias = friction + max(c[5], c[6]) * w + 3.0 * p3 * w * w  # bound on |H dphi + G|
    position = math.sqrt(2.0 * p3 * k * k * (tau_norm + bias) + 3.0 * p3 * k * w * w)
    n = dt * (damping + position) / SUBSTEP_STIFFNESS
    return int(math.ceil(n)) if n < MAX_SUBSTEPS + 1 else MAX_SUBSTEPS + 1


def kinetic_energy(phi2: float, dphi1: float, dphi2: float, p: ArmParameters) -> float:
    """1/2 dphi^T D(phi) dphi."""
    d11, d12, d22 = inertia_entries(phi2, p)
    return 0.5 * (d11 * dphi1 * dphi1 + 2.0 * d12 * dphi1 * dphi2 + d22 * dphi2 * dphi2)


def integrate(
    state: tuple[float, float, float, float], tau1: float, tau2: float, dt: float, min_substeps: int,
    p: ArmParameters,
) -> tuple[float, float, float, float]:
    """``rk4_step`` with at least ``min_substeps`` substeps and as many more as the stiffness at this
    state asks (``substeps_needed``), and a physical check of the result; raises IntegrationError
    (naming the reason) instead of returning a blown-up state.

    The check: along eq. (1) dE/dt = dphi^T (tau - G(dphi)) <= dphi^T tau (H is the Christoffel form,
    friction dissipates), so ||dphi||_D = sqrt(2 E) grows by at most dt ||tau|| sqrt(||D^-1||); a
    larger growth (5 % slack for the integration error) is a numerical blow-up, not motion."""
    q1, q2, w1, w2 = state
    tau_norm = hypot(tau1, tau2)
    n = max(min_substeps, substeps_needed(q2, w1, w2, dt, p, tau_norm))
    if n > MAX_SUBSTEPS:
        raise IntegrationError(
            f"the arm at dphi = ({w1:.6g}, {w2:.6g}) rad/s with |tau| = {tau_norm:.6g} N.m is too stiff for a "
            f"{dt:g} s step: it needs more than {MAX_SUBSTEPS} RK4 substeps (shorten the communication step)")
    new = rk4_step(state, tau1, tau2, dt, n, p)
    if not (math.isfinite(new[0]) and math.isfinite(new[1]) and math.isfinite(new[2]) and math.isfinite(new[3])):
        raise IntegrationError("the integration gave a non-finite state")
    speed_before = math.sqrt(2.0 * kinetic_energy(q2, w1, w2, p))
    speed_after = math.sqrt(2.0 * kinetic_energy(new[1], new[2], new[3], p))
    allowed = (speed_before + dt * tau_norm * math.sqrt(p.inv_inertia)) * 1.05 + 1e-9
    if not speed_after <= allowed:
        raise IntegrationError(
            f"the integration blew up: sqrt(2 E) went from {speed_before:.6g} to {speed_after:.6g}, but the "
            f"torque can raise it to {allowed:.6g} at most over {dt:g} s")
    return new


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
    k = p.coefficients
    for _ in range(substeps):
        a1, a2 = _accel(q2, w1, w2, tau1, tau2, k)
        k2q2, k2w1, k2w2 = q2 + half * w2, w1 + half * a1, w2 + half * a2
        b1, b2 = _accel(k2q2, k2w1, k2w2, tau1, tau2, k)
        k3q2, k3w1, k3w2 = q2 + half * k2w2, w1 + half * b1, w2 + half * b2
        c1, c2 = _accel(k3q2, k3w1, k3w2, tau1, tau2, k)
        k4q2, k4w1, k4w2 = q2 + h * k3w2, w1 + h * c1, w2 + h * c2
        e1, e2 = _accel(k4q2, k4w1, k4w2, tau1, tau2, k)
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
