"""MeasurementNoise: FMI 2.0 and 3.0 co-simulation FMU between the plant and a controller.

Inputs ``phi1, phi2, dphi1, dphi2`` (the plant's state), outputs ``phi1_m .. dphi2_m`` = input +
seeded Gaussian noise (``fmu_plant.perturbation``); each output depends directly on its input. The
draw at communication point t_k depends on (seed, k) only.
"""
from __future__ import annotations

import math

from fmi_slave.parameters import check_all
from fmi_slave.slave import (
    DescribedSlave as Fmi2Slave,  # the name pythonfmu's binary looks for
)
from fmu_plant.paper_setting import STEP_SIZE
from fmu_plant.perturbation import MAX_SEED, NOISE_PARAMETER_SPECS, NoiseSequence

PORTS = (("phi1", "rad"), ("phi2", "rad"), ("dphi1", "rad/s"), ("dphi2", "rad/s"))


class MeasurementNoise(Fmi2Slave):
    STEP_SIZE = STEP_SIZE  # the DefaultExperiment's step: T of the arm model (fmu_plant.dynamics)
    description = "Seeded Gaussian measurement noise on the arm's angles and velocities (robustness studies)"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        for spec in NOISE_PARAMETER_SPECS:
            self.declare_parameter(spec)
        self.declare_integer_parameter("seed", 0, 0, MAX_SEED, "Seed of the noise sequence")
        for index, (name, unit) in enumerate(PORTS):
            self.declare_input(name, unit, f"True {name} (from the plant)")
            self.declare_output(f"{name}_m", unit, f"Measured {name} = true value + noise", depends_on=(name,),
                                getter=self._getter(name, index))
        self._noise = NoiseSequence(0)
        self._std = (0.0, 0.0, 0.0, 0.0)

    def _getter(self, name: str, index: int):
        def get() -> float:
            value = getattr(self, name)
            if self._initialized and math.isfinite(value):
                value += self._std[index] * float(self._noise.at(self._steps)[index])
            if not math.isfinite(value):  # refused by the base class's get, naming it and the input
                self._output_problem = f"input '{name}' is {getattr(self, name)!r}"
            return value
        return get

    def initialize(self) -> None:
        values = check_all(NOISE_PARAMETER_SPECS, self.parameter_values(NOISE_PARAMETER_SPECS))
        self._noise = NoiseSequence(self.seed)
        self._std = (values["std_phi"], values["std_phi"], values["std_dphi"], values["std_dphi"])

    def step(self, current_time: float, step_size: float) -> bool:
        return True  # the next sample index (the base class counts the steps) selects the next draw

    def restore_internal_state(self, state) -> None:
        if self._initialized:
            self.initialize()
