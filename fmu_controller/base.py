"""The contract every controller core honours, and the port convention every controller FMU shares.

A controller FMU reads the plant's measurement and the reference at a communication point t and
outputs the torque to hold over [t, t + T) (direct feedthrough: ``tau`` depends on the inputs at
the same instant). Learning, if any, happens in ``advance`` during ``doStep(t, T)``.

Cores are plain numpy/float code with no FMI import: the FMU wrapper (``fmu_controller.slave``)
and the pure closed loop (``orchestration.study.pure_loop``) call the same methods.
"""
from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import Any, ClassVar, Sequence

from fmi_slave.parameters import ParameterError, ParameterSpec, check_all
from fmu_controller.ports import TORQUE_PORTS
from fmu_plant.dynamics import ARM_PARAMETER_SPECS, ArmParameters

# Parameters renamed in 0.2.0 (CHANGELOG.md): the torque limit is ``rho`` in every controller, as in the paper.
RENAMED_PARAMETERS = {"tau_max": "rho", "tau_limit": "rho"}


# The nominal model a model-based controller uses: the plant's physical constants (not l1, l2).
MODEL_PARAMETER_SPECS: tuple[ParameterSpec, ...] = tuple(
    s for s in ARM_PARAMETER_SPECS if s.name in ("p1", "p2", "p3", "f1", "f2", "b1", "b2")
)


@dataclass(frozen=True)
class OutputSpec:
    """An extra (diagnostic) output of a controller: name, unit, description."""

    name: str
    unit: str
    description: str


class ControllerCore(ABC):
    """Base of every controller core.

    Subclasses declare ``PARAMETER_SPECS`` (their own tuning, validated on construction) and
    ``EXTRA_OUTPUTS`` (diagnostics after tau1, tau2), and implement ``evaluate``.
    """

    PARAMETER_SPECS: ClassVar[tuple[ParameterSpec, ...]] = ()
    EXTRA_OUTPUTS: ClassVar[tuple[OutputSpec, ...]] = ()
    # True when ``evaluate`` gives numpy no floating-point warning to print (no numpy arithmetic, or
    # only inside its own ``np.errstate``): the FMU then calls it without entering one itself
    SILENT_FLOATING_POINT: ClassVar[bool] = False

    def __init__(self, model: ArmParameters | None = None, **params: float):
        self.model = model if model is not None else ArmParameters()
        for old in params.keys() & RENAMED_PARAMETERS.keys():
            raise ParameterError(old, f"renamed '{RENAMED_PARAMETERS[old]}' in 0.2.0 (see CHANGELOG.md)")
        self.params = check_all(self.PARAMETER_SPECS, params)
        # tau1, tau2, then EXTRA_OUTPUTS in order; written by evaluate()
        self.outputs: list[float] = [0.0] * (2 + len(self.EXTRA_OUTPUTS))

    @classmethod
    def output_names(cls) -> tuple[str, ...]:
        return TORQUE_PORTS + tuple(o.name for o in cls.EXTRA_OUTPUTS)

    @abstractmethod
    def evaluate(self, t: float, y: Sequence[float], r: Sequence[float]) -> None:
        """Compute ``self.outputs`` for measurement y (MEASUREMENT_PORTS order) and reference r
        (REFERENCE_PORTS order) at time t. Must not change the learning state: calling it twice
        with the same arguments gives the same outputs."""

    def advance(self, t: float, dt: float) -> None:
        """Update the internal (learning) state over [t, t + dt) from the last ``evaluate``."""

    def get_state(self) -> dict[str, Any]:
        """Everything ``advance`` changes, as JSON-serialisable values."""
        return {}

    def set_state(self, state: dict[str, Any]) -> None:
        """Restore what ``get_state`` returned."""
