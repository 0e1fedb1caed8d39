"""The FMI wrapper shared by every controller FMU: ports, parameters and the feedthrough rule.

Port convention (``fmu_controller.base``): inputs ``phi1, phi2, dphi1, dphi2`` (plant) and
``phi1_d ... ddphi2_d`` (reference), outputs ``tau1, tau2`` then the core's diagnostics. The torque
and every diagnostic computed from the measurement depend directly on every input: the torque read
at communication point t is computed from the inputs set at t, and the master holds it over
[t, t + T). Diagnostics of the learning state or of time alone (``STATE_OUTPUTS``, e.g. critic
weights) declare no input dependency. ``doStep(t, T)`` then lets the core learn over that interval.
A non-finite input makes every output that depends on the inputs read NaN (with a logged warning)
until it is replaced; the ``STATE_OUTPUTS`` keep showing the learning state.
"""
from __future__ import annotations

import math
import operator
from typing import Any, ClassVar

import numpy as np

from fmi_slave.parameters import ParameterError
from fmi_slave.slave import DescribedSlave, all_finite
from fmu_controller.base import MODEL_PARAMETER_SPECS, ControllerCore
from fmu_controller.ports import INPUT_UNITS, MEASUREMENT_PORTS, REFERENCE_PORTS, TORQUE_UNIT
from fmu_plant.dynamics import STEP_SIZE, ArmParameters

INPUT_PORTS = MEASUREMENT_PORTS + REFERENCE_PORTS
_MEASUREMENTS, _REFERENCES = operator.attrgetter(*MEASUREMENT_PORTS), operator.attrgetter(*REFERENCE_PORTS)
INPUT_DOCS = {
    "phi1": "Measured joint 1 angle", "phi2": "Measured joint 2 angle",
    "dphi1": "Measured joint 1 velocity", "dphi2": "Measured joint 2 velocity",
    "phi1_d": "Reference joint 1 angle", "phi2_d": "Reference joint 2 angle",
    "dphi1_d": "Reference joint 1 velocity", "dphi2_d": "Reference joint 2 velocity",
    "ddphi1_d": "Reference joint 1 acceleration", "ddphi2_d": "Reference joint 2 acceleration",
}


class ControllerSlave(DescribedSlave):
    """Subclasses set ``CORE`` (a ControllerCore subclass) and ``description``, and list in
    ``STATE_OUTPUTS`` the diagnostics computed from the learning state and time only: those declare
    no dependency on the inputs (``sotc-cosim validate`` checks both declarations by experiment)."""

    STEP_SIZE = STEP_SIZE  # the DefaultExperiment's step: T of the arm model (fmu_plant.dynamics)

    CORE: ClassVar[type[ControllerCore]]
    STATE_OUTPUTS: ClassVar[tuple[str, ...]] = ()

    def __init__(self, **kwargs: Any):
        super().__init__(**kwargs)
        self._param_specs = MODEL_PARAMETER_SPECS + self.CORE.PARAMETER_SPECS
        for spec in self._param_specs:
            self.declare_parameter(spec)
        for name in INPUT_PORTS:
            self.declare_input(name, INPUT_UNITS[name], INPUT_DOCS[name])
        self._core = self._make_core()
        units = {"tau1": (TORQUE_UNIT, "Joint 1 torque command, held over [t, t + T)"),
                 "tau2": (TORQUE_UNIT, "Joint 2 torque command, held over [t, t + T)")}
        units.update({o.name: (o.unit, o.description) for o in self.CORE.EXTRA_OUTPUTS})
        unknown = sorted(set(self.STATE_OUTPUTS) - set(self.CORE.output_names()))
        if unknown:
            raise ValueError(f"STATE_OUTPUTS {unknown} are not outputs of {self.CORE.__name__}")
        self._input_dependent = tuple(name not in self.STATE_OUTPUTS for name in self.CORE.output_names())
        for index, name in enumerate(self.CORE.output_names()):
            unit, doc = units[name]
            depends_on = INPUT_PORTS if self._input_dependent[index] else ()
            self.declare_output(name, unit, doc, depends_on=depends_on, getter=self._output_getter(index))
        self._stale = True  # inputs or learning state changed since the core last evaluated
        self._invalid_inputs: str | None = None  # why the input-dependent outputs are NaN, or None
        self._last_valid: tuple[list[float], list[float]] | None = None  # inputs of the last good evaluation

    def _make_core(self) -> ControllerCore:
        values = self.parameter_values(self._param_specs)
        model = ArmParameters.from_mapping({s.name: values[s.name] for s in MODEL_PARAMETER_SPECS})
        return self.CORE(model, **{s.name: values[s.name] for s in self.CORE.PARAMETER_SPECS})

    def _output_getter(self, index: int):
        return lambda: self.output_values()[index]

    def output_values(self) -> list[float]:
        """Every output in ``CORE.output_names()`` order, evaluated at most once per change of the
        inputs or of the learning state; NaN for the input-dependent ones while an input is bad."""
        if self._stale and self._initialized:
            self._evaluate()
        outputs = self._core.outputs  # a list, or the float64 buffer a kernel rewrites (sotc_kernel)
        if self._invalid_inputs is None:
            return outputs if type(outputs) is list else outputs.tolist()  # the FMI layer takes lists only
        return [math.nan if dependent else v for v, dependent in zip(outputs, self._input_dependent)]

    def _inputs(self) -> tuple[list[float], list[float]]:
        return list(_MEASUREMENTS(self)), list(_REFERENCES(self))

    def _evaluate(self, inputs_checked: bool = False) -> None:
        """Outputs for the current inputs. A bad input makes the input-dependent outputs NaN (logged),
        never a stale value; the state outputs are then evaluated at the last good inputs, which
        leaves them exact (they do not depend on the inputs) and the learning state untouched."""
        self._stale = False
        y, r = self._inputs()
        self._invalid_inputs = None if inputs_checked else self.input_problem(y + r)  # INPUT_PORTS order
        self._output_problem = self._invalid_inputs
        if self._invalid_inputs is not None:
            y, r = self._last_valid or ([0.0] * len(MEASUREMENT_PORTS), [0.0] * len(REFERENCE_PORTS))
        try:
            # absurd (finite) inputs may overflow: the non-finite outputs are detected and logged below,
            # so numpy's warnings would only add noise to the host's stderr
            if self._core.SILENT_FLOATING_POINT:  # no errstate to enter (about 1 us a call)
                self._core.evaluate(self._time, y, r)
            else:
                with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
                    self._core.evaluate(self._time, y, r)
        except Exception as exc:  # e.g. an overflow for absurd inputs: refuse these inputs, keep running
            self._invalid_inputs = f"the controller cannot evaluate these inputs: {type(exc).__name__}: {exc}"
            self._output_problem = self._invalid_inputs
            return
        if self._invalid_inputs is not None:
            return
        self._last_valid = (y, r)
        outputs = self._core.outputs  # a list, or the kernel's float64 buffer (summed as floats: a list)
        if not all_finite(outputs if type(outputs) is list else outputs.tolist()):
            self._output_problem = f"it is not finite for the finite inputs at t = {self._time!r}"

    def inputs_checked(self) -> bool:
        # an evaluation since the last set_real or restored state has checked the inputs (``_evaluate``)
        return not self._stale and self._invalid_inputs is None

    def set_real(self, vrs, values):
        self._stale = True  # first: a call refused halfway may have set some inputs
        super().set_real(vrs, values)

    def initialize(self) -> None:
        try:
            self._core = self._make_core()
        except ParameterError:
            raise
        except Exception as exc:  # the core failed on an admissible-looking combination: say which values
            values = self.parameter_values(self._param_specs)
            changed = ", ".join(f"'{s.name}' = {values[s.name]!r}" for s in self._param_specs
                                if values[s.name] != s.default) or "every parameter at its default"
            raise ValueError(f"the {self.CORE.__name__} core cannot be built with parameter {changed}: "
                             f"{type(exc).__name__}: {exc}") from exc
        self._stale = True

    def step(self, current_time: float, step_size: float) -> bool:
        if self._stale:
            self._evaluate(inputs_checked=True)  # the base class has refused bad inputs already
        if self._invalid_inputs is not None:
            return self.discard(f"{self._invalid_inputs}; the step is refused and the state is kept")
        if self._output_problem is not None:
            bad = next(n for n, v in zip(self.CORE.output_names(), self._core.outputs) if not math.isfinite(v))
            return self.discard(f"output '{bad}' is not finite at t = {current_time!r}: "
                                "the core does not learn from it; the step is refused and the state is kept")
        self._core.advance(current_time, step_size)
        self._stale = True  # the outputs now reflect the new learning state at the next read
        return True

    def internal_state(self) -> dict[str, Any]:
        return {"core": self._core.get_state()}

    def restore_internal_state(self, state: dict[str, Any]) -> None:
        if self._initialized:
            self._core = self._make_core()
            self._core.set_state(state.get("core", {}))
        # the cached evaluation belongs to the state left behind: the next read evaluates again
        self._stale = True
        self._invalid_inputs = None
