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

from array import array
from typing import Any, ClassVar, Sequence

from fmi_slave.parameters import ParameterError, ParameterSpec, nonnegative, positive
from fmu_controller.base import ControllerCore, OutputSpec
from fmu_controller.saturation import ACCEL, limit_handling_spec
from fmu_numerics.elementary import tanh
from fmu_controller.sotc_kernel import SotcKernel
from fmu_controller.sotc_math import N_BASIS, CriticConstants, policy_arguments
from fmu_controller.sotc_stack import REPLAYS as CL_REPLAYS
from fmu_controller.sotc_stack import SELECTIONS as CL_SELECTIONS
from fmu_controller.sotc_stack import CLStack
from fmu_plant.dynamics import TORQUE_LIMIT, ArmParameters

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
    SILENT_FLOATING_POINT: ClassVar[bool] = True  # C doubles compiled; the Python build's numpy in errstate

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
        stack = CLStack(self.P, forms["cl_selection"], forms["cl_replay"], self.constants)
        self._kernel = SotcKernel(self, stack, 2 + len(_EXTRA))
        self.outputs = self._kernel.outputs  # one float64 buffer, rewritten by every evaluate
        self.reset()

    # --- learning state ----------------------------------------------------------------------------

    @property
    def stack(self) -> CLStack:
        """The CL stack the kernel offers every sample to (replacing it here replaces it there)."""
        return self._kernel.stack

    @stack.setter
    def stack(self, value: CLStack) -> None:
        self._kernel.stack = value

    @property
    def W(self) -> array:
        """The critic weights W of eq. (27) (a copy)."""
        return array("d", self._kernel.weights)

    @W.setter
    def W(self, values: Sequence[float]) -> None:
        self._kernel.weights[:] = array("d", values)

    @property
    def next_record_t(self) -> float:
        return self._kernel.next_record_t

    @property
    def prev_chi(self) -> list[float] | None:
        """(t, chi_vd1, chi_vd2) of the last step (``difference`` form), or None."""
        k = self._kernel
        return [k.prev_t, k.prev1, k.prev2] if k.has_prev else None

    @property
    def _pending(self) -> dict[str, Any] | None:
        """The sample the next ``advance`` integrates (for tests and studies)."""
        return self._kernel.pending()

    def reset(self) -> None:
        """Back to t = 0: W = W(0), empty CL stack, nothing pending."""
        self.W = [self.params[f"W0_{k}"] for k in range(1, N_BASIS + 1)]
        self.stack.clear()
        self._kernel.reset()

    def get_state(self) -> dict[str, Any]:
        """Weights, CL stack, record clock, the previous chi_vd (``difference`` form) and the inputs of
        the last evaluate (so that ``set_state`` restores the outputs and the pending step too)."""
        k = self._kernel
        return {
            "W": list(k.weights),
            "stack": self.stack.to_state(),
            "next_record_t": k.next_record_t,
            "prev_chi": self.prev_chi,
            "last_inputs": {"t": k.last_t, "y": list(k.last_y), "r": list(k.last_r)} if k.has_last else None,
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
        next_record_t = float(state["next_record_t"])
        prev = None if prev is None else [float(v) for v in prev]
        k = self._kernel
        k.reset()
        k.next_record_t = next_record_t
        if prev is not None:
            k.has_prev, (k.prev_t, k.prev1, k.prev2) = True, prev
        last = state.get("last_inputs")
        if last is not None:
            self.evaluate(last["t"], last["y"], last["r"])

    # --- one sample: the kernel's (sotc_kernel) --------------------------------------------------------

    def evaluate(self, t: float, y: Sequence[float], r: Sequence[float]) -> None:
        """Steps 1-4 of the module docstring at time t: the outputs, and what ``advance`` needs."""
        self._kernel.evaluate(t, y, r)

    def optimal_virtual_velocity(self, z: tuple[float, ...]) -> tuple[float, float]:
        """chi_vd* of (28) at the error z under the current W (it does not depend on D^-1)."""
        x = policy_arguments(self.constants, z[0], z[1], z[2], z[3], self._kernel.weights, 1.0, 0.0, 1.0)
        return -self.s * tanh(x[0]), -self.s * tanh(x[1])

    def advance(self, t: float, dt: float) -> None:
        """Integrate (30)/(31) over [t, t + dt) from the last ``evaluate`` (which must be at t), then
        offer that sample to the CL stack (every ``cl_record_interval`` s).

        ``weight_integrator`` = implicit (chosen): the part of (30)/(31) linear in W, -alpha1 Gamma W
        with Gamma = xi eta^T + M (symmetric >= 0), is taken at the end of the step:
            (I + dt alpha1 Gamma) W+ = W + dt (dW/dt + alpha1 Gamma W).
        = euler: W+ = W + dt dW/dt, stable only while dt alpha1 lambda_max(Gamma) < 2, which the CL
        sum can break (lambda_max(Gamma) <= (P + 1)/4, i.e. up to 2.6 at the paper's values)."""
        self._kernel.advance(t, dt)
