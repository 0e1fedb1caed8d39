"""The sampled closed loop in plain Python: exactly what the FMU master does, without FMUs.

Per step k (t_k = k T, computed from the step count, never by summing T):

1. sample the reference r(t_k);
2. controller.evaluate(t_k, y_m(t_k), r(t_k)) -> torque (direct feedthrough), where y_m = y plus the
   measurement noise of draw k (``fmu_plant.perturbation.NoiseSequence``, the MeasurementNoise FMU's);
3. record sample k (the true y);
4. plant: RK4 (``dynamics.integrate``) over [t_k, t_k + T) with tau + d(t_k) held (zero-order hold;
   d = ``perturbation.disturbance_torque``, the Disturbance FMU's);
5. controller.advance(t_k, T) (learning over the same interval).

With a plant ``arm`` other than the controller's model, a disturbance and noise, this is the
``paper-perturbed`` scenario through the FMUs (tests/orchestration/test_pure_loop_perturbed.py).

Samples are recorded at t_0 .. t_N inclusive (N = stop_time / T; 10,001 samples for 100 s at
T = 0.01 s); at t_N the controller is evaluated and recorded but neither the plant nor the
controller is advanced.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from fmu_controller.base import ControllerCore
from fmu_plant.dynamics import ArmParameters, integrate
from fmu_plant.paper_setting import INITIAL_ANGLES, INITIAL_VELOCITIES, STEP_SIZE, SUBSTEPS
from fmu_plant.perturbation import (
    DISTURBANCE_PARAMETER_SPECS,
    NOISE_PARAMETER_SPECS,
    NoiseSequence,
    disturbance_torque,
)
from fmu_plant.trajectory import CircleTrajectory
from orchestration.run.metrics import tracking_metrics


_DEFAULT = {spec.name: spec.default for spec in (*DISTURBANCE_PARAMETER_SPECS, *NOISE_PARAMETER_SPECS)}


@dataclass(frozen=True)
class Perturbation:
    """The Disturbance and MeasurementNoise FMUs' parameters (their defaults: no perturbation)."""

    step1: float = _DEFAULT["step1"]
    step2: float = _DEFAULT["step2"]
    step_time: float = _DEFAULT["step_time"]
    sin1: float = _DEFAULT["sin1"]
    sin2: float = _DEFAULT["sin2"]
    omega: float = _DEFAULT["omega"]
    std_phi: float = _DEFAULT["std_phi"]
    std_dphi: float = _DEFAULT["std_dphi"]
    seed: int = 0  # the MeasurementNoise FMU's default seed

    @property
    def disturbs(self) -> bool:
        """False where ``disturbance`` is (0.0, 0.0) at every t: no amplitude other than +0.0."""
        return any(a != 0.0 or math.copysign(1.0, a) < 0.0 for a in (self.step1, self.step2, self.sin1, self.sin2))

    @property
    def noisy(self) -> bool:
        """False where ``measure`` returns the state itself (no noise): a loop may skip the call then."""
        return self.std_phi != 0.0 or self.std_dphi != 0.0

    def disturbance(self, t: float) -> tuple[float, float]:
        return disturbance_torque(t, self.step1, self.step2, self.step_time, self.sin1, self.sin2, self.omega)

    def measure(self, state: tuple[float, float, float, float], noise: NoiseSequence, k: int) -> tuple[float, ...]:
        """y_m(t_k) = y + std * (the draws of sample k), component by component."""
        if not self.noisy:
            return state
        n1, n2, n3, n4 = noise.row(k)
        a, v = self.std_phi, self.std_dphi
        return state[0] + a * n1, state[1] + a * n2, state[2] + v * n3, state[3] + v * n4


NO_PERTURBATION = Perturbation()


@dataclass
class LoopResult:
    """Recorded samples of one run; every array has one row per sample t_0 .. t_N."""

    t: np.ndarray  # (N+1,)
    y: np.ndarray  # (N+1, 4) phi1, phi2, dphi1, dphi2
    ref: np.ndarray  # (N+1, 8) CircleTrajectory.sample: phi_d, dphi_d, ddphi_d, x_d, y_d
    outputs: np.ndarray  # (N+1, 2 + extras) tau1, tau2, extras in controller.output_names() order
    names: tuple[str, ...] = field(default=())

    def out(self, name: str) -> np.ndarray:
        """One controller output column by name."""
        return self.outputs[:, self.names.index(name)]

    @property
    def error(self) -> np.ndarray:
        """e = phi - phi_d, (N+1, 2)."""
        return self.y[:, :2] - self.ref[:, :2]

    @property
    def tau(self) -> np.ndarray:
        return self.outputs[:, :2]


def steps(stop_time: float, step: float) -> int:
    """N = stop_time / T; ValueError unless stop_time is a positive whole multiple of the step."""
    n = int(round(stop_time / step))
    if n < 1 or abs(n * step - stop_time) > 1e-9 * max(1.0, stop_time):
        raise ValueError(f"stop_time {stop_time} must be a positive integer multiple of step {step}")
    return n


def simulate(
    controller_core: ControllerCore,
    stop_time: float = 100.0,
    step: float = STEP_SIZE,
    arm: ArmParameters | None = None,
    trajectory: CircleTrajectory | None = None,
    phi0: tuple[float, float] = INITIAL_ANGLES,
    dphi0: tuple[float, float] = INITIAL_VELOCITIES,
    substeps: int = SUBSTEPS,
    perturbation: Perturbation = NO_PERTURBATION,
) -> LoopResult:
    """Run the sampled zero-order-hold loop (see module docstring) and return the recording; by
    default from section 4's initial state with the plant FMU's substeps (``fmu_plant.paper_setting``)."""
    arm = arm if arm is not None else ArmParameters()
    trajectory = trajectory if trajectory is not None else CircleTrajectory()
    n = steps(stop_time, step)
    names = controller_core.output_names()
    ts = np.empty(n + 1)
    ys = np.empty((n + 1, 4))
    refs = np.empty((n + 1, 8))
    outs = np.empty((n + 1, len(names)))
    state = (float(phi0[0]), float(phi0[1]), float(dphi0[0]), float(dphi0[1]))
    noise = NoiseSequence(perturbation.seed)
    for k in range(n + 1):
        t = k * step
        ref = trajectory.sample(t)
        controller_core.evaluate(t, perturbation.measure(state, noise, k), ref[:6])
        out = controller_core.outputs
        ts[k] = t
        ys[k] = state
        refs[k] = ref
        outs[k] = out
        if k == n:
            break
        d1, d2 = perturbation.disturbance(t)
        state = integrate(state, out[0] + d1, out[1] + d2, step, substeps, arm)
        controller_core.advance(t, step)
    return LoopResult(ts, ys, refs, outs, names)


def metrics(res: LoopResult, late_from: float = 50.0) -> dict[str, float]:
    """The project's target figures, from ``orchestration.run.metrics.tracking_metrics``: MSE (50) per
    joint over all samples, max |e| for t >= late_from (or over the last half of a shorter run),
    max ||tau||."""
    late = min(late_from, 0.5 * float(res.t[-1]))
    m = tracking_metrics(res.t, res.error, res.tau, stop_time=2.0 * late)
    return {
        "mse1": m["mse"][0],
        "mse2": m["mse"][1],
        "max_late_e1": m["max_abs_error_last_half"][0],
        "max_late_e2": m["max_abs_error_last_half"][1],
        "max_tau_norm": m["max_tau_norm"],
    }
