"""Saturated computed-torque baseline (CtCore).

The classical computed-torque (inverse-dynamics) law on the nominal model of eq. (1) of the SOTC
paper (Dien, Luy, Lai & Hai 2023), followed by the paper's torque constraint:

    e = phi - phi_d,   e_dot = dphi - dphi_d                                         (CT-1)
    v = ddphi_d - Kd e_dot - Kp e                                                    (CT-2)
    tau_raw = D(phi) v + H(phi, dphi) dphi + G(dphi)                                 (CT-3)
    tau = tau_raw                          if ||tau_raw|| <= rho                     (CT-4)
        = tau_raw * rho / ||tau_raw||      otherwise

With the model exact and (CT-4) inactive, substituting (CT-3) into eq. (1) gives
D (ddphi - v) = 0, i.e. the decoupled linear error dynamics e_ddot + Kd e_dot + Kp e = 0 per joint.

Saturation acts on the Euclidean norm, as the paper's constraint ||tau|| <= rho (section 2.1,
rho = 4 N.m in section 4): the whole vector is scaled down, which keeps its direction. Clipping each
joint to +-rho instead would allow ||tau|| up to sqrt(2) rho and so violate the paper's
bound. (CT-4) is ``fmu_controller.saturation.limit_torque``, shared with every controller; the
parameter ``limit_handling`` selects radial scaling (0, the default and the formula above), per-joint
clip then norm cap (1), the D^-2-metric projection the SOTC uses for its bound (5) (2), or none (3).

Default gains: kp = 25 1/s^2, kd = 10 1/s, i.e. a critically damped double pole at -5 rad/s per
joint (kd = 2 sqrt(kp)). kd T = 0.1 at T = 0.01 s, far from the sampling limit kd T ~ 2, and the
PD share of the torque at the tracking errors reached after the transient (1e-3 rad) is small
against the friction compensation (~2.6 N.m), so the bound is active only during the initial
transient. Measured on the paper's scenario (docs/baselines.md).
"""
from __future__ import annotations

from typing import Sequence

from fmi_slave.parameters import ParameterSpec, positive
from fmu_controller.base import ControllerCore, OutputSpec
from fmu_numerics.elementary import hypot
from fmu_controller.saturation import ACCEL, limit_handling_spec, limit_torque
from fmu_plant.dynamics import TORQUE_LIMIT, inertia_entries, inverse_dynamics

# the paper's torque bound rho, section 4

RHO_SPEC = positive("rho", TORQUE_LIMIT, "N.m", "Torque limit rho, ||tau|| <= rho (the paper's eq. (1)), eq. (CT-4)")
# (CT-4) by default: radial scaling; every other handling of fmu_controller.saturation is selectable
LIMIT_SPEC = limit_handling_spec(0, "the computed torque tau_raw, eq. (CT-4)")


class LinearisingCore(ControllerCore):
    """Feedback linearisation with error feedback, saturated on the norm: the common frame of the
    computed-torque and LQR baselines. Subclasses give the feedback acceleration w(e, e_dot):

        tau_raw = D(phi) (ddphi_d + w) + H(phi, dphi) dphi + G(dphi),   tau = sat(tau_raw)   (CT-3), (CT-4)
    """

    EXTRA_OUTPUTS = (
        OutputSpec("tau_norm_raw", "N.m", "||tau|| before saturation, eq. (CT-3)"),
        OutputSpec("saturated", "1", "1 when the limit handling (CT-4) changed the torque, else 0"),
        OutputSpec("v1", "rad/s2", "Error-feedback acceleration w_1 of joint 1 (added to ddphi1_d)"),
        OutputSpec("v2", "rad/s2", "Error-feedback acceleration w_2 of joint 2 (added to ddphi2_d)"),
    )

    def feedback(self, e1: float, e2: float, de1: float, de2: float) -> tuple[float, float]:
        raise NotImplementedError

    def evaluate(self, t: float, y: Sequence[float], r: Sequence[float]) -> None:
        phi1, phi2, dphi1, dphi2 = (float(v) for v in y)
        q1d, q2d, dq1d, dq2d, ddq1d, ddq2d = (float(v) for v in r[:6])
        w1, w2 = self.feedback(phi1 - q1d, phi2 - q2d, dphi1 - dq1d, dphi2 - dq2d)  # eq. (CT-1)
        raw1, raw2 = inverse_dynamics(phi2, dphi1, dphi2, ddq1d + w1, ddq2d + w2, self.model)  # eq. (CT-3)
        code = int(self.params["limit_handling"])
        d = inertia_entries(phi2, self.model) if code == ACCEL else (1.0, 0.0, 1.0)
        tau1, tau2, sat = limit_torque(code, raw1, raw2, self.params["rho"], *d)  # eq. (CT-4)
        self.outputs = [tau1, tau2, hypot(raw1, raw2), 1.0 if sat else 0.0, w1, w2]


class CtCore(LinearisingCore):
    """Computed torque with PD error feedback, saturated on the torque norm, eqs. (CT-1)..(CT-4)."""

    PARAMETER_SPECS: tuple[ParameterSpec, ...] = (
        positive("kp", 25.0, "1/s2", "Position gain Kp of the error dynamics e_ddot + Kd e_dot + Kp e = 0, eq. (CT-2)", high=1e6),
        positive("kd", 10.0, "1/s", "Velocity gain Kd of the error dynamics, eq. (CT-2); 2 sqrt(kp) is critical damping", high=1e4),
        RHO_SPEC,
        LIMIT_SPEC,
    )

    def feedback(self, e1: float, e2: float, de1: float, de2: float) -> tuple[float, float]:
        kp, kd = self.params["kp"], self.params["kd"]
        return -kd * de1 - kp * e1, -kd * de2 - kp * e2  # eq. (CT-2): v = ddphi_d + w
