"""Saturated LQR on the feedback-linearised error dynamics (LqrCore).

Computed-torque feedback linearisation on the nominal model of eq. (1) of the SOTC paper
(``shared/reference/sotc-paper.md``) turns the arm into one double integrator per joint,

    tau_raw = D(phi) (ddphi_d + v) + H(phi, dphi) dphi + G(dphi)                      (LQR-1)
    =>  x_dot = A x + B v,  x = [e1, e2, e_dot1, e_dot2],  e = phi - phi_d            (LQR-2)
        A = [[0, I2], [0, 0]],  B = [[0], [I2]]

and v is the linear-quadratic regulator of (LQR-2) for the cost

    J = int_0^inf (x' Theta x + v' R v) dt,   Theta = q I4,  R = r I2                 (LQR-3)

    v = -K x,   K = R^-1 B' P,   A'P + PA - P B R^-1 B' P + Theta = 0                 (LQR-4)

solved once at construction with ``scipy.linalg.solve_continuous_are``. Theta = I4 is the SOTC's
state weight (section 4); r = 1 is the SOTC's R = 1 (there R weights its bounded inputs mu, here
the commanded acceleration v, so the numbers are analogous, not identical problems).

The torque is then bounded on its Euclidean norm, as the paper's ||tau|| <= rho, by scaling the
vector down (``computed_torque.saturate_norm``), eq. (CT-4). Because A, B, Theta, R are block
diagonal, K = [k_p I2, k_d I2] with k_p = sqrt(q/r), k_d = sqrt(2 k_p + q/r) — the tests check
that, but the gain here comes from the Riccati solver, not from this formula.
"""
from __future__ import annotations

from typing import Sequence

import numpy as np
from scipy.linalg import solve_continuous_are

from fmu_controller.base import ControllerCore, OutputSpec
from fmu_controller.computed_torque import DEFAULT_TAU_MAX, saturate_norm
from fmu_plant.dynamics import inverse_dynamics
from fmu_plant.parameters import ParameterSpec, positive


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
    p = solve_continuous_are(a, b, theta, rm)
    k = np.linalg.solve(rm, b.T @ p)
    return k, p


class LqrCore(ControllerCore):
    """LQR of the feedback-linearised error, saturated on the torque norm, eqs. (LQR-1)..(LQR-4)."""

    PARAMETER_SPECS: tuple[ParameterSpec, ...] = (
        positive("q", 1.0, "1", "State weight: Theta = q I4 on x = [e, e_dot], eq. (LQR-3); 1 is the SOTC's Theta = I4", high=1e8),
        positive("r", 1.0, "1", "Input weight: R = r I2 on the commanded acceleration v, eq. (LQR-3)", high=1e8),
        positive("tau_max", DEFAULT_TAU_MAX, "N.m", "Bound on the torque norm ||tau|| (the paper's rho), eq. (CT-4)"),
    )
    EXTRA_OUTPUTS = (
        OutputSpec("tau_norm_raw", "N.m", "||tau|| before saturation, eq. (LQR-1)"),
        OutputSpec("saturated", "1", "1 when the norm bound scaled the torque down, else 0"),
        OutputSpec("v1", "rad/s2", "LQR acceleration command of joint 1, v = -K x, eq. (LQR-4)"),
        OutputSpec("v2", "rad/s2", "LQR acceleration command of joint 2, eq. (LQR-4)"),
    )

    def __init__(self, model=None, **params: float):
        super().__init__(model, **params)
        self.gain, self.riccati = lqr_gain(self.params["q"], self.params["r"])

    def evaluate(self, t: float, y: Sequence[float], r: Sequence[float]) -> None:
        phi1, phi2, dphi1, dphi2 = (float(v) for v in y)
        q1d, q2d, dq1d, dq2d, ddq1d, ddq2d = (float(v) for v in r[:6])
        x = np.array([phi1 - q1d, phi2 - q2d, dphi1 - dq1d, dphi2 - dq2d])
        v1, v2 = (-self.gain @ x).tolist()
        raw1, raw2 = inverse_dynamics(phi2, dphi1, dphi2, ddq1d + v1, ddq2d + v2, self.model)
        tau1, tau2, norm, sat = saturate_norm(raw1, raw2, self.params["tau_max"])
        self.outputs = [tau1, tau2, norm, 1.0 if sat else 0.0, v1, v2]
