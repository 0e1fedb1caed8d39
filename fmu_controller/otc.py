"""Reconstructed optimal tracking controller (OTC) of the SOTC paper's comparison (OtcCore).

The SOTC paper (Dien, Luy, Lai & Hai 2023, section 4) compares against the OTC of its
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

Torque limit (``limit_handling``, ``fmu_controller.saturation``): none by default, as the paper's
OTC; any handling of the other controllers can be applied to tau, the "clipped OTC" of the
comparison. The learning laws below use the designed u_hat either way.

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

from fmi_slave.parameters import (
    ParameterError,
    ParameterSpec,
    any_real,
    nonnegative,
    positive,
)
from fmu_controller.base import ControllerCore, OutputSpec
from fmu_numerics.elementary import exp, hypot
from fmu_numerics.fixed_linalg import dot_sequence
from fmu_controller.riccati import solve_care
from fmu_controller.saturation import NONE, limit_handling_spec, limit_torque
from fmu_controller.sotc_math import (
    N_BASIS,
    basis,
    basis_directional,
    matrix_to_weights,
    normalisation,
    probing_signal,
    value_gradient,
)
from fmu_plant.dynamics import (
    TORQUE_LIMIT,
    bias_torque,
    inertia_entries,
)

# The quadratic basis sigma(z) of (OTC-7) is the SOTC's zeta(z) of section 4 (same 10 monomials, same
# order), and the probing signal of (OTC-10) is the SOTC's PE(t): both come from sotc_math.
N_WEIGHTS = N_BASIS


def _norm(w: Sequence[float]) -> float:
    """||w||: the square root of the sum of squares in index order (``dot_sequence``; sqrt is correctly
    rounded), the same bits on every machine, unlike an n-argument hypot."""
    return math.sqrt(dot_sequence(w, w))


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
        positive("rho", TORQUE_LIMIT, "N.m", "Torque-norm bound: the over_limit diagnostic, and the limit that limit_handling enforces (if not 3 = none)", high=1e6),
        limit_handling_spec(NONE, "the total torque tau of (OTC-10) (the critic and actor learn from the unlimited u); "
                            "the paper's OTC is unsaturated"),
    )
    EXTRA_OUTPUTS = (
        OutputSpec("tau_norm", "N.m", "||tau|| of the commanded torque, eq. (OTC-10), after limit_handling"),
        OutputSpec("over_limit", "1", "1 when ||tau|| before limit_handling exceeds rho, else 0"),
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
        self._lam = (pr["lambda1"], pr["lambda2"])
        self._r = (pr["r1"], pr["r2"])
        self._limit_code = int(pr["limit_handling"])
        mode = pr["init_weights"]
        if mode not in (0.0, 1.0):
            raise ParameterError("init_weights", f"{mode:g} is not 0 (zeros) or 1 (Riccati)")
        if mode == 1.0:
            self.wc = matrix_to_weights(self.frozen_riccati(pr["init_phi2"]))
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
        d11, d12, d22 = inertia_entries(phi2, self.model)
        det = d11 * d22 - d12 * d12
        g = np.zeros((4, 2))
        g[2:, :] = [[d22 / det, -d12 / det], [-d12 / det, d11 / det]]  # D^-1, closed form
        stabilising = np.zeros((2, 4))
        stabilising[:, 2:] = [[d11, d12], [d12, d22]]  # u = -D z2: z2' = -z2, and z1' = -Lambda z1 + z2
        return solve_care(f, g, self.params["q"] * np.eye(4), np.diag(self.r_diag), stabilising)

    # --- control law --------------------------------------------------------------------------

    def evaluate(self, t: float, y: Sequence[float], r: Sequence[float]) -> None:
        # plain float arithmetic on 2- and 4-vectors (several times faster than small numpy arrays)
        phi1, phi2, dphi1, dphi2 = (float(v) for v in y)
        q1d, q2d, dq1d, dq2d, ddq1d, ddq2d = (float(v) for v in r[:6])
        lam1, lam2 = self._lam
        r1, r2 = self._r
        q = self.params["q"]
        e1, e2 = phi1 - q1d, phi2 - q2d
        de1, de2 = dphi1 - dq1d, dphi2 - dq2d
        z = (e1, e2, de1 + lam1 * e1, de2 + lam2 * e2)  # (OTC-3)

        d11, d12, d22 = inertia_entries(phi2, self.model)
        det = d11 * d22 - d12 * d12
        i11, i12, i22 = d22 / det, -d12 / det, d11 / det  # D^-1, closed-form 2x2 inverse
        ad1, ad2 = ddq1d - lam1 * de1, ddq2d - lam2 * de2  # alpha_dot
        b1, b2 = bias_torque(phi2, dphi1, dphi2, self.model)
        ta1, ta2 = d11 * ad1 + d12 * ad2 + b1, d12 * ad1 + d22 * ad2 + b2  # (OTC-4)

        # (OTC-7): u = -1/2 R^-1 g' grad(sigma)' Wa with g = [0; D^-1]: g' grad(sigma)' Wa = D^-1 dV_a/dz2
        _, _, ga3, ga4 = value_gradient(z, self.wa.tolist())
        u1 = -0.5 * (i11 * ga3 + i12 * ga4) / r1
        u2 = -0.5 * (i12 * ga3 + i22 * ga4) / r2

        # (OTC-5): z_dot = F z + g u, F = [[-Lambda, I], [0, 0]]
        z_dot = (-lam1 * z[0] + z[2], -lam2 * z[1] + z[3], i11 * u1 + i12 * u2, i12 * u1 + i22 * u2)
        omega = basis_directional(z, z_dot)  # grad(sigma) z_dot
        wc = self.wc.tolist()
        cost_rate = q * (z[0] * z[0] + z[1] * z[1] + z[2] * z[2] + z[3] * z[3]) + (u1 * (r1 * u1) + u2 * (r2 * u2))
        delta = dot_sequence(omega, wc) + cost_rate  # (OTC-8)

        probe = 0.0
        if t < self.params["probe_duration"]:
            probe = probing_signal(t, self.params["probe_amplitude"])
        raw1, raw2 = ta1 + u1 + probe, ta2 + u2 + probe  # (OTC-10)
        rho = self.params["rho"]
        over = hypot(raw1, raw2) > rho
        tau1, tau2, _ = limit_torque(self._limit_code, raw1, raw2, rho, d11, d12, d22)
        tau_norm = hypot(tau1, tau2)

        self._last = {
            "z": z, "dinv": (i11, i12, i22), "omega": omega, "cost_rate": cost_rate,
            "lyap_rate": z[0] * z_dot[0] + z[1] * z_dot[1] + z[2] * z_dot[2] + z[3] * z_dot[3],
        }
        self.outputs = [
            tau1, tau2,
            tau_norm, 1.0 if over else 0.0,
            ta1, ta2, u1, u2,
            z[2], z[3],
            dot_sequence(basis(z), wc), delta, cost_rate,
            _norm(wc), _norm(self.wa.tolist()),
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
        ww = dot_sequence(omega, omega)
        if ww > 0.0 and pr["alpha_c"] > 0.0:
            # exact solution of (OTC-8) for a held regressor: the residual omega'Wc + cost decays
            # as exp(-alpha_c ww/(ww+1)^2 t); only the component of Wc along omega moves.
            s0 = dot_sequence(omega, self.wc.tolist()) + last["cost_rate"]
            decay = exp(-pr["alpha_c"] * ww / normalisation(ww) * dt)
            self.wc = self.wc - np.array(omega) * (s0 * (1.0 - decay) / ww)
        decay_a = exp(-pr["alpha_a"] * dt)
        wa = self.wc + (self.wa - self.wc) * decay_a
        if last["lyap_rate"] > 0.0 and pr["alpha_s"] > 0.0:
            # stabilising term of (OTC-9): alpha_s/2 grad(sigma) g R^-1 g' z, g R^-1 g' z = [0; D^-1 R^-1 D^-1 z2]
            z, (i11, i12, i22) = last["z"], last["dinv"]
            v1, v2 = (i11 * z[2] + i12 * z[3]) / self._r[0], (i12 * z[2] + i22 * z[3]) / self._r[1]
            gz = (0.0, 0.0, i11 * v1 + i12 * v2, i12 * v1 + i22 * v2)
            wa = wa + (0.5 * pr["alpha_s"] * dt) * np.array(basis_directional(z, gz))
        self.wa = wa

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

