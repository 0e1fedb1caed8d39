"""Disturbance: FMI 2.0 and 3.0 co-simulation FMU of the disturbance torques d1, d2 (``fmu_plant.perturbation``).

Outputs are a function of time only (no inputs): connect them to the plant's inputs d1, d2.
"""
from __future__ import annotations

from fmi_slave.parameters import check_all
from fmi_slave.slave import (
    TimeFunctionSlave as Fmi2Slave,  # the name pythonfmu's binary looks for
)
from fmu_plant.paper_setting import STEP_SIZE
from fmu_plant.perturbation import DISTURBANCE_PARAMETER_SPECS, disturbance_torque


class Disturbance(Fmi2Slave):
    STEP_SIZE = STEP_SIZE  # the DefaultExperiment's step: T of the arm model (fmu_plant.dynamics)
    description = "Step and sinusoidal disturbance torques for the arm's inputs d1, d2 (robustness studies)"
    TIME_OUTPUTS = ("d1", "d2")

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        for spec in DISTURBANCE_PARAMETER_SPECS:
            self.declare_parameter(spec)
        self.declare_output("d1", "N.m", "Disturbance torque on joint 1")
        self.declare_output("d2", "N.m", "Disturbance torque on joint 2")
        self._values = {s.name: s.default for s in DISTURBANCE_PARAMETER_SPECS}

    def initialize(self) -> None:
        self._values = check_all(DISTURBANCE_PARAMETER_SPECS, self.parameter_values(DISTURBANCE_PARAMETER_SPECS))
        self.publish_initial(tuple(self._values))

    def outputs_at(self, t: float) -> tuple[float, float]:
        return disturbance_torque(t, **self._values)

    def restore_internal_state(self, state) -> None:
        if self._initialized:
            self.initialize()
