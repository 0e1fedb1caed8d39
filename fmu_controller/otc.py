"""Reconstructed optimal tracking controller (OTC) of the SOTC paper's comparison (OtcCore).

The SOTC paper (``shared/reference/sotc-paper.md``, section 4) compares against the OTC of its
ref. [7]: L. Kong, W. He, C. Yang, C. Sun, "Robust neurooptimal control for a robot via adaptive
dynamic programming", IEEE TNNLS 32(6), 2584-2594, 2021, with Q = I4, R = diag[20, 100],
Lambda = diag[200, 50]. The text of [7] could not be consulted, so the law below is a
*reconstruction* from the SOTC paper's own structure (its eqs. (2)-(7), (19)-(31)) and the
actor-critic ADP literature it builds on (Vamvoudakis & Lewis 2010; Dierks & Jagannathan 2010 /
Liu, Wang et al. 2014 for the stabilising term). Every assumption is listed in docs/baselines.md;
the labels (OTC-n) below are this module's, not [7]'s.

Error coordinates (backstepping / filtered tracking error; Lambda is the virtual-control gain):

    e = phi - phi_d,  e_dot = dphi - dphi_d                                           (OTC-1)
    alpha = dphi_d - Lambda e            (virtual velocity command)                   (OTC-2)
    z1 = e,  z2 = dphi - alpha = e_dot + Lambda e,   z = [z1; z2] in R^4              (OTC-3)

Feedforward torque cancelling the nominal dynamics of eq. (1) along alpha:

    tau_a = D(phi) alpha_dot + H(phi, dphi) dphi + G(dphi),
    alpha_dot = ddphi_d - Lambda e_dot                                                (OTC-4)

so that with tau = tau_a + u the error system is affine in the optimal feedback u:

    z_dot = F z + g(phi) u,   F = [[-Lambda, I2], [0, 0]],   g = [[0], [D(phi)^-1]]   (OTC-5)

Cost (quadratic, no input bound -- the OTC is unsaturated by design):

    J = int (z' Q z + u' R u) dt,   Q = q I4,  R = diag(r1, r2)                       (OTC-6)

Critic and actor: one-layer NNs on the quadratic basis of z (the same 10 monomials as the SOTC),

    V_hat = Wc' sigma(z),   u_hat = -1/2 R^-1 g' grad_sigma(z)' Wa                    (OTC-7)

Critic tuning, normalised gradient descent on the Hamiltonian residual (Vamvoudakis & Lewis 2010):

    omega = grad_sigma(z) (F z + g u_hat),   delta = omega' Wc + z'Qz + u_hat' R u_hat
    Wc_dot = -alpha_c omega delta / (omega'omega + 1)^2                               (OTC-8)

Actor tuning: follow the critic, plus the stabilising term that removes the need for an initial
admissible policy (active while the Lyapunov candidate L = z'z/2 grows along (OTC-5)):

    Wa_dot = -alpha_a (Wa - Wc) + [z'(F z + g u_hat) > 0] alpha_s/2 grad_sigma g R^-1 g' z   (OTC-9)

Exploration: the SOTC's probing signal PE(t) (section 4, scaled by ``probe_amplitude`` instead of
its 0.5) is added to both torques for t < ``probe_duration``:

    tau = tau_a + u_hat + n(t)                                                        (OTC-10)

Initial weights (``init_weights``): 1 (default) sets Wc = Wa to the exact value function z'Pz of
the linear problem (OTC-5)-(OTC-6) with D frozen at phi2 = ``init_phi2`` (the algebraic Riccati
equation, ``frozen_riccati``): an admissible initial policy, as Vamvoudakis & Lewis 2010 require;
0 starts from zero weights and relies on the stabilising term alone (measured to track poorly in
this loop, docs/baselines.md). ``advance`` integrates (OTC-8) exactly over the sample with the
regressor held (the residual decays as exp(-alpha_c w'w/(w'w+1)^2 t)), and (OTC-9) by exponential
Euler towards the updated critic.
"""
from __future__ import annotations

import math
from typing import Any, Sequence

import numpy as np
from scipy.linalg import solve_continuous_are

from fmu_controller.base import ControllerCore, OutputSpec
from fmu_controller.computed_torque import DEFAULT_TAU_MAX
from fmu_plant.dynamics import bias_torque, inertia_matrix
from fmu_plant.parameters import ParameterError, ParameterSpec, any_real, nonnegative, positive

N_WEIGHTS = 10
# index pairs (i, j), i <= j, of the quadratic basis, in the SOTC's order (section 4):
# z1^2, z1 z2, z1 z3, z1 z4, z2^2, z2 z3, z2 z4, z3^2, z3 z4, z4^2
BASIS_PAIRS: tuple[tuple[int, int], ...] = tuple((i, j) for i in range(4) for j in range(i, 4))


def basis(z: np.ndarray) -> np.ndarray:
    """sigma(z): the 10 quadratic monomials z_i z_j (i <= j), eq. (OTC-7)."""
    return np.array([z[i] * z[j] for i, j in BASIS_PAIRS])


def basis_gradient(z: np.ndarray) -> np.ndarray:
    """d sigma / d z, a 10 x 4 matrix, eq. (OTC-7)."""
    grad = np.zeros((N_WEIGHTS, 4))
    for n, (i, j) in enumerate(BASIS_PAIRS):
        grad[n, i] += z[j]
        grad[n, j] += z[i]
    return grad


def probing_signal(t: float) -> float:
    """The SOTC paper's PE signal without its factor 0.5 (section 4)."""
    s1 = math.sin(t)
    return (
        s1 * s1 * math.cos(t)
        + math.sin(2.0 * t) ** 2 * math.cos(0.1 * t)
        + math.sin(1.2 * t) ** 2 * math.cos(0.5 * t)
        + s1**5
        + math.sin(1.12 * t) ** 2
        + math.cos(2.4 * t) * math.sin(2.4 * t) ** 3
    )


def weights_from_quadratic(p: np.ndarray) -> np.ndarray:
    """Weights W with W' sigma(z) = z' P z for a symmetric 4 x 4 P (P_ii, then 2 P_ij)."""
    return np.array([p[i, j] if i == j else 2.0 * p[i, j] for i, j in BASIS_PAIRS])


class OtcCore(ControllerCore):
    """Reconstructed actor-critic OTC of Kong et al. 2021 (the SOTC paper's ref. [7]), unsaturated."""

    PARAMETER_SPECS: tuple[ParameterSpec, ...] = (
        positive("lambda1", 200.0, "1/s", "Lambda_11: virtual-control (filtered error) gain of joint 1, eqs. (OTC-2)-(OTC-4); paper section 4", high=1e5),
        positive("lambda2", 50.0, "1/s", "Lambda_22: virtual-control (filtered error) gain of joint 2, eqs. (OTC-2)-(OTC-4); paper section 4", high=1e5),
        positive("q", 1.0, "1", "State weight: Q = q I4 on z, eq. (OTC-6); paper Q = I4", high=1e8),
        positive("r1", 20.0, "1", "Input weight R_11 on u1, eq. (OTC-6); paper R = diag[20, 100]", high=1e8),
        positive("r2", 100.0, "1", "Input weight R_22 on u2, eq. (OTC-6); paper R = diag[20, 100]", high=1e8),
        nonnegative("alpha_c", 0.5, "1/s", "Critic learning rate, eq. (OTC-8) (assumed; larger values drift, docs/baselines.md)", high=1e5),
        nonnegative("alpha_a", 5.0, "1/s", "Actor learning rate, eq. (OTC-9) (assumed)", high=1e5),
        nonnegative("alpha_s", 0.01, "1/s", "Stabilising-term gain, eq. (OTC-9) (assumed; the SOTC's alpha_2)", high=1e5),
        nonnegative("probe_amplitude", 0.5, "N.m", "Factor of the probing signal PE(t) added to the torques, eq. (OTC-10) (assumed; the SOTC's 0.5)", high=1e3),
        nonnegative("probe_duration", 0.4, "s", "Probing is applied for t < probe_duration, eq. (OTC-10) (assumed; the SOTC's 0.4 s)", high=1e6),
        ParameterSpec("init_weights", 1.0, "1", "Initial weights: 0 = zeros (rely on the stabilising term), 1 = Riccati solution of (OTC-5)-(OTC-6) frozen at phi2 = init_phi2 (an admissible initial policy)", low=0.0, high=1.0),
        any_real("init_phi2", -0.5, "rad", "Elbow angle at which D(phi) is frozen for init_weights = 1 (the paper's phi2(0))"),
        positive("tau_limit", DEFAULT_TAU_MAX, "N.m", "Torque-norm bound used only for the over_limit diagnostic (never applied)", high=1e6),
    )
    EXTRA_OUTPUTS = (
        OutputSpec("tau_norm", "N.m", "||tau|| of the (unsaturated) commanded torque, eq. (OTC-10)"),
        OutputSpec("over_limit", "1", "1 when ||tau|| exceeds tau_limit, else 0"),
        OutputSpec("tau_a1", "N.m", "Feedforward torque of joint 1, eq. (OTC-4)"),
        OutputSpec("tau_a2", "N.m", "Feedforward torque of joint 2, eq. (OTC-4)"),
        OutputSpec("u1", "N.m", "Actor (optimal feedback) torque of joint 1, eq. (OTC-7)"),
        OutputSpec("u2", "N.m", "Actor (optimal feedback) torque of joint 2, eq. (OTC-7)"),
        OutputSpec("z2_1", "rad/s", "Filtered error z2 = e_dot + Lambda e of joint 1, eq. (OTC-3)"),
        OutputSpec("z2_2", "rad/s", "Filtered error z2 of joint 2, eq. (OTC-3)"),
        OutputSpec("value", "1", "Critic value V_hat = Wc' sigma(z), eq. (OTC-7)"),
        OutputSpec("bellman_residual", "1/s", "Hamiltonian residual delta of eq. (OTC-8)"),
        OutputSpec("cost_rate", "1/s", "Cost integrand z'Qz + u_hat'R u_hat, eq. (OTC-6)"),
        OutputSpec("wc_norm", "1", "||Wc||, critic weights"),
        OutputSpec("wa_norm", "1", "||Wa||, actor weights"),
    )

    def __init__(self, model=None, **params: float):
        super().__init__(model, **params)
        pr = self.params
        self.lam = np.array([pr["lambda1"], pr["lambda2"]])
        self.r_diag = np.array([pr["r1"], pr["r2"]])
        mode = pr["init_weights"]
        if mode not in (0.0, 1.0):
            raise ParameterError("init_weights", f"{mode:g} is not 0 (zeros) or 1 (Riccati)")
        if mode == 1.0:
            self.wc = weights_from_quadratic(self.frozen_riccati(pr["init_phi2"]))
        else:
            self.wc = np.zeros(N_WEIGHTS)
        self.wa = self.wc.copy()
        self._last: dict[str, Any] | None = None  # regressors of the last evaluate, for advance

    def frozen_riccati(self, phi2: float) -> np.ndarray:
        """P of the algebraic Riccati equation of (OTC-5)-(OTC-6) with D frozen at ``phi2``:
        the exact value function z'Pz of the linear problem, a quadratic form the basis of
        (OTC-7) represents exactly."""
        f = np.zeros((4, 4))
        f[:2, :2] = -np.diag(self.lam)
        f[:2, 2:] = np.eye(2)
        g = np.zeros((4, 2))
        g[2:, :] = np.linalg.inv(inertia_matrix(phi2, self.model))
        return solve_continuous_are(f, g, self.params["q"] * np.eye(4), np.diag(self.r_diag))

    # --- control law --------------------------------------------------------------------------

    def evaluate(self, t: float, y: Sequence[float], r: Sequence[float]) -> None:
        phi1, phi2, dphi1, dphi2 = (float(v) for v in y)
        q1d, q2d, dq1d, dq2d, ddq1d, ddq2d = (float(v) for v in r[:6])
        lam, q = self.lam, self.params["q"]
        e = np.array([phi1 - q1d, phi2 - q2d])
        de = np.array([dphi1 - dq1d, dphi2 - dq2d])
        z = np.concatenate([e, de + lam * e])  # (OTC-3)

        d = inertia_matrix(phi2, self.model)
        d_inv = np.linalg.inv(d)
        alpha_dot = np.array([ddq1d, ddq2d]) - lam * de
        tau_a = d @ alpha_dot + np.array(bias_torque(phi2, dphi1, dphi2, self.model))  # (OTC-4)

        g = np.zeros((4, 2))
        g[2:, :] = d_inv  # (OTC-5)
        grad = basis_gradient(z)
        gt_grad_t = g.T @ grad.T  # 2 x 10
        u_hat = -0.5 * (gt_grad_t @ self.wa) / self.r_diag  # (OTC-7)

        fz = np.concatenate([-lam * z[:2] + z[2:], np.zeros(2)])
        z_dot = fz + g @ u_hat
        omega = grad @ z_dot
        cost_rate = q * float(z @ z) + float(u_hat @ (self.r_diag * u_hat))
        delta = float(omega @ self.wc) + cost_rate  # (OTC-8)

        probe = 0.0
        if t < self.params["probe_duration"]:
            probe = self.params["probe_amplitude"] * probing_signal(t)
        tau = tau_a + u_hat + probe  # (OTC-10)
        tau_norm = float(math.hypot(tau[0], tau[1]))

        self._last = {
            "z": z, "grad": grad, "g": g, "omega": omega, "cost_rate": cost_rate,
            "lyap_rate": float(z @ z_dot),
        }
        self.outputs = [
            float(tau[0]), float(tau[1]),
            tau_norm, 1.0 if tau_norm > self.params["tau_limit"] else 0.0,
            float(tau_a[0]), float(tau_a[1]), float(u_hat[0]), float(u_hat[1]),
            float(z[2]), float(z[3]),
            float(self.wc @ basis(z)), delta, cost_rate,
            float(np.linalg.norm(self.wc)), float(np.linalg.norm(self.wa)),
        ]

    # --- learning -----------------------------------------------------------------------------

    def advance(self, t: float, dt: float) -> None:
        """Integrate the critic (OTC-8) and actor (OTC-9) laws over [t, t + dt) with the
        regressors of the last ``evaluate`` held."""
        last = self._last
        if last is None or dt <= 0.0:
            return
        pr = self.params
        omega = last["omega"]
        ww = float(omega @ omega)
        if ww > 0.0 and pr["alpha_c"] > 0.0:
            # exact solution of (OTC-8) for a held regressor: the residual omega'Wc + cost decays
            # as exp(-alpha_c ww/(ww+1)^2 t); only the component of Wc along omega moves.
            s0 = float(omega @ self.wc) + last["cost_rate"]
            decay = math.exp(-pr["alpha_c"] * ww / (ww + 1.0) ** 2 * dt)
            self.wc = self.wc - omega * (s0 * (1.0 - decay) / ww)
        stab = np.zeros(N_WEIGHTS)
        if last["lyap_rate"] > 0.0 and pr["alpha_s"] > 0.0:
            g, grad, z = last["g"], last["grad"], last["z"]
            stab = 0.5 * pr["alpha_s"] * (grad @ (g @ ((g.T @ z) / self.r_diag)))
        decay_a = math.exp(-pr["alpha_a"] * dt)
        self.wa = self.wc + (self.wa - self.wc) * decay_a + stab * dt

    def get_state(self) -> dict[str, Any]:
        return {"wc": self.wc.tolist(), "wa": self.wa.tolist()}

    def set_state(self, state: dict[str, Any]) -> None:
        for key in ("wc", "wa"):
            w = np.asarray(state[key], dtype=float)
            if w.shape != (N_WEIGHTS,) or not np.all(np.isfinite(w)):
                raise ParameterError(key, f"state needs {N_WEIGHTS} finite weights, got {w.shape}")
        self.wc = np.asarray(state["wc"], dtype=float).copy()
        self.wa = np.asarray(state["wa"], dtype=float).copy()
        self._last = None
