"""``ExchangeSlave``: a ``WrappedSlave`` that also exports FMI 3.0 Model Exchange (pythonfmu3's
``ModelExchange``): the host integrates the continuous states with its own solver while the inputs
are held as it sets them. A model lists its state arrays in ``STATE_ARRAYS`` (FMI 3 variables of the
wrapped class, read like any output) and gives ``state_derivatives()`` and ``set_states(values)``.

The derivative of a state array ``x`` is the state array ``dx`` where there is one (the angles'
derivative is the velocity); otherwise a local array ``der(x)`` that reads ``state_derivatives``.
"""
from __future__ import annotations

from typing import ClassVar

from pythonfmu3 import Fmi3Causality, Fmi3Variability, Float64
from pythonfmu3.modelexchange import ModelExchange
from pythonfmu3.variables import Dimension

from fmi3_slave.slave import WrappedSlave


class ExchangeSlave(WrappedSlave, ModelExchange):
    STATE_ARRAYS: ClassVar[tuple[str, ...]] = ()

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        vr_of = {v.name: vr for vr, v in self.vars.items()}
        self._state_vrs = [vr_of[s] for s in self.STATE_ARRAYS]
        self._derivative_of: dict[int, int] = {}  # derivative variable -> its state variable
        self._local: dict[int, slice] = {}  # der(x) variables -> their part of state_derivatives()
        offset = 0
        for name, vr in zip(self.STATE_ARRAYS, self._state_vrs):
            size = len(self._scalars[vr])
            if f"d{name}" in self.STATE_ARRAYS:
                self._derivative_of[vr_of[f"d{name}"]] = vr
            else:
                unit = self.vars[vr].unit
                var = Float64(f"der({name})", causality=Fmi3Causality.local, variability=Fmi3Variability.continuous,
                              description=f"Time derivative of {name}", getter=lambda: None,
                              dimensions=[Dimension(start=str(size))] if size > 1 else [],
                              unit=f"{unit}/s" if unit and "/" not in unit else (f"{unit}2" if unit else None))
                self.register_variable(var)
                self._derivative_of[var.value_reference] = vr
                self._local[var.value_reference] = slice(offset, offset + size)
            offset += size

    def derivative_references(self) -> list[int]:
        """The FMI 3 variables that are state derivatives, in the order of the states."""
        by_state = {state: d for d, state in self._derivative_of.items()}
        return [by_state[vr] for vr in self._state_vrs]

    def state_derivatives(self) -> list[float]:  # pragma: no cover - abstract
        raise NotImplementedError

    def set_states(self, values: list[float]) -> None:  # pragma: no cover - abstract
        raise NotImplementedError

    def get_float64(self, vrs):
        if any(vr in self._local for vr in vrs):
            values = self._forward(self.state_derivatives)
            out = []
            for vr in vrs:
                out += values[self._local[vr]] if vr in self._local else super().get_float64([vr])
            return out
        return super().get_float64(vrs)

    def get_continuous_states(self) -> list[float]:
        return super().get_float64(self._state_vrs)

    def set_continuous_states(self, values) -> None:
        self._forward(self.set_states, [float(v) for v in values])

    def get_continuous_state_derivatives(self) -> list[float]:
        return self._forward(self.state_derivatives)

    def get_number_of_continuous_states(self) -> int:
        return sum(len(self._scalars[vr]) for vr in self._state_vrs)

    def get_nominals_of_continuous_states(self, size: int) -> list[float]:
        return [1.0] * size

    def set_time(self, time: float) -> None:
        self.time = self._inner._time = float(time)

    def to_xml(self, model_options: dict[str, str] = dict()):  # noqa: B006 (pythonfmu3's signature)
        root = super().to_xml(model_options)
        # written here: pythonfmu3 0.3.4 formats a ``derivative`` attribute of an array like its start
        for element in root.find("ModelVariables"):
            state = self._derivative_of.get(int(element.get("valueReference")))
            if state is not None:
                element.set("derivative", str(state))
        return root
