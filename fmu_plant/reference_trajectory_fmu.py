"""ReferenceTrajectory: FMI 2.0 co-simulation FMU of the desired path, eq. (47), mapped through the
inverse kinematics (48) to joint references with analytic first and second derivatives.

Outputs at a communication point t are the reference at t; they depend on time only.
"""
from __future__ import annotations

import math

from fmu_plant.slave_base import DescribedSlave as Fmi2Slave  # the name pythonfmu's binary looks for
from fmu_plant.trajectory import REFERENCE_SIGNALS, TRAJECTORY_PARAMETER_SPECS, CircleTrajectory

SIGNAL_DOCS = {
    "phi1_d": ("rad", "Reference angle of joint 1, eq. (48)"),
    "phi2_d": ("rad", "Reference angle of joint 2, eq. (48)"),
    "dphi1_d": ("rad/s", "Reference velocity of joint 1 (analytic)"),
    "dphi2_d": ("rad/s", "Reference velocity of joint 2 (analytic)"),
    "ddphi1_d": ("rad/s2", "Reference acceleration of joint 1 (analytic)"),
    "ddphi2_d": ("rad/s2", "Reference acceleration of joint 2 (analytic)"),
    "x_d": ("m", "Desired end-effector X, eq. (47)"),
    "y_d": ("m", "Desired end-effector Y, eq. (47)"),
}


class ReferenceTrajectory(Fmi2Slave):
    description = "Circular end-effector path (47) and its joint-space reference (48)"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        for spec in TRAJECTORY_PARAMETER_SPECS:
            self.declare_parameter(spec)
        for name in REFERENCE_SIGNALS:
            unit, doc = SIGNAL_DOCS[name]
            self.declare_output(name, unit, doc)
        self._trajectory = CircleTrajectory()

    def initialize(self) -> None:
        self._trajectory = CircleTrajectory(**self.parameter_values(TRAJECTORY_PARAMETER_SPECS))
        problem = self._publish(self._time)
        if problem:
            raise ValueError(f"{problem}: parameters 'rate' = {self.rate!r}, 'radius' = {self.radius!r} give no "
                             "finite reference")

    def _publish(self, t: float) -> str | None:
        """Set the outputs to the reference at t, or (leaving them) say which one is not finite."""
        try:
            values = self._trajectory.sample(t)
        except (ValueError, OverflowError) as exc:
            return f"the reference at t = {t!r} cannot be computed: {exc}"
        for name, value in zip(REFERENCE_SIGNALS, values):
            if not math.isfinite(value):
                return f"output '{name}' would be {value!r} at t = {t!r}"
        for name, value in zip(REFERENCE_SIGNALS, values):
            setattr(self, name, value)
        return None

    def step(self, current_time: float, step_size: float) -> bool:
        # the outputs follow time alone: the reference at the time this step reaches
        problem = self._publish(self.next_time(current_time, step_size))
        return self.discard(f"{problem}; the step is refused and the state is kept") if problem else True

    def restore_internal_state(self, state) -> None:
        if self._initialized:
            self._trajectory = CircleTrajectory(**self.parameter_values(TRAJECTORY_PARAMETER_SPECS))
