"""The FMI wrapper shared by every controller FMU: ports, parameters and the feedthrough rule.

Port convention (``fmu_controller.base``): inputs ``phi1, phi2, dphi1, dphi2`` (plant) and
``phi1_d ... ddphi2_d`` (reference), outputs ``tau1, tau2`` then the core's diagnostics. Every
output depends directly on every input: the torque read at communication point t is computed from
the inputs set at t, and the master holds it over [t, t + T). ``doStep(t, T)`` then lets the core
learn over that interval.
"""
from __future__ import annotations

from typing import Any, ClassVar

from fmu_controller.base import (
    INPUT_UNITS, MEASUREMENT_PORTS, MODEL_PARAMETER_SPECS, REFERENCE_PORTS, ControllerCore,
)
from fmu_plant.dynamics import ArmParameters
from fmu_plant.slave_base import DescribedSlave

INPUT_PORTS = MEASUREMENT_PORTS + REFERENCE_PORTS
INPUT_DOCS = {
    "phi1": "Measured joint 1 angle", "phi2": "Measured joint 2 angle",
    "dphi1": "Measured joint 1 velocity", "dphi2": "Measured joint 2 velocity",
    "phi1_d": "Reference joint 1 angle", "phi2_d": "Reference joint 2 angle",
    "dphi1_d": "Reference joint 1 velocity", "dphi2_d": "Reference joint 2 velocity",
    "ddphi1_d": "Reference joint 1 acceleration", "ddphi2_d": "Reference joint 2 acceleration",
}


class ControllerSlave(DescribedSlave):
    """Subclasses set ``CORE`` (a ControllerCore subclass) and ``description``."""

    CORE: ClassVar[type[ControllerCore]]

    def __init__(self, **kwargs: Any):
        super().__init__(**kwargs)
        self._param_specs = MODEL_PARAMETER_SPECS + self.CORE.PARAMETER_SPECS
        for spec in self._param_specs:
            self.declare_parameter(spec)
        for name in INPUT_PORTS:
            self.declare_input(name, INPUT_UNITS[name], INPUT_DOCS[name])
        self._core = self._make_core()
        units = {"tau1": ("N.m", "Joint 1 torque command, held over [t, t + T)"),
                 "tau2": ("N.m", "Joint 2 torque command, held over [t, t + T)")}
        units.update({o.name: (o.unit, o.description) for o in self.CORE.EXTRA_OUTPUTS})
        for index, name in enumerate(self.CORE.output_names()):
            unit, doc = units[name]
            self.declare_output(name, unit, doc, depends_on=INPUT_PORTS, getter=self._output_getter(index))
        self._stale = True

    def _make_core(self) -> ControllerCore:
        values = self.parameter_values(self._param_specs)
        model = ArmParameters.from_mapping({s.name: values[s.name] for s in MODEL_PARAMETER_SPECS})
        return self.CORE(model, **{s.name: values[s.name] for s in self.CORE.PARAMETER_SPECS})

    def _output_getter(self, index: int):
        def get() -> float:
            if self._stale and self._initialized:
                self._evaluate()
            return self._core.outputs[index]
        return get

    def _inputs(self) -> tuple[list[float], list[float]]:
        return [getattr(self, n) for n in MEASUREMENT_PORTS], [getattr(self, n) for n in REFERENCE_PORTS]

    def _evaluate(self) -> None:
        y, r = self._inputs()
        self._core.evaluate(self._time, y, r)
        self._stale = False

    def set_real(self, vrs, values):
        super().set_real(vrs, values)
        self._stale = True

    def initialize(self) -> None:
        self._core = self._make_core()
        self._stale = True

    def step(self, current_time: float, step_size: float) -> bool:
        reason = self.first_nonfinite(INPUT_PORTS)
        if reason:
            return self.discard(reason)
        if self._stale:
            self._evaluate()
        self._core.advance(current_time, step_size)
        self._stale = True  # the outputs now reflect the new learning state at the next read
        return True

    def internal_state(self) -> dict[str, Any]:
        return {"core": self._core.get_state()}

    def restore_internal_state(self, state: dict[str, Any]) -> None:
        if self._initialized:
            self._core = self._make_core()
            self._core.set_state(state.get("core", {}))
        self._stale = True
