"""Saturated optimal tracking controller (SOTC) of Dien, Luy, Lai & Hai (2023): the pure core.

Reference: N. D. Dien, N. T. Luy, L. K. Lai, T. T. Hai, "Optimal tracking control for robot
manipulators with input constraint based reinforcement learning", J. Computer Science and
Cybernetics, 2023. Equation numbers are the paper's. Where the
paper is ambiguous, the chosen reading is the default and each alternative stays selectable
through an integer ``*_form`` / ``cl_*`` / ``weight_integrator`` parameter; the reasons and the
measured effect of each are in ``docs/paper-notes.md``.

One sample (``evaluate`` at t_k, then ``advance(t_k, T)``):

1. error z = [z_phi, z_v], eqs. (6)/(7): z_phi = phi - phi_d and z_v = dphi - chi_vd with
   chi_vd = chi_vd* + chi_vd^a. chi_vd* of (28) depends on z_v, so z_v is solved for (Newton, with a
   guess-free fallback for large W; the residual is the output ``zv_residual``);
2. critic J_hat = W^T zeta(z), eq. (27), and the saturated law mu_hat = [chi_vd*, tau*], eq. (28);
3. the modelled error rate zdot of (6)/(7), eta = grad(zeta) zdot, the Bellman residual e1 of (29)
   and the weight rate of the tuning law (30) or (31), with the concurrent-learning sum;
4. feedforward inputs (4) with the bound (5); tau = tau* + tau^a + PE (while probing), then the
   actuator limit ||tau|| <= rho;
5. ``advance``: one linearly implicit Euler step of (30)/(31) over [t_k, t_k + T) and the CL
   stack update (``sotc_stack``).
"""
from __future__ import annotations

import math
import operator
from array import array
from math import fsum, nan  # Python's own (math.f is C's libm f in the compiled core)
from typing import Any, ClassVar, Sequence

from fmi_slave.parameters import ParameterError, ParameterSpec, nonnegative, positive
from fmu_controller.base import ControllerCore, OutputSpec
from fmu_controller.saturation import (
    ACCEL,
    JOINT,
    NONE,
    clip_box,
    limit_handling_spec,
    limit_torque,
    limit_without_metric,
    saturate_norm,
)
from fmu_controller.elementary import hypot, tanh
from fmu_controller.fixed_linalg import add_scaled, buffer, cholesky, cholesky_solve, dot, scale_into
from fmu_controller.sotc_math import (N_BASIS, CriticConstants, basis, critic_row, directional_into, gradient,
                                      implicit_system, normalisation, policy_arguments, probing_signal, value_hessian)
from fmu_controller.sotc_stack import REPLAYS as CL_REPLAYS
from fmu_controller.sotc_stack import SELECTIONS as CL_SELECTIONS
from fmu_controller.sotc_stack import CLStack
from fmu_controller.sotc_zv import solve_zv
from fmu_plant.dynamics import (
    TORQUE_LIMIT,
    ArmParameters,
    bias_torque,
    forward_dynamics,
    inertia_entries,
)

TANH1 = tanh(1.0)

W0_BOUND = 1e8  # |W0_i| far beyond this (1e300) or r_i below 1e-6 overflow (28) at the first sample

# Reading switches (integer-coded parameters); index 0 is the chosen reading, see docs/paper-notes.md.
CHI_A_FORMS = ("backstepping", "literal")  # chi_vd^a = dphi_d - L1 z_phi | dphi_d + L1 z_v (as printed)
FV_ERROR_FORMS = ("drift", "zero")  # F_v(z_phi, z_v) = -D(z_phi)^-1 (H(z) z_v + G(z_v)) (as printed) | 0
ACTUATOR_FORMS = ("norm", "joint")  # limit rho: on ||tau||_2 (as printed) | on each |tau_i|
SATURATION_FORMS = ("sigma", "rho")  # level of (13)/(28): sigma (Remark 2) | rho (as printed)
CHI_DOT_FORMS = ("chain", "feedforward", "difference")  # dchi_vd/dt: chain rule | d(chi_vd^a)/dt | backward diff.
PE_FORMS = ("torque", "critic")  # PE on the applied torque only | also inside the critic's mu_hat
WEIGHT_INTEGRATORS = ("implicit", "euler")  # (30)/(31) over a step: linearly implicit | explicit Euler
ETA_FORMS = ("coupled", "printed")  # zdot in eta/(29): full (6) | F_bar of (7) as printed, without +z_v, -z_phi


def _switch(name: str, choices: tuple[str, ...], description: str) -> ParameterSpec:
    options = ", ".join(f"{i} = {c}" for i, c in enumerate(choices))
    return ParameterSpec(name, 0.0, "1", f"{description} ({options})", low=0.0, high=float(len(choices) - 1))


_L1 = "Lambda_1 = diag(lambda1_1, lambda1_2) of the feedforward (4); paper: 1"
_L2 = "Lambda_2 = diag(lambda2_1, lambda2_2) of the feedforward (4); paper: 1"
_THETA = "Theta = diag(theta_1..theta_4) of the cost (12), weight of {}; paper: 1"
_R = "R = diag(r_1..r_4) of the input cost (13), weight of {}; paper: R = 1"

SOTC_PARAMETER_SPECS: tuple[ParameterSpec, ...] = (
    positive("lambda1_1", 1.0, "1/s", _L1, high=1e6),
    positive("lambda1_2", 1.0, "1/s", _L1, high=1e6),
    positive("lambda2_1", 1.0, "1/s", _L2, high=1e6),
    positive("lambda2_2", 1.0, "1/s", _L2, high=1e6),
    positive("theta_1", 1.0, "1", _THETA.format("z_phi1"), high=1e6),
    positive("theta_2", 1.0, "1", _THETA.format("z_phi2"), high=1e6),
    positive("theta_3", 1.0, "1", _THETA.format("z_v1"), high=1e6),
    positive("theta_4", 1.0, "1", _THETA.format("z_v2"), high=1e6),
    ParameterSpec("r_1", 1.0, "1", _R.format("chi_vd*1"), low=1e-6, high=1e6),
    ParameterSpec("r_2", 1.0, "1", _R.format("chi_vd*2"), low=1e-6, high=1e6),
    ParameterSpec("r_3", 1.0, "1", _R.format("tau*1"), low=1e-6, high=1e6),
    ParameterSpec("r_4", 1.0, "1", _R.format("tau*2"), low=1e-6, high=1e6),
    positive("alpha1", 50.0, "1/s", "Critic learning rate alpha_1 of the tuning laws (30)/(31); paper: 50", high=1e6),
    positive("alpha2", 0.01, "1/s", "Stabilising gain alpha_2 of the tuning law (31); paper: 0.01", high=1e6),
    # lower bounds 1e-6 N.m: below that 1/(2 sigma r) of (28) overflows for admissible r
    ParameterSpec("sigma", 0.6, "N.m",
                  "Saturation level sigma of the optimal input, 0 < sigma < rho (Remark 2, eq. (5)); paper: 0.6",
                  low=1e-6, high=1e3),
    ParameterSpec("rho", TORQUE_LIMIT, "N.m", "Torque limit rho, ||tau|| <= rho (eqs. (1), (5)); paper: 4", low=1e-6, high=1e3),
    ParameterSpec("P", 20.0, "1",
                  "Size P of the concurrent-learning stack, an integer >= 10 = number of weights; paper: 20",
                  low=10.0, high=1000.0),
    *(ParameterSpec(f"W0_{k}", 0.0, "1", f"Initial critic weight W_{k}(0) of eq. (27); paper: 0", -W0_BOUND, W0_BOUND)
      for k in range(1, N_BASIS + 1)),
    nonnegative("pe_amplitude", 0.5, "N.m", "Gain of the section-4 probing signal PE (the paper's factor 0.5)",
                high=1e3),
    nonnegative("pe_duration", 0.4, "s",
                "PE is added to both joint torques while t < pe_duration; paper: 0.4 s (80 s without CL)"),
    ParameterSpec("cl_enabled", 1.0, "1", "Concurrent learning (experience replay) in (30)/(31): 1 = on, 0 = off",
                  low=0.0, high=1.0),
    positive("cl_record_interval", 0.02, "s",
             "Time between CL stack records (0.02 s: P = 20 records during the 0.4 s of PE)", high=1e3),
    _switch("cl_selection", CL_SELECTIONS, "Which samples the CL stack keeps"),
    _switch("cl_replay", CL_REPLAYS, "What the CL sum of (30)/(31) replays"),
    nonnegative("cl_start_time", 0.0, "s",
                "The CL sum enters (30)/(31) only for t >= cl_start_time (records are taken from t = 0): "
                "0 = from the first record; the paper's 'PE for 0.4 s, then CL' is 0.4", high=1e6),
    _switch("eta_form", ETA_FORMS,
            "Error rate in eta and the residual (29): (6) with its coupling terms +z_v, -z_phi, or F_bar of (7) as printed"),
    _switch("weight_integrator", WEIGHT_INTEGRATORS, "How (30)/(31) is integrated over a step"),
    _switch("chi_a_form", CHI_A_FORMS, "Reading of chi_vd^a in (4)"),
    _switch("fv_error_form", FV_ERROR_FORMS, "Reading of F_v(z_phi, z_v) in (4)/(6)"),
    limit_handling_spec(ACCEL, "the feedforward tau^a under the bound (5) (chi_vd^a: radial, per joint under 1); "
                        "1 clips each joint to (5) and the actuator limit then caps ||tau|| <= rho; 3 also drops "
                        "the actuator limit"),
    _switch("actuator_form", ACTUATOR_FORMS, "How the torque limit rho on the output is enforced"),
    _switch("saturation_form", SATURATION_FORMS, "Saturation level of (13) and (28)"),
    _switch("chi_dot_form", CHI_DOT_FORMS, "How dchi_vd/dt in tau^a of (4) is obtained"),
    _switch("pe_form", PE_FORMS, "Where the probing signal enters"),
)

_SWITCHES: dict[str, tuple[str, ...]] = {
    "cl_enabled": ("off", "on"),
    "cl_selection": CL_SELECTIONS,
    "cl_replay": CL_REPLAYS,
    "weight_integrator": WEIGHT_INTEGRATORS,
    "chi_a_form": CHI_A_FORMS,
    "fv_error_form": FV_ERROR_FORMS,
    "eta_form": ETA_FORMS,
    "actuator_form": ACTUATOR_FORMS,
    "saturation_form": SATURATION_FORMS,
    "chi_dot_form": CHI_DOT_FORMS,
    "pe_form": PE_FORMS,
}

_EXTRA: tuple[OutputSpec, ...] = (
    OutputSpec("tau_star1", "N.m", "Saturated optimal torque tau*_1, eq. (28)"),
    OutputSpec("tau_star2", "N.m", "Saturated optimal torque tau*_2, eq. (28)"),
    OutputSpec("tau_a1", "N.m", "Feedforward torque tau^a_1 of (4) after the bound (5)"),
    OutputSpec("tau_a2", "N.m", "Feedforward torque tau^a_2 of (4) after the bound (5)"),
    OutputSpec("chi_vd_star1", "rad/s", "Saturated optimal virtual velocity chi_vd*_1, eq. (28)"),
    OutputSpec("chi_vd_star2", "rad/s", "Saturated optimal virtual velocity chi_vd*_2, eq. (28)"),
    OutputSpec("chi_vd_a1", "rad/s", "Feedforward virtual velocity chi_vd^a_1 of (4) after the bound (5)"),
    OutputSpec("chi_vd_a2", "rad/s", "Feedforward virtual velocity chi_vd^a_2 of (4) after the bound (5)"),
    OutputSpec("z1", "rad", "Error z_phi1 = phi1 - phi1_d, eq. (6)"),
    OutputSpec("z2", "rad", "Error z_phi2 = phi2 - phi2_d, eq. (6)"),
    OutputSpec("z3", "rad/s", "Error z_v1 = dphi1 - chi_vd1, eq. (6)"),
    OutputSpec("z4", "rad/s", "Error z_v2 = dphi2 - chi_vd2, eq. (6)"),
    *(OutputSpec(f"W{k}", "1", f"Critic weight W_{k} of eq. (27) used at this sample") for k in range(1, N_BASIS + 1)),
    OutputSpec("J_hat", "1", "Critic value J_hat(z) = W^T zeta(z), eq. (27)"),
    OutputSpec("e1", "1", "Bellman (HJB) residual e1 = W^T eta + z^T Theta z + Omega(mu_hat), eq. (29)"),
    OutputSpec("Omega", "1", "Saturated input cost Omega(mu_hat), eq. (17)"),
    OutputSpec("cost_rate", "1/s", "Integrand of the cost (12): z^T Theta z + Omega(mu_hat)"),
    OutputSpec("tuning_law", "1", "Tuning law in force: 30 if z^T zdot < 0, else 31"),
    OutputSpec("cl_stack_size", "1", "Number of samples in the CL stack"),
    OutputSpec("cl_stack_min_eig", "1",
               "lambda_min of the CL matrix sum_i eta_i eta_i^T / (eta_i^T eta_i + 1)^2 at this sample"),
    OutputSpec("pe_active", "1", "1 while the probing signal is added (t < pe_duration), else 0"),
    OutputSpec("pe", "N.m", "Probing signal added to both joint torques at this sample"),
    OutputSpec("tau_a_bounded", "1", "1 if the bound (5) changed tau^a at this sample, else 0"),
    OutputSpec("chi_a_bounded", "1", "1 if the bound (5) changed chi_vd^a at this sample, else 0"),
    OutputSpec("tau_limited", "1", "1 if the actuator limit rho changed tau at this sample, else 0"),
    OutputSpec("tau_norm", "N.m", "Euclidean norm ||tau|| of the output torque"),
    OutputSpec("tau_a_raw1", "N.m", "Feedforward torque tau^a_1 of (4) before the bound (5)"),
    OutputSpec("tau_a_raw2", "N.m", "Feedforward torque tau^a_2 of (4) before the bound (5)"),
    OutputSpec("dchi_vd1", "rad/s2", "dchi_vd1/dt used in tau^a of (4)"),
    OutputSpec("dchi_vd2", "rad/s2", "dchi_vd2/dt used in tau^a of (4)"),
    OutputSpec("Wdot_norm", "1/s", "Norm of the weight rate dW/dt of (30)/(31) at this sample"),
    OutputSpec("zv_residual", "rad/s",
               "max_i |z_vi - (dphi_i - chi_vd*_i - chi_vd^a_i)|: residual of the implicit z_v of (6)/(28) after "
               "the solve (chi_vd^a before the bound (5) in the printed reading); rounding level when solved"),
)


class SotcCore(ControllerCore):
    """SOTC core: feedforward (4)-(5), critic (27), saturated law (28), tuning (30)/(31) with CL.

    ``model`` is the nominal arm model (D, H, G of (46)) used by tau^a of (4) and by g_v = D^-1;
    ``params`` are ``SOTC_PARAMETER_SPECS`` (defaults: section 4 of the paper, the ``paper`` setting).
    """

    PARAMETER_SPECS: ClassVar[tuple[ParameterSpec, ...]] = SOTC_PARAMETER_SPECS
    EXTRA_OUTPUTS: ClassVar[tuple[OutputSpec, ...]] = _EXTRA

    def __init__(self, model: ArmParameters | None = None, **params: float):
        super().__init__(model, **params)
        p = self.params
        if not p["sigma"] < p["rho"]:
            raise ParameterError(
                "sigma", f"{p['sigma']:g} must be smaller than rho = {p['rho']:g} (0 < sigma < rho, eq. (5))")
        if p["P"] != int(p["P"]):
            raise ParameterError(
                "P", f"{p['P']:g} must be an integer in [10, 1000] (rank(eta_1..eta_P) = 10 needs P >= 10)")
        for name, choices in _SWITCHES.items():
            if p[name] != int(p[name]):
                options = ", ".join(f"{i} = {c}" for i, c in enumerate(choices))
                raise ParameterError(name, f"{p[name]:g} is not one of the codes {options}")
        self.P = int(p["P"])
        self.lam1 = (p["lambda1_1"], p["lambda1_2"])
        self.lam2 = (p["lambda2_1"], p["lambda2_2"])
        self.theta = (p["theta_1"], p["theta_2"], p["theta_3"], p["theta_4"])
        self.r = (p["r_1"], p["r_2"], p["r_3"], p["r_4"])
        self.alpha1, self.alpha2 = p["alpha1"], p["alpha2"]
        self.rho, self.sigma = p["rho"], p["sigma"]
        self.pe_amplitude, self.pe_duration = p["pe_amplitude"], p["pe_duration"]
        self.cl_enabled = p["cl_enabled"] == 1.0
        self.cl_record_interval = p["cl_record_interval"]
        forms = {name: choices[int(p[name])] for name, choices in _SWITCHES.items()}
        self.backstepping = forms["chi_a_form"] == "backstepping"
        self.fv_drift = forms["fv_error_form"] == "drift"
        self.limit_code = int(p["limit_handling"])
        self.cl_start_time = p["cl_start_time"]
        self.eta_coupled = forms["eta_form"] == "coupled"
        self.actuator_per_joint = forms["actuator_form"] == "joint"
        self.chi_dot_form = forms["chi_dot_form"]
        self.pe_in_critic = forms["pe_form"] == "critic"
        self.implicit = forms["weight_integrator"] == "implicit"
        # saturation level s of (13) and (28): Remark 2 asks ||tau*|| <= sigma so that tau* + tau^a respects rho
        self.s = self.sigma if forms["saturation_form"] == "sigma" else self.rho
        self.bound5 = self.rho - self.sigma * TANH1  # eq. (5)
        self.constants = CriticConstants(self.s, self.r, self.theta, self.lam1, self.lam2, self.backstepping,
                                         self.eta_coupled)
        N = N_BASIS
        self._G, self._L, self._rhs, self._Wn = buffer(N * N), buffer(N * N), buffer(N), buffer(N)  # weight step
        self._eta, self._xi, self._wdot, self._gz = buffer(N), buffer(N), buffer(N), buffer(N)  # of the last sample
        self.stack = CLStack(self.P, forms["cl_selection"], forms["cl_replay"], self.constants)
        self.reset()

    # --- learning state ----------------------------------------------------------------------------

    def reset(self) -> None:
        """Back to t = 0: W = W(0), empty CL stack, nothing pending."""
        self.W = array("d", [self.params[f"W0_{k}"] for k in range(1, N_BASIS + 1)])
        self.stack.clear()
        self.next_record_t = 0.0
        self.prev_chi: list[float] | None = None  # (t, chi_vd1, chi_vd2) of the last step ("difference")
        self._pending: dict[str, Any] | None = None
        self._last_inputs: dict[str, Any] | None = None

    def get_state(self) -> dict[str, Any]:
        """Weights, CL stack, record clock, the previous chi_vd (``difference`` form) and the inputs of
        the last evaluate (so that ``set_state`` restores the outputs and the pending step too)."""
        return {
            "W": list(self.W),
            "stack": self.stack.to_state(),
            "next_record_t": self.next_record_t,
            "prev_chi": None if self.prev_chi is None else list(self.prev_chi),
            "last_inputs": None if self._last_inputs is None else dict(self._last_inputs),
        }

    def set_state(self, state: dict[str, Any]) -> None:
        W = array("d", [float(w) for w in state["W"]])
        if len(W) != N_BASIS:
            raise ValueError(f"state has {len(W)} weights, the SOTC critic has {N_BASIS}")
        self.stack.from_state(state["stack"])
        self.W = W
        prev = state.get("prev_chi")
        if prev is not None and (not isinstance(prev, list) or len(prev) != 3):
            raise ValueError(f"state prev_chi = {prev!r} must be null or [t, chi_vd1, chi_vd2]")
        if isinstance(state["next_record_t"], bool):
            raise ValueError(f"state next_record_t = {state['next_record_t']!r} must be a time in s")
        self.next_record_t = float(state["next_record_t"])
        self.prev_chi = None if prev is None else [float(v) for v in prev]
        self._pending = None
        self._last_inputs = None
        last = state.get("last_inputs")
        if last is not None:
            self.evaluate(last["t"], last["y"], last["r"])

    # --- one sample -----------------------------------------------------------------------------------

    def evaluate(self, t: float, y: Sequence[float], r: Sequence[float]) -> None:
        """Steps 1-4 of the module docstring at time t: the outputs, and what ``advance`` needs."""
        phi1, phi2, dphi1, dphi2 = float(y[0]), float(y[1]), float(y[2]), float(y[3])
        ref = (float(r[0]), float(r[1]), float(r[2]), float(r[3]), float(r[4]), float(r[5]))
        W, s = self.W, self.s
        hess = value_hessian(W)  # d^2 J_hat / dz^2: constant in z (quadratic basis)
        zp1, zp2, dzp1, dzp2, zv1, zv2, zv_res, ca1, ca2, chi_a_bounded = self._error(
            phi1, phi2, dphi1, dphi2, ref, hess)
        z = (zp1, zp2, zv1, zv2)

        # g_phi = I, g_v = D^-1(phi) of eq. (2), nominal model
        d11, d12, d22 = inertia_entries(phi2, self.model)
        det = d11 * d22 - d12 * d12
        dinv = (d22 / det, -d12 / det, d11 / det)
        x, (t1, t2, t3, t4) = self._policy_arguments(z, dinv)
        cs1, cs2 = -s * t1, -s * t2  # chi_vd*
        ts1, ts2 = -s * t3, -s * t4  # tau*

        # probing signal of section 4, added to both joint torques while t < pe_duration
        pe_active = t < self.pe_duration
        pe = probing_signal(t, self.pe_amplitude) if pe_active else 0.0
        tc = (ts1 + pe, ts2 + pe) if self.pe_in_critic else (ts1, ts2)
        fe = (0.0, 0.0)
        if self.fv_drift:  # F_v(z_phi, z_v) of (4)/(6): the drift -D^-1 (H v + G) of (2) at the error coordinates
            fe = forward_dynamics(zp2, zv1, zv2, 0.0, 0.0, self.model)
        zd, rew, omega, e1, cl, law31 = self._critic(t, z, (cs1, cs2, tc[0], tc[1]), fe, x, dinv)
        eta, xi, wdot = self._eta, self._xi, self._wdot
        dchi1, dchi2 = self._chi_dot(t, ref, (dzp1, dzp2), zd, z, (t1, t2), wdot, hess, (ca1 + cs1, ca2 + cs2),
                                     chi_a_bounded)
        ta1, ta2, tau_a_bounded, tr1, tr2 = self._feedforward(phi2, dphi1, dphi2, z, fe, (dchi1, dchi2),
                                                             (d11, d12, d22))
        tau1, tau2, tau_limited = self._actuator_limit(ts1 + ta1 + pe, ts2 + ta2 + pe)

        self._pending = {
            "t": t, "wdot": wdot, "xi": xi, "eta": eta, "r": rew, "z": z,
            "dinv": dinv, "fe": fe, "cl": cl, "chi": (ca1 + cs1, ca2 + cs2),
        }
        self._last_inputs = {"t": float(t), "y": [phi1, phi2, dphi1, dphi2], "r": list(ref)}
        J = fsum(map(operator.mul, W, basis(z)))
        self.outputs = [
            tau1, tau2, ts1, ts2, ta1, ta2, cs1, cs2, ca1, ca2, zp1, zp2, zv1, zv2, *W,
            J, e1, omega, rew, 31.0 if law31 else 30.0, float(self.stack.count), self.stack.min_eig,
            1.0 if pe_active else 0.0, pe, float(tau_a_bounded), float(chi_a_bounded), float(tau_limited),
            hypot(tau1, tau2), tr1, tr2, dchi1, dchi2, math.sqrt(dot(wdot, wdot, N_BASIS)), zv_res,
        ]

    def _error(self, phi1: float, phi2: float, dphi1: float, dphi2: float, ref: tuple[float, ...],
               hess: tuple[tuple[float, ...], ...]) -> tuple:
        """Step 1: z_phi, its measured rate, z_v (solved jointly with (28)) and chi_vd^a under (5)."""
        phi1_d, phi2_d, dphi1_d, dphi2_d = ref[:4]
        (lam11, lam12), code, W = self.lam1, self.limit_code, self.W
        h13, h14, h23, h24 = hess[0][2], hess[0][3], hess[1][2], hess[1][3]  # the z_phi z_v block of the Hessian
        # tracking error z_phi = chi_phi - chi_phi_d (section 2.1) and its measured rate
        zp1, zp2 = phi1 - phi1_d, phi2 - phi2_d
        dzp1, dzp2 = dphi1 - dphi1_d, dphi2 - dphi2_d
        # eq. (4), first line, with the bound (5); z_v = dphi - chi_vd* - chi_vd^a solved jointly with (28)
        if self.backstepping:  # chi_vd^a = dphi_d - Lambda1 z_phi, so F_bar_phi = -Lambda1 z_phi in (6)
            ca1, ca2, chi_a_bounded = limit_without_metric(dphi1_d - lam11 * zp1, dphi2_d - lam12 * zp2, self.bound5, code)
            zv1, zv2, zv_res = solve_zv(self.constants, zp1, zp2, dphi1 - ca1, dphi2 - ca2, 1.0, 1.0, W, h13, h14,
                                        h23, h24)
        else:  # as printed, chi_vd^a = dphi_d + Lambda1 z_v: (I + Lambda1) z_v = dphi - dphi_d - chi_vd*
            zv1, zv2, zv_res = solve_zv(self.constants, zp1, zp2, dzp1, dzp2, 1.0 + lam11, 1.0 + lam12, W, h13, h14,
                                        h23, h24)
            ca1, ca2, chi_a_bounded = limit_without_metric(dphi1_d + lam11 * zv1, dphi2_d + lam12 * zv2, self.bound5, code)
        return zp1, zp2, dzp1, dzp2, zv1, zv2, zv_res, ca1, ca2, chi_a_bounded

    def _policy_arguments(self, z: tuple[float, ...], dinv: tuple[float, float, float]) -> tuple:
        """Step 2, eq. (28): the tanh arguments x of mu_hat = -s tanh(x), and their tanh."""
        x = policy_arguments(self.constants, z[0], z[1], z[2], z[3], self.W, dinv[0], dinv[1], dinv[2])
        return x, (tanh(x[0]), tanh(x[1]), tanh(x[2]), tanh(x[3]))

    def optimal_virtual_velocity(self, z: tuple[float, ...]) -> tuple[float, float]:
        """chi_vd* of (28) at the error z under the current W (it does not depend on D^-1)."""
        _, (t1, t2, _, _) = self._policy_arguments(z, (1.0, 0.0, 1.0))
        return -self.s * t1, -self.s * t2

    def _critic(self, t: float, z: tuple[float, ...], mu: tuple[float, ...], fe: tuple[float, float],
                x: tuple[float, ...], dinv: tuple[float, float, float]) -> tuple:
        """Step 3, eqs. (6)/(7) and (29)-(31): zdot = F_bar(z) + g mu_hat (F_v(z_phi, z_v) = fe, the drift
        -D^-1 (H v + G) of (2) at the error coordinates), eta, the reward, the Bellman residual e1 and
        dW/dt (with the CL sum), every sum in a fixed order; eta, xi and dW/dt go to their buffers."""
        zp1, zp2, zv1, zv2 = z
        N, W, K, (i11, i12, i22) = N_BASIS, self.W, self.constants, dinv
        eta, xi, wdot = self._eta, self._xi, self._wdot
        # eq. (29): eta = grad(zeta) zdot, e1 = W^T eta + z^T Theta z + Omega(mu_hat), Omega of eq. (17)
        zd1, zd2, zd3, zd4, rew, omega = critic_row(K, zp1, zp2, zv1, zv2, x[0], x[1], x[2], x[3], mu[0], mu[1],
                                                    mu[2], mu[3], fe[0], fe[1], i11, i12, i22, eta, 0)
        e1 = dot(W, eta, N) + rew
        # eqs. (30)/(31): dW/dt = -alpha1 xi e1 - alpha1 sum_i xi_i (eta_i^T W + r_i) [+ alpha2/2 grad(zeta) G z],
        # xi = eta / (eta^T eta + 1)^2; the CL sum is M W + b (sotc_stack)
        scale_into(xi, 1.0 / normalisation(dot(eta, eta, N)), eta, N)
        scale_into(wdot, -self.alpha1 * e1, xi, N)
        cl = self.cl_enabled and self.stack.count > 0 and t >= self.cl_start_time
        if cl:
            add_scaled(wdot, -self.alpha1, self.stack.terms(W), N)  # - alpha1 (M W + b)
        law31 = zp1 * zd1 + zp2 * zd2 + zv1 * zd3 + zv2 * zd4 >= 0.0  # z^T zdot >= 0: eq. (31)
        if law31:  # + alpha2/2 grad(zeta) G z with G = g R^-1 g^T = diag(R_phi^-1, D^-1 R_v^-1 D^-1)
            u1, u2 = (i11 * zv1 + i12 * zv2) / K.r3, (i12 * zv1 + i22 * zv2) / K.r4
            gz = self._gz
            directional_into(gz, 0, zp1, zp2, zv1, zv2, zp1 / K.r1, zp2 / K.r2, i11 * u1 + i12 * u2,
                             i12 * u1 + i22 * u2)
            add_scaled(wdot, 0.5 * self.alpha2, gz, N)
        return (zd1, zd2, zd3, zd4), rew, omega, e1, cl, law31

    def _chi_dot(self, t: float, ref: tuple[float, ...], dzp: tuple[float, float], zd: tuple[float, ...],
                 z: tuple[float, ...], tanh_phi: tuple[float, float], wdot: array,
                 hess: tuple[tuple[float, ...], ...], chi: tuple[float, float], chi_a_bounded: bool) -> tuple:
        """dchi_vd/dt for tau^a of (4), as ``chi_dot_form`` reads it."""
        (lam11, lam12), rr = self.lam1, self.r
        ddphi1_d, ddphi2_d = ref[4:6]
        zd1, zd2, zd3, zd4 = zd
        if self.backstepping:
            dca1, dca2 = ddphi1_d - lam11 * dzp[0], ddphi2_d - lam12 * dzp[1]
        else:
            dca1, dca2 = ddphi1_d + lam11 * zd3, ddphi2_d + lam12 * zd4
        if chi_a_bounded:
            dca1 = dca2 = 0.0  # a bounded chi_vd^a is not differentiated (docs/paper-notes.md 2.5 lists where)
        if self.chi_dot_form == "chain":
            # chi_vd* = -s tanh(x_phi), x_phi = grad_phi J_hat / (2 s r): the chain rule gives
            # dx_phi/dt = (Hess(J_hat) zdot + grad(zeta)^T dW/dt)_phi / (2 s r), zdot from (6)
            h, (t1, t2) = hess, tanh_phi
            gd1, gd2, _, _ = gradient(z[0], z[1], z[2], z[3], wdot)
            hz1 = h[0][0] * zd1 + h[0][1] * zd2 + h[0][2] * zd3 + h[0][3] * zd4
            hz2 = h[1][0] * zd1 + h[1][1] * zd2 + h[1][2] * zd3 + h[1][3] * zd4
            return (dca1 - (1.0 - t1 * t1) * (hz1 + gd1) / (2.0 * rr[0]),
                    dca2 - (1.0 - t2 * t2) * (hz2 + gd2) / (2.0 * rr[1]))
        if self.chi_dot_form == "difference" and self.prev_chi is not None and t > self.prev_chi[0]:
            hstep = t - self.prev_chi[0]
            return (chi[0] - self.prev_chi[1]) / hstep, (chi[1] - self.prev_chi[2]) / hstep
        return dca1, dca2

    def _feedforward(self, phi2: float, dphi1: float, dphi2: float, z: tuple[float, ...], fe: tuple[float, float],
                     dchi: tuple[float, float], d: tuple[float, float, float]) -> tuple:
        """Step 4, eq. (4), second line, with g_v^-1 = D and -D F_v(phi, dphi) = H dphi + G:
        tau^a = D (F_v(z_phi, z_v) + dchi_vd/dt - z_phi - Lambda2 z_v) + H dphi + G, then the bound (5)."""
        zp1, zp2, zv1, zv2 = z
        (lam21, lam22), (d11, d12, d22) = self.lam2, d
        v1 = fe[0] + dchi[0] - zp1 - lam21 * zv1
        v2 = fe[1] + dchi[1] - zp2 - lam22 * zv2
        b1, b2 = bias_torque(phi2, dphi1, dphi2, self.model)
        tr1, tr2 = d11 * v1 + d12 * v2 + b1, d12 * v1 + d22 * v2 + b2
        if self.limit_code == JOINT:
            ta1, ta2, bounded = clip_box(tr1, tr2, self.bound5)
        else:
            ta1, ta2, bounded = limit_torque(self.limit_code, tr1, tr2, self.bound5, d11, d12, d22)
        return ta1, ta2, bounded, tr1, tr2

    def _actuator_limit(self, tau1: float, tau2: float) -> tuple[float, float, bool]:
        """Step 4: tau = tau* + tau^a (+ PE) under the actuator limit ||tau|| <= rho of eq. (1)."""
        if self.actuator_per_joint:
            return clip_box(tau1, tau2, self.rho)
        if self.limit_code != NONE:
            tau1, tau2, _, limited = saturate_norm(tau1, tau2, self.rho)
            return tau1, tau2, limited
        return tau1, tau2, False

    # --- learning over [t, t + dt) ---------------------------------------------------------------------

    def advance(self, t: float, dt: float) -> None:
        """Integrate (30)/(31) over [t, t + dt) from the last ``evaluate`` (which must be at t), then
        offer that sample to the CL stack (every ``cl_record_interval`` s).

        ``weight_integrator`` = implicit (chosen): the part of (30)/(31) linear in W, -alpha1 Gamma W
        with Gamma = xi eta^T + M (symmetric >= 0), is taken at the end of the step:
            (I + dt alpha1 Gamma) W+ = W + dt (dW/dt + alpha1 Gamma W).
        = euler: W+ = W + dt dW/dt, stable only while dt alpha1 lambda_max(Gamma) < 2, which the CL
        sum can break (lambda_max(Gamma) <= (P + 1)/4, i.e. up to 2.6 at the paper's values)."""
        pend = self._pending
        if pend is None or abs(pend["t"] - t) > 1e-9 * max(1.0, abs(t)):
            raise RuntimeError(f"advance({t}, {dt}) needs evaluate() at t = {t} first")
        if not (dt > 0.0 and math.isfinite(dt)):
            raise ValueError(f"advance: step size {dt} must be positive and finite")
        self.W = self._weight_step(pend, dt)
        if self.chi_dot_form == "difference":
            self.prev_chi = [t, *pend["chi"]]
        if self.cl_enabled and t >= self.next_record_t - 1e-9:
            self.next_record_t += self.cl_record_interval
            self.stack.record(pend["eta"], pend["r"], pend["z"], pend["dinv"], pend["fe"], t, pend["cl"])
        self._pending = None

    def _weight_step(self, pend: dict[str, Any], dt: float) -> array:
        """W after one step of (30)/(31); see ``advance``. (I + dt alpha1 Gamma) is symmetric positive
        definite, so a Cholesky solve in fixed order (``fixed_linalg``) gives W+."""
        N, W, wdot = N_BASIS, self.W, pend["wdot"]
        if not self.implicit:
            return array("d", [W[k] + dt * wdot[k] for k in range(N)])
        implicit_system(W, wdot, pend["xi"], pend["eta"], self.stack.M, pend["cl"], dt, dt * self.alpha1,
                        self._G, self._rhs)
        if not cholesky(self._G, N, self._L):  # I + (symmetric >= 0) fails only on non-finite or overflowing
            return array("d", [nan] * N)  # entries: non-finite weights, which the next sample's outputs report as such
        cholesky_solve(self._L, self._rhs, N, self._Wn)
        return array("d", self._Wn)

