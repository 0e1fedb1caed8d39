"""ReferenceTrajectory: FMI 2.0 and 3.0 co-simulation FMU of the desired path, eq. (47), mapped through the
inverse kinematics (48) to joint references with analytic first and second derivatives.

Outputs at a communication point t are the reference at t; they depend on time only.
"""
from __future__ import annotations

from fmi_slave.slave import (
    TimeFunctionSlave as Fmi2Slave,  # the name pythonfmu's binary looks for
)
from fmu_plant.paper_setting import STEP_SIZE
from fmu_plant.trajectory import (
    REFERENCE_SIGNALS,
    TRAJECTORY_PARAMETER_SPECS,
    CircleTrajectory,
)

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
    STEP_SIZE = STEP_SIZE  # the DefaultExperiment's step: T of the arm model (fmu_plant.dynamics)
    description = "Circular end-effector path (47) and its joint-space reference (48)"
    TIME_OUTPUTS = REFERENCE_SIGNALS

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
        self.publish_initial(("rate", "radius"))

    def outputs_at(self, t: float) -> tuple[float, ...]:
        return self._trajectory.sample(t)

    def restore_internal_state(self, state) -> None:
        if self._initialized:
            self._trajectory = CircleTrajectory(**self.parameter_values(TRAJECTORY_PARAMETER_SPECS))
