"""Saturated LQR on the feedback-linearised error dynamics (LqrCore).

Computed-torque feedback linearisation on the nominal model of eq. (1) of the SOTC paper
(Dien, Luy, Lai & Hai 2023) turns the arm into one double integrator per joint,

    tau_raw = D(phi) (ddphi_d + v) + H(phi, dphi) dphi + G(dphi)                      (LQR-1)
    =>  x_dot = A x + B v,  x = [e1, e2, e_dot1, e_dot2],  e = phi - phi_d            (LQR-2)
        A = [[0, I2], [0, 0]],  B = [[0], [I2]]

and v is the linear-quadratic regulator of (LQR-2) for the cost

    J = int_0^inf (x' Theta x + v' R v) dt,   Theta = q I4,  R = r I2                 (LQR-3)

    v = -K x,   K = R^-1 B' P,   A'P + PA - P B R^-1 B' P + Theta = 0                 (LQR-4)

solved once at construction (``fmu_controller.riccati.solve_care``). Theta = I4 is the SOTC's
state weight (section 4); r = 1 is the SOTC's R = 1 (there R weights its bounded inputs mu, here
the commanded acceleration v, so the numbers are analogous, not identical problems).

The torque is then bounded on its Euclidean norm, as the paper's ||tau|| <= rho, by scaling the
vector down (``saturation.limit_torque``, eq. (CT-4); ``limit_handling`` selects any other
handling). Because A, B, Theta, R are block
diagonal, K = [k_p I2, k_d I2] with k_p = sqrt(q/r), k_d = sqrt(2 k_p + q/r) — the tests check
that, but the gain here comes from the Riccati solver, not from this formula.
"""
from __future__ import annotations

import numpy as np

from fmi_slave.parameters import ParameterSpec
from fmu_controller.computed_torque import LIMIT_SPEC, RHO_SPEC, LinearisingCore
from fmu_controller.riccati import gain, solve_care


def error_system() -> tuple[np.ndarray, np.ndarray]:
    """(A, B) of the feedback-linearised error dynamics, eq. (LQR-2)."""
    a = np.zeros((4, 4))
    a[0, 2] = a[1, 3] = 1.0
    b = np.zeros((4, 2))
    b[2, 0] = b[3, 1] = 1.0
    return a, b


def lqr_gain(q: float, r: float) -> tuple[np.ndarray, np.ndarray]:
    """(K, P) of eq. (LQR-4) for Theta = q I4, R = r I2."""
    a, b = error_system()
    theta, rm = q * np.eye(4), r * np.eye(2)
    stabilising = np.hstack([np.eye(2), np.eye(2)])  # v = -(e + e_dot): A - B K has eigenvalues (-1 +- i sqrt 3) / 2
    p = solve_care(a, b, theta, rm, stabilising)
    return gain(b, rm, p), p


class LqrCore(LinearisingCore):
    """LQR of the feedback-linearised error, saturated on the torque norm, eqs. (LQR-1)..(LQR-4)."""

    PARAMETER_SPECS: tuple[ParameterSpec, ...] = (
        # bounded away from 0: the Riccati solver fails for weights near underflow (found by hypothesis)
        ParameterSpec("q", 1.0, "1", "State weight: Theta = q I4 on x = [e, e_dot], eq. (LQR-3); 1 is the SOTC's Theta = I4",
                      low=1e-6, high=1e8),
        ParameterSpec("r", 1.0, "1", "Input weight: R = r I2 on the commanded acceleration v, eq. (LQR-3)",
                      low=1e-6, high=1e8),
        RHO_SPEC,
        LIMIT_SPEC,
    )

    def __init__(self, model=None, **params: float):
        super().__init__(model, **params)
        self.gain, self.riccati = lqr_gain(self.params["q"], self.params["r"])
        # rows of -K as plain floats: the per-step product below is scalar arithmetic
        self._neg_gain = tuple(tuple(row) for row in (-self.gain).tolist())

    def feedback(self, e1: float, e2: float, de1: float, de2: float) -> tuple[float, float]:
        (a1, a2, a3, a4), (b1, b2, b3, b4) = self._neg_gain  # eq. (LQR-4): v = -K x
        return a1 * e1 + a2 * e2 + a3 * de1 + a4 * de2, b1 * e1 + b2 * e2 + b3 * de1 + b4 * de2
