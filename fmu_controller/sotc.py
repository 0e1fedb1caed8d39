"""Saturated optimal tracking controller (SOTC) of Dien, Luy, Lai & Hai (2023): the pure core.

Reference: N. D. Dien, N. T. Luy, L. K. Lai, T. T. Hai, "Optimal tracking control for robot
manipulators with input constraint based reinforcement learning", J. Computer Science and
Cybernetics, 2023 (``shared/reference/sotc-paper.md``). Equation numbers are the paper's; where the
paper is ambiguous the chosen reading, the alternatives and their measured effect are in
``docs/paper-notes.md`` (each alternative stays selectable through a ``*_form`` parameter).

Structure of one sample (``evaluate`` at t_k, then ``advance(t_k, T)``):

1. error z = [z_phi, z_v] of eqs. (6)/(7): z_phi = phi - phi_d; z_v = dphi - chi_vd with
   chi_vd = chi_vd* + chi_vd^a (chi_vd* depends on z_v itself, solved by Newton, see below);
2. critic J_hat = W^T zeta(z), eq. (27), and the saturated law mu_hat = [chi_vd*, tau*], eq. (28);
3. the modelled error rate zdot of eq. (6)/(7), eta = grad(zeta) zdot, the Bellman residual e1,
   eq. (29), and the weight rate of the tuning law (30) or (31) with concurrent learning;
4. feedforward inputs (4) with the bound (5); tau = tau* + tau^a (+ PE while probing), limited to
   ||tau|| <= rho;
5. ``advance``: one explicit Euler step of the tuning law, W <- W + T Wdot, and the CL stack update.
"""
from __future__ import annotations

import math
from typing import Any, ClassVar, Sequence

import numpy as np

from fmu_controller.base import ControllerCore, OutputSpec
from fmu_controller.sotc_math import (
    N_BASIS,
    basis,
    basis_directional,
    omega_term_of_arg,
    probing_signal,
    value_gradient,
    value_hessian,
)
from fmu_plant.dynamics import ArmParameters, bias_torque, forward_dynamics, inertia_entries
from fmu_plant.parameters import ParameterError, ParameterSpec, any_real, nonnegative, positive

TANH1 = math.tanh(1.0)

# Reading switches (integer-coded parameters). Index 0 is always the chosen reading.
CHI_A_FORMS = ("backstepping", "literal")  # chi_vd^a = dphi_d - L1 z_phi  |  dphi_d + L1 z_v (as printed)
FV_ERROR_FORMS = ("zero", "drift")  # F_v(z_phi, z_v) in (4): 0  |  -D(z_phi)^-1 (H(z) z_v + G(z_v))
LIMIT_FORMS = ("norm", "joint")  # bound (5) and the actuator limit act on ||.||_2 | on each joint
SATURATION_FORMS = ("sigma", "rho")  # level s of (13)/(28): sigma (Remark 2) | rho (as printed)
CHI_DOT_FORMS = ("chain", "feedforward")  # dchi_vd/dt: chain rule incl. chi_vd*  |  d(chi_vd^a)/dt only
CL_SELECTIONS = ("fill", "maxeig", "fifo")  # CL stack: first P records | swap to raise lambda_min | newest P
PE_FORMS = ("torque", "critic")  # PE on the applied torque only | also inside the critic's mu_hat


def _switch(name: str, choices: tuple[str, ...], description: str) -> ParameterSpec:
    options = ", ".join(f"{i} = {c}" for i, c in enumerate(choices))
    return ParameterSpec(name, 0.0, "1", f"{description} ({options})", low=0.0, high=float(len(choices) - 1))


SOTC_PARAMETER_SPECS: tuple[ParameterSpec, ...] = (
    positive("lambda1_1", 1.0, "1/s", "Lambda_1 = diag(lambda1_1, lambda1_2) of the feedforward (4), section 4"),
    positive("lambda1_2", 1.0, "1/s", "Lambda_1 = diag(lambda1_1, lambda1_2) of the feedforward (4), section 4"),
    positive("lambda2_1", 1.0, "1/s", "Lambda_2 = diag(lambda2_1, lambda2_2) of the feedforward (4), section 4"),
    positive("lambda2_2", 1.0, "1/s", "Lambda_2 = diag(lambda2_1, lambda2_2) of the feedforward (4), section 4"),
    positive("theta_1", 1.0, "1", "Theta = diag(theta_1..theta_4) of the cost (12) (z_phi1 weight)"),
    positive("theta_2", 1.0, "1", "Theta = diag(theta_1..theta_4) of the cost (12) (z_phi2 weight)"),
    positive("theta_3", 1.0, "1", "Theta = diag(theta_1..theta_4) of the cost (12) (z_v1 weight)"),
    positive("theta_4", 1.0, "1", "Theta = diag(theta_1..theta_4) of the cost (12) (z_v2 weight)"),
    positive("r_1", 1.0, "1", "R = diag(r_1..r_4) of the input cost (13) (chi_vd*1 weight); paper: R = 1"),
    positive("r_2", 1.0, "1", "R = diag(r_1..r_4) of the input cost (13) (chi_vd*2 weight); paper: R = 1"),
    positive("r_3", 1.0, "1", "R = diag(r_1..r_4) of the input cost (13) (tau*1 weight); paper: R = 1"),
    positive("r_4", 1.0, "1", "R = diag(r_1..r_4) of the input cost (13) (tau*2 weight); paper: R = 1"),
    positive("alpha1", 50.0, "1/s", "Critic learning rate alpha_1 of the tuning laws (30)/(31)", high=1e6),
    positive("alpha2", 0.01, "1/s", "Stabilising gain alpha_2 of the tuning law (31)", high=1e6),
    positive("sigma", 0.6, "N.m", "Saturation level sigma of the optimal input, 0 < sigma < rho (Remark 2, (5))"),
    positive("rho", 4.0, "N.m", "Torque limit rho: ||tau|| <= rho, eqs. (1), (5)"),
    ParameterSpec("P", 20.0, "1", "Concurrent-learning stack size P (integer, P >= 10 = number of weights)",
                  low=10.0, high=1000.0),
    *(any_real(f"W0_{k}", 0.0, "1", f"Initial critic weight W_{k}(0) of eq. (27); paper: 0")
      for k in range(1, N_BASIS + 1)),
    nonnegative("pe_amplitude", 0.5, "N.m", "Gain of the section-4 probing signal (the paper's 0.5)", high=1e3),
    nonnegative("pe_duration", 0.4, "s", "Probing (PE) is added while t < pe_duration; paper: 0.4 s with CL"),
    ParameterSpec("cl_enabled", 1.0, "1", "Concurrent learning (experience replay) of (30)/(31): 1 = on, 0 = off",
                  low=0.0, high=1.0),
    positive("cl_record_interval", 0.02, "s",
             "Time between CL stack records (0.02 s fills P = 20 over the 0.4 s of PE)", high=1e3),
    _switch("cl_selection", CL_SELECTIONS, "Which samples the CL stack keeps"),
    _switch("chi_a_form", CHI_A_FORMS, "Reading of chi_vd^a in (4)"),
    _switch("fv_error_form", FV_ERROR_FORMS, "Reading of F_v(z_phi, z_v) in (4)/(6)"),
    _switch("limit_form", LIMIT_FORMS, "How the bound (5) and the torque limit rho act"),
    _switch("saturation_form", SATURATION_FORMS, "Saturation level of (13)/(28)"),
    _switch("chi_dot_form", CHI_DOT_FORMS, "How dchi_vd/dt in tau^a of (4) is obtained"),
    _switch("pe_form", PE_FORMS, "Where the probing signal enters"),
)

_SWITCHES = {
    "cl_enabled": ("off", "on"),
    "cl_selection": CL_SELECTIONS,
    "chi_a_form": CHI_A_FORMS,
    "fv_error_form": FV_ERROR_FORMS,
    "limit_form": LIMIT_FORMS,
    "saturation_form": SATURATION_FORMS,
    "chi_dot_form": CHI_DOT_FORMS,
    "pe_form": PE_FORMS,
}

# The three settings of section 4 (parameters that differ from the defaults = the `paper` setting).
SCENARIO_SETTINGS: dict[str, dict[str, float]] = {
    # CL on, PE for the first 0.4 s, P = 20 (Figure 2, Table 1)
    "paper": {},
    # PE only, on for 0 <= t <= 80 s, no CL (Figure 1)
    "paper-pe-only": {"cl_enabled": 0.0, "pe_duration": 80.0},
    # CL on with 20 s of PE: a richer stack, to compare the learned W with an LQR value
    "paper-long-pe": {"pe_duration": 20.0},
}

_EXTRA = [
    OutputSpec("tau_star1", "N.m", "Saturated optimal torque tau*_1 of (28) (joint 1)"),
    OutputSpec("tau_star2", "N.m", "Saturated optimal torque tau*_2 of (28) (joint 2)"),
    OutputSpec("tau_a1", "N.m", "Feedforward torque tau^a_1 of (4) after the bound (5)"),
    OutputSpec("tau_a2", "N.m", "Feedforward torque tau^a_2 of (4) after the bound (5)"),
    OutputSpec("chi_vd_star1", "rad/s", "Saturated optimal virtual velocity chi_vd*_1 of (28)"),
    OutputSpec("chi_vd_star2", "rad/s", "Saturated optimal virtual velocity chi_vd*_2 of (28)"),
    OutputSpec("chi_vd_a1", "rad/s", "Feedforward virtual velocity chi_vd^a_1 of (4) after the bound (5)"),
    OutputSpec("chi_vd_a2", "rad/s", "Feedforward virtual velocity chi_vd^a_2 of (4) after the bound (5)"),
    OutputSpec("z1", "rad", "Error z_phi1 = phi1 - phi1_d of (6)"),
    OutputSpec("z2", "rad", "Error z_phi2 = phi2 - phi2_d of (6)"),
    OutputSpec("z3", "rad/s", "Error z_v1 = dphi1 - chi_vd1 of (6)"),
    OutputSpec("z4", "rad/s", "Error z_v2 = dphi2 - chi_vd2 of (6)"),
    *(OutputSpec(f"W{k}", "1", f"Critic weight W_{k} of (27) used at this sample") for k in range(1, N_BASIS + 1)),
    OutputSpec("J_hat", "1", "Critic value J_hat(z) = W^T zeta(z), eq. (27)"),
    OutputSpec("e1", "1", "Bellman residual e1 = W^T eta + z^T Theta z + Omega(mu_hat), eq. (29)"),
    OutputSpec("Omega", "1", "Saturated input cost Omega(mu_hat), eq. (17)"),
    OutputSpec("tuning_law", "1", "Tuning law in force: 30 if z^T zdot < 0, else 31"),
    OutputSpec("cl_stack_size", "1", "Number of samples in the CL stack"),
    OutputSpec("cl_stack_min_eig", "1", "Smallest eigenvalue of the CL matrix sum_i eta_i eta_i^T/(eta_i^T eta_i+1)^2"),
    OutputSpec("pe_active", "1", "1 while the probing signal is added (t < pe_duration), else 0"),
    OutputSpec("pe", "N.m", "Probing signal added to both joint torques at this sample"),
    OutputSpec("tau_a_bounded", "1", "1 if the bound (5) clipped tau^a at this sample, else 0"),
    OutputSpec("chi_a_bounded", "1", "1 if the bound (5) clipped chi_vd^a at this sample, else 0"),
    OutputSpec("tau_limited", "1", "1 if the actuator limit rho clipped tau at this sample, else 0"),
    OutputSpec("tau_norm", "N.m", "Euclidean norm of the output torque"),
    OutputSpec("dchi_vd1", "rad/s2", "dchi_vd1/dt used by tau^a of (4)"),
    OutputSpec("dchi_vd2", "rad/s2", "dchi_vd2/dt used by tau^a of (4)"),
    OutputSpec("Wdot_norm", "1/s", "Norm of the weight rate of (30)/(31) applied over the next step"),
]


class SOTCController(ControllerCore):
    """SOTC core: feedforward (4)-(5), critic (27), saturated law (28), tuning (30)/(31) with CL.

    Parameters: see ``SOTC_PARAMETER_SPECS`` (defaults = the paper's section 4). ``model`` is the
    nominal arm model used by the feedforward (4) and by g_v = D^-1.
    """

    PARAMETER_SPECS: ClassVar[tuple[ParameterSpec, ...]] = SOTC_PARAMETER_SPECS
    EXTRA_OUTPUTS: ClassVar[tuple[OutputSpec, ...]] = tuple(_EXTRA)

    def __init__(self, model: ArmParameters | None = None, **params: float):
        super().__init__(model, **params)
        p = self.params
        if not p["sigma"] < p["rho"]:
            raise ParameterError("sigma", f"{p['sigma']:g} must be smaller than rho = {p['rho']:g} (0 < sigma < rho, eq. (5))")
        for name, choices in _SWITCHES.items():
            v = p[name]
            if v != int(v):
                opts = ", ".join(f"{i} = {c}" for i, c in enumerate(choices))
                raise ParameterError(name, f"{v:g} must be an integer code: {opts}")
        if p["P"] != int(p["P"]):
            raise ParameterError("P", f"{p['P']:g} must be an integer >= 10 (the stack needs rank 10)")
        if p["cl_selection"] == 1 and int(p["P"]) < N_BASIS:
            raise ParameterError("P", "must be >= 10")
        self.P = int(p["P"])
        self.lam1 = (p["lambda1_1"], p["lambda1_2"])
        self.lam2 = (p["lambda2_1"], p["lambda2_2"])
        self.theta = (p["theta_1"], p["theta_2"], p["theta_3"], p["theta_4"])
        self.r = (p["r_1"], p["r_2"], p["r_3"], p["r_4"])
        self.alpha1, self.alpha2 = p["alpha1"], p["alpha2"]
        self.rho, self.sigma = p["rho"], p["sigma"]
        self.cl_enabled = p["cl_enabled"] == 1.0
        self.cl_selection = CL_SELECTIONS[int(p["cl_selection"])]
        self.chi_a_form = CHI_A_FORMS[int(p["chi_a_form"])]
        self.fv_error_form = FV_ERROR_FORMS[int(p["fv_error_form"])]
        self.limit_form = LIMIT_FORMS[int(p["limit_form"])]
        self.chi_dot_form = CHI_DOT_FORMS[int(p["chi_dot_form"])]
        self.pe_form = PE_FORMS[int(p["pe_form"])]
        # level s of (13)/(28); Remark 2 asks ||tau*|| <= sigma so that tau* + tau^a respects rho
        self.s = self.sigma if SATURATION_FORMS[int(p["saturation_form"])] == "sigma" else self.rho
        self.bound5 = self.rho - self.sigma * TANH1  # eq. (5)
        self.reset()

    # --- learning state ---------------------------------------------------------------------------

    def reset(self) -> None:
        """Back to t = 0: W = W(0), empty CL stack."""
        p = self.params
        self.W = [p[f"W0_{k}"] for k in range(1, N_BASIS + 1)]
        self.stack_eta = np.zeros((self.P, N_BASIS))
        self.stack_r = np.zeros(self.P)
        self.stack_count = 0  # number of filled rows
        self.stack_next = 0  # row the FIFO overwrites next
        self.next_record_t = 0.0
        self._refresh_stack()
        self._pending: dict[str, Any] | None = None
        self._last_inputs: tuple[float, list[float], list[float]] | None = None

    def _refresh_stack(self) -> None:
        """CL matrix M = sum_i xi_i eta_i^T and vector b = sum_i xi_i r_i, xi = eta/(eta^T eta+1)^2,
        so the CL sum of (30)/(31) is M W + b. Always rebuilt from the stack (bit-reproducible)."""
        E = self.stack_eta
        scale = 1.0 / (1.0 + np.einsum("ij,ij->i", E, E)) ** 2
        Xi = E * scale[:, None]
        self.cl_M = Xi.T @ E
        self.cl_b = Xi.T @ self.stack_r
        self.cl_min_eig = float(np.linalg.eigvalsh(self.cl_M)[0]) if self.stack_count else 0.0

    def get_state(self) -> dict[str, Any]:
        state: dict[str, Any] = {
            "W": list(self.W),
            "stack_eta": self.stack_eta.tolist(),
            "stack_r": self.stack_r.tolist(),
            "stack_count": self.stack_count,
            "stack_next": self.stack_next,
            "next_record_t": self.next_record_t,
        }
        if self._last_inputs is not None:
            t, y, r = self._last_inputs
            state["last_inputs"] = {"t": t, "y": list(y), "r": list(r)}
        return state

    def set_state(self, state: dict[str, Any]) -> None:
        W = [float(w) for w in state["W"]]
        eta = np.array(state["stack_eta"], dtype=float)
        if len(W) != N_BASIS or eta.shape != (self.P, N_BASIS):
            raise ValueError(f"state does not fit this controller (10 weights, {self.P} x 10 stack)")
        self.W = W
        self.stack_eta = eta
        self.stack_r = np.array(state["stack_r"], dtype=float)
        self.stack_count = int(state["stack_count"])
        self.stack_next = int(state["stack_next"])
        self.next_record_t = float(state["next_record_t"])
        self._refresh_stack()
        self._pending = None
        self._last_inputs = None
        last = state.get("last_inputs")
        if last is not None:  # re-evaluate so that outputs and the pending step are restored exactly
            self.evaluate(last["t"], last["y"], last["r"])

    # --- one sample ---------------------------------------------------------------------------------

    def _optimal_velocity(self, zp1, zp2, zv1, zv2, W):
        """chi_vd* = first block of (28), g_phi = I: -s tanh(grad_phi J / (2 s r_i)); returns the
        arguments, tanh values and the Hessian rows needed for Newton and the chain rule."""
        s = self.s
        g1, g2, _, _ = value_gradient((zp1, zp2, zv1, zv2), W)
        x1 = g1 / (2.0 * s * self.r[0])
        x2 = g2 / (2.0 * s * self.r[1])
        return x1, x2, math.tanh(x1), math.tanh(x2)

    def _solve_zv(self, zp1, zp2, c1, c2, a1, a2, W):
        """Solve a_i z_vi + chi_vd*_i(z_phi, z_v) = c_i for z_v (Newton, 2x2).

        z_v = dphi - chi_vd* - chi_vd^a and chi_vd* depends on z_v through grad J (the basis couples
        z_phi and z_v), so z_v is defined implicitly; the paper is silent on this."""
        s, r = self.s, self.r
        hs = value_hessian(W)
        h13, h14, h23, h24 = hs[0][2], hs[0][3], hs[1][2], hs[1][3]
        zv1, zv2 = c1 / a1, c2 / a2
        for _ in range(30):
            x1, x2, t1, t2 = self._optimal_velocity(zp1, zp2, zv1, zv2, W)
            f1 = a1 * zv1 - s * t1 - c1
            f2 = a2 * zv2 - s * t2 - c2
            # d(-s tanh x_i)/d z_vj = -(1 - t_i^2) H_{i, 2+j} / (2 r_i)
            k1 = (1.0 - t1 * t1) / (2.0 * r[0])
            k2 = (1.0 - t2 * t2) / (2.0 * r[1])
            j11, j12 = a1 - k1 * h13, -k1 * h14
            j21, j22 = -k2 * h23, a2 - k2 * h24
            det = j11 * j22 - j12 * j21
            if det == 0.0 or not math.isfinite(det):
                break
            d1 = (j22 * f1 - j12 * f2) / det
            d2 = (j11 * f2 - j21 * f1) / det
            zv1 -= d1
            zv2 -= d2
            if abs(d1) + abs(d2) <= 1e-14 * (1.0 + abs(zv1) + abs(zv2)):
                break
        return zv1, zv2

    def _limit(self, v1: float, v2: float, bound: float) -> tuple[float, float, bool]:
        """Apply a bound to a 2-vector: on its Euclidean norm (radial scaling) or per joint."""
        if self.limit_form == "norm":
            n = math.hypot(v1, v2)
            if n > bound:
                k = bound / n
                return v1 * k, v2 * k, True
            return v1, v2, False
        c1 = min(max(v1, -bound), bound)
        c2 = min(max(v2, -bound), bound)
        return c1, c2, (c1 != v1 or c2 != v2)

    def evaluate(self, t: float, y: Sequence[float], r: Sequence[float]) -> None:
        m = self.model
        W = self.W
        s, rr = self.s, self.r
        lam11, lam12 = self.lam1
        lam21, lam22 = self.lam2
        phi1, phi2, dphi1, dphi2 = (float(v) for v in y)
        phi1_d, phi2_d, dphi1_d, dphi2_d, ddphi1_d, ddphi2_d = (float(v) for v in r[:6])

        # tracking error, section 2.1
        zp1, zp2 = phi1 - phi1_d, phi2 - phi2_d
        dzp1, dzp2 = dphi1 - dphi1_d, dphi2 - dphi2_d  # measured dz_phi/dt

        # eq. (4), first line, and z_v = dphi - chi_vd* - chi_vd^a (solved jointly with (28))
        if self.chi_a_form == "backstepping":
            # chi_vd^a = dphi_d - Lambda1 z_phi: F_bar_phi = -Lambda1 z_phi in (6)
            ca1, ca2, chi_a_bounded = self._limit(dphi1_d - lam11 * zp1, dphi2_d - lam12 * zp2, self.bound5)  # eq. (5)
            zv1, zv2 = self._solve_zv(zp1, zp2, dphi1 - ca1, dphi2 - ca2, 1.0, 1.0, W)
        else:
            # as printed: chi_vd^a = dphi_d + Lambda1 z_v, so (I + Lambda1) z_v = dphi - dphi_d - chi_vd*
            zv1, zv2 = self._solve_zv(zp1, zp2, dzp1, dzp2, 1.0 + lam11, 1.0 + lam12, W)
            ca1, ca2, chi_a_bounded = self._limit(dphi1_d + lam11 * zv1, dphi2_d + lam12 * zv2, self.bound5)  # eq. (5)
        z = (zp1, zp2, zv1, zv2)

        # g_v = D^-1(phi) of eq. (2) from the nominal model
        d11, d12, d22 = inertia_entries(phi2, m)
        det = d11 * d22 - d12 * d12
        i11, i12, i22 = d22 / det, -d12 / det, d11 / det

        # eq. (28): mu_hat = -s tanh(R^-1 g^T grad J / (2 s)), g = diag(I, D^-1)
        gJ1, gJ2, gJ3, gJ4 = value_gradient(z, W)  # eq. (27): grad J_hat = grad(zeta)^T W
        x1 = gJ1 / (2.0 * s * rr[0])
        x2 = gJ2 / (2.0 * s * rr[1])
        x3 = (i11 * gJ3 + i12 * gJ4) / (2.0 * s * rr[2])
        x4 = (i12 * gJ3 + i22 * gJ4) / (2.0 * s * rr[3])
        t1, t2, t3, t4 = math.tanh(x1), math.tanh(x2), math.tanh(x3), math.tanh(x4)
        cs1, cs2 = -s * t1, -s * t2  # chi_vd*
        ts1, ts2 = -s * t3, -s * t4  # tau*

        # probing signal (section 4), added to the applied torque of both joints while t < pe_duration
        pe_active = t < self.params["pe_duration"]
        pe = probing_signal(t, self.params["pe_amplitude"]) if pe_active else 0.0
        tc1, tc2 = (ts1 + pe, ts2 + pe) if self.pe_form == "critic" else (ts1, ts2)

        # F_v(z_phi, z_v) of (4)/(6)
        if self.fv_error_form == "drift":
            fe1, fe2 = forward_dynamics(zp2, zv1, zv2, 0.0, 0.0, m)
        else:
            fe1, fe2 = 0.0, 0.0

        # modelled error dynamics (6) = (7): zdot = F_bar + g mu_hat (with the coupling terms of (6))
        if self.chi_a_form == "backstepping":
            zd1 = -lam11 * zp1 + cs1 + zv1
            zd2 = -lam12 * zp2 + cs2 + zv2
        else:
            zd1 = lam11 * zv1 + cs1 + zv1
            zd2 = lam12 * zv2 + cs2 + zv2
        zd3 = fe1 - lam21 * zv1 - zp1 + i11 * tc1 + i12 * tc2
        zd4 = fe2 - lam22 * zv2 - zp2 + i12 * tc1 + i22 * tc2
        zdot = (zd1, zd2, zd3, zd4)

        # eq. (29): eta = grad(zeta) zdot, e1 = W^T eta + z^T Theta z + Omega(mu_hat)
        eta = basis_directional(z, zdot)
        th = self.theta
        zqz = th[0] * zp1 * zp1 + th[1] * zp2 * zp2 + th[2] * zv1 * zv1 + th[3] * zv2 * zv2
        omega = (omega_term_of_arg(x1, s, rr[0]) + omega_term_of_arg(x2, s, rr[1])
                 + omega_term_of_arg(x3, s, rr[2]) + omega_term_of_arg(x4, s, rr[3]))  # eq. (17)
        rew = zqz + omega
        Wv = np.array(W)
        eta_v = np.array(eta)
        etaeta = float(eta_v @ eta_v)
        e1 = float(Wv @ eta_v) + rew

        # tuning law (30) / (31): normalised gradient on e1, plus the CL sum over the stack
        wdot = eta_v * (-self.alpha1 * e1 / (etaeta + 1.0) ** 2)
        if self.cl_enabled and self.stack_count:
            wdot -= self.alpha1 * (self.cl_M @ Wv + self.cl_b)
        law31 = zp1 * zd1 + zp2 * zd2 + zv1 * zd3 + zv2 * zd4 >= 0.0
        if law31:
            # eq. (31): + alpha2/2 grad(zeta) G z, G = g R^-1 g^T = diag(R1^-1, D^-1 R2^-1 D^-1)
            u1, u2 = i11 * zv1 + i12 * zv2, i12 * zv1 + i22 * zv2
            u1, u2 = u1 / rr[2], u2 / rr[3]
            gz = (zp1 / rr[0], zp2 / rr[1], i11 * u1 + i12 * u2, i12 * u1 + i22 * u2)
            wdot += (0.5 * self.alpha2) * np.array(basis_directional(z, gz))

        # d chi_vd / dt for tau^a, eq. (4)
        if self.chi_a_form == "backstepping":
            dca1, dca2 = ddphi1_d - lam11 * dzp1, ddphi2_d - lam12 * dzp2
        else:
            dca1, dca2 = ddphi1_d + lam11 * zd3, ddphi2_d + lam12 * zd4
        if chi_a_bounded:
            dca1 = dca2 = 0.0  # the bounded chi_vd^a is not differentiated (never active in section 4)
        if self.chi_dot_form == "chain":
            # chi_vd* = -s tanh(x_phi), x_phi = grad_phi J / (2 s r): dx/dt = (Hess zdot + grad(zeta)^T Wdot) / (2 s r)
            hs = value_hessian(W)
            wd = wdot.tolist()
            gd1, gd2, _, _ = value_gradient(z, wd)
            hz1 = hs[0][0] * zd1 + hs[0][1] * zd2 + hs[0][2] * zd3 + hs[0][3] * zd4
            hz2 = hs[1][0] * zd1 + hs[1][1] * zd2 + hs[1][2] * zd3 + hs[1][3] * zd4
            dcs1 = -s * (1.0 - t1 * t1) * (hz1 + gd1) / (2.0 * s * rr[0])
            dcs2 = -s * (1.0 - t2 * t2) * (hz2 + gd2) / (2.0 * s * rr[1])
        else:
            dcs1 = dcs2 = 0.0
        dchi1, dchi2 = dca1 + dcs1, dca2 + dcs2

        # eq. (4), second line: tau^a = D (F_v(z) + dchi_vd/dt - z_phi - Lambda2 z_v) - D F_v(phi, dphi)
        # with -D F_v(phi, dphi) = H dphi + G
        v1 = fe1 + dchi1 - zp1 - lam21 * zv1
        v2 = fe2 + dchi2 - zp2 - lam22 * zv2
        b1, b2 = bias_torque(phi2, dphi1, dphi2, m)
        ta1, ta2, tau_a_bounded = self._limit(d11 * v1 + d12 * v2 + b1, d12 * v1 + d22 * v2 + b2, self.bound5)  # eq. (5)

        # tau = tau* + tau^a (+ PE), then the actuator limit ||tau|| <= rho
        tau1, tau2, tau_limited = self._limit(ts1 + ta1 + pe, ts2 + ta2 + pe, self.rho)

        J = sum(w * b for w, b in zip(W, basis(z)))
        self._pending = {
            "t": t,
            "wdot": wdot,
            "eta": eta_v,
            "r": rew,
            "law": 31 if law31 else 30,
        }
        self._last_inputs = (float(t), [float(v) for v in y], [float(v) for v in r])
        self.outputs = [
            tau1, tau2, ts1, ts2, ta1, ta2, cs1, cs2, ca1, ca2, zp1, zp2, zv1, zv2, *W,
            J, e1, omega, 31.0 if law31 else 30.0, float(self.stack_count), self.cl_min_eig,
            1.0 if pe_active else 0.0, pe, float(tau_a_bounded), float(chi_a_bounded), float(tau_limited),
            math.hypot(tau1, tau2), dchi1, dchi2, float(np.sqrt(wdot @ wdot)),
        ]

    # --- learning over [t, t + dt) -----------------------------------------------------------------------

    def advance(self, t: float, dt: float) -> None:
        """Euler step of (30)/(31) with the rate computed at the last evaluate, then the CL stack."""
        pend = self._pending
        if pend is None or abs(pend["t"] - t) > 1e-9 * max(1.0, abs(t)):
            raise RuntimeError(f"advance({t}, {dt}) needs evaluate() at the same t first")
        wdot = pend["wdot"]
        self.W = [w + dt * wd for w, wd in zip(self.W, wdot.tolist())]
        if self.cl_enabled and t >= self.next_record_t - 1e-9:
            self.next_record_t += self.params["cl_record_interval"]
            self._record(pend["eta"], pend["r"])
        self._pending = None

    def _record(self, eta: np.ndarray, rew: float) -> None:
        """Store (eta(t_i), r(t_i)) in the CL stack according to ``cl_selection``."""
        P = self.P
        if self.stack_count < P:
            row = self.stack_count
            self.stack_count += 1
        elif self.cl_selection == "fill":
            return
        elif self.cl_selection == "fifo":
            row = self.stack_next
            self.stack_next = (self.stack_next + 1) % P
        else:  # "maxeig": swap the row whose replacement raises lambda_min(M) the most
            E = self.stack_eta
            sc = 1.0 / (1.0 + np.einsum("ij,ij->i", E, E)) ** 2
            terms = np.einsum("i,ij,ik->ijk", sc, E, E)
            cand = np.outer(eta, eta) / (1.0 + float(eta @ eta)) ** 2
            trial = self.cl_M[None, :, :] - terms + cand[None, :, :]
            eigs = np.linalg.eigvalsh(trial)[:, 0]
            row = int(np.argmax(eigs))
            if not eigs[row] > self.cl_min_eig:
                return
        self.stack_eta[row] = eta
        self.stack_r[row] = rew
        self._refresh_stack()
