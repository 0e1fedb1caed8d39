"""``WrappedSlave``: an FMI 3.0 co-simulation slave (pythonfmu3) around an FMI 2 model class of
``fmi_slave`` (``WRAPPED``, e.g. ``fmu_plant.arm_plant_fmu.ArmPlant``).

Every FMI 3 call goes to the one wrapped instance through the calls of FMI 2 it corresponds to, so
the two versions share everything but the calling convention: parameters refused with the same
messages at ``exitInitializationMode``, non-finite inputs discarded by ``doStep`` with the state
kept, non-finite outputs refused by name, FMU states checked field by field and applied all or
nothing (``fmi_slave.fmu_state``). What FMI 3 adds is presented here: arrays over the scalars
(``fmi3_slave.arrays``), Float64/Int32 types, an ``independent`` time variable.

pythonfmu3 0.3.4's binary (measured, the same as pythonfmu 0.7's): on a Python exception in a
callback it releases its references to the model class, the instance and the log queue, and again
when the instance is freed; ``_forward`` takes one extra reference to each before an exception
leaves (``fmi_slave.pythonfmu_fixes.balance_releases``). Its regex finds the model class by a base
named ``Fmi3Slave``, so each FMI 3 script imports this class under that name.
"""
from __future__ import annotations

import re
from typing import Any, Callable, ClassVar

from pythonfmu3 import Fmi3Causality, Fmi3Slave, Fmi3Status, Fmi3Variability, Float64, Int32
from pythonfmu3.default_experiment import DefaultExperiment
from pythonfmu3.enums import Fmi3Initial
from pythonfmu3.variables import Dimension

from fmi_slave.fmu_state import FmuStateMixin
from fmi_slave.pythonfmu_fixes import balance_releases
from fmi_slave.slave import DescribedSlave
from fmi3_slave.arrays import group
from fmi3_slave.model_description import complete_model_description

# the FMI 2 calls the shared code names in its messages -> what an FMI 3 host called
_CALLS = {"fmi2GetReal": "fmi3GetFloat64", "fmi2SetReal": "fmi3SetFloat64", "fmi2GetInteger": "fmi3GetInt32",
          "fmi2SetInteger": "fmi3SetInt32", "fmi2GetFMUstate": "fmi3GetFMUState",
          "fmi2SetFMUstate": "fmi3SetFMUState", "fmi2SetupExperiment": "fmi3EnterInitializationMode"}
_CALL = re.compile(r"\bfmi2([A-Z][A-Za-z]*)")
_CAUSALITY = {"parameter": Fmi3Causality.parameter, "input": Fmi3Causality.input,
              "output": Fmi3Causality.output, "local": Fmi3Causality.local}
_VARIABILITY = {"fixed": Fmi3Variability.fixed, "continuous": Fmi3Variability.continuous,
                "discrete": Fmi3Variability.discrete, "tunable": Fmi3Variability.tunable}


class WrappedSlave(Fmi3Slave):
    """Subclasses set ``WRAPPED`` (a ``DescribedSlave`` subclass); nothing else."""

    WRAPPED: ClassVar[type[DescribedSlave]]
    # CoSimulation flags (FMI 3 spelling); the FMU state calls are the wrapped class's
    OPTIONS: ClassVar[dict[str, bool]] = {
        "needsExecutionTool": True, "canBeInstantiatedOnlyOncePerProcess": False,
        "canGetAndSetFMUState": True, "canSerializeFMUState": True,
        "canHandleVariableCommunicationStepSize": True, "needsCompletedIntegratorStep": False,
    }

    def __init__(self, **kwargs: Any):
        super().__init__(**kwargs)
        inner = self._inner = self.WRAPPED(instance_name=kwargs["instance_name"], resources=kwargs.get("resources"))
        for attr in ("author", "license", "version", "description"):  # the model's, on its class
            setattr(self, attr, getattr(inner, attr) or getattr(type(inner), attr, None))
        e = inner.default_experiment or type(inner).default_experiment  # pythonfmu's is on the class
        if e is not None:
            self.default_experiment = DefaultExperiment(e.start_time, e.stop_time, e.step_size, e.tolerance)
        self.time = 0.0
        self.register_variable(Float64("time", causality=Fmi3Causality.independent,
                                       variability=Fmi3Variability.continuous, description="Simulation time",
                                       getter=lambda: self._inner._time, setter=None))
        # FMI 3 value reference -> the wrapped scalars' value references (one for a scalar)
        self._scalars: dict[int, tuple[int, ...]] = {}
        self._expanded: dict[tuple[int, ...], tuple[int, ...]] = {}
        by_name = {v.name: v for v in inner.vars.values()}
        kind = lambda name: (by_name[name].causality, type(by_name[name]).__name__)  # noqa: E731
        for name, members in group(by_name, kind):
            self._register_group(name, [by_name[m] for m in members])

    def _register_group(self, name: str, members: list) -> None:
        first, meta = members[0], self._inner._meta
        cls = Int32 if type(first).__name__ == "Integer" else Float64
        extra: dict[str, Any] = {"dimensions": [Dimension(start=str(len(members)))]} if len(members) > 1 else {}
        units = {meta[m.name].unit for m in members}
        if cls is Float64 and len(units) == 1 and None not in units:
            extra["unit"] = units.pop()
        description = first.description if len(members) == 1 else _array_description(members, meta)
        causality = _CAUSALITY[first.causality.name]
        initial = Fmi3Initial.exact if causality == Fmi3Causality.parameter else None
        var = cls(name, causality=causality, variability=_VARIABILITY[first.variability.name], initial=initial,
                  description=description, getter=lambda: None, setter=None, **extra)
        self.register_variable(var)
        self._scalars[var.value_reference] = tuple(m.value_reference for m in members)

    # --- the calls, forwarded -----------------------------------------------------------------

    def _forward(self, call: Callable, *args: Any) -> Any:
        """Run one wrapped call; hand its log messages to the host, and balance the binary's extra
        releases if it raises (the wrapped instance has logged why)."""
        try:
            return call(*args)
        except Exception:
            balance_releases(self, type(self), self.log_queue)
            raise
        finally:
            if self._inner.log_queue:
                for message in self._inner.log_queue:
                    self.log(fmi3_text(message.msg), Fmi3Status(int(message.status)))
                self._inner.log_queue.clear()

    def _expand(self, vrs) -> tuple[int, ...]:
        """The wrapped scalars' value references for a list of FMI 3 value references."""
        key = tuple(vrs)
        found = self._expanded.get(key)
        if found is None:
            unknown = [vr for vr in key if vr not in self._scalars]
            if unknown:
                raise ValueError(f"no variable of {type(self).__name__} that can be read or set has valueReference "
                                 f"{unknown[0]} (time is read with fmi3GetFloat64 on its own)")
            found = tuple(s for vr in key for s in self._scalars[vr])
            if len(self._expanded) < 64:
                self._expanded[key] = found
        return found

    def _sized(self, call: str, vrs, values) -> tuple[int, ...]:
        """The wrapped scalars of ``vrs``, refused before anything is set (naming each variable with its
        size) unless ``values`` holds exactly one value per element (was: zip() argument 2 is shorter)."""
        scalars = self._expand(vrs)
        if len(values) != len(scalars):
            sizes = ", ".join(f"'{self.vars[vr].name}' ({len(self._scalars[vr])})" for vr in vrs)
            message = f"{call}: {len(values)} values for {sizes}, which take {len(scalars)}; nothing was set"
            self.log(message, Fmi3Status.error)
            raise ValueError(message)
        return scalars

    def get_float64(self, vrs):
        if len(vrs) == 1 and vrs[0] == 0:  # the independent variable
            return [self._inner._time]
        return self._forward(lambda: self._inner.get_real(self._expand(vrs)))

    def set_float64(self, vrs, values):
        self._forward(lambda: self._inner.set_real(self._sized("fmi3SetFloat64", vrs, values), list(values)))

    def get_int32(self, vrs):
        return self._forward(lambda: self._inner.get_integer(self._expand(vrs)))

    def set_int32(self, vrs, values):
        self._forward(lambda: self._inner.set_integer(self._sized("fmi3SetInt32", vrs, values), list(values)))

    def setup_experiment(self, start_time: float):
        self._forward(self._inner.setup_experiment, start_time)

    def enter_initialization_mode(self):
        self._forward(self._inner.enter_initialization_mode)

    def exit_initialization_mode(self):
        self._forward(self._inner.exit_initialization_mode)

    def do_step(self, current_time: float, step_size: float) -> bool:
        return self._forward(self._inner.do_step, current_time, step_size)

    def terminate(self):
        self._forward(self._inner.terminate)

    def _get_fmu_state(self) -> dict[str, Any]:
        return self._forward(self._inner._get_fmu_state)

    def _set_fmu_state(self, state: dict[str, Any]) -> None:
        self._forward(self._inner._set_fmu_state, state)

    # called on the class by the binary: the wrapped framework's (never raise)
    _fmu_state_to_bytes = staticmethod(FmuStateMixin._fmu_state_to_bytes)
    _fmu_state_from_bytes = staticmethod(FmuStateMixin._fmu_state_from_bytes)

    # --- modelDescription ------------------------------------------------------------------------

    def to_xml(self, model_options: dict[str, str] = dict()):  # noqa: B006 (pythonfmu3's signature)
        root = super().to_xml({**self.OPTIONS, **model_options})
        return complete_model_description(root, self, self._inner)


def fmi3_text(message: str) -> str:
    """A message of the shared code with the FMI 3 names of the calls it names."""
    return _CALL.sub(lambda m: _CALLS.get(m.group(0), f"fmi3{m.group(1)}"), message)


def _array_description(members: list, meta: dict) -> str:
    """An array's description: its elements' own, with their units where they differ."""
    units = {meta[m.name].unit for m in members}
    parts = [f"[{k}] {m.description}" + (f" ({meta[m.name].unit})" if len(units) > 1 else "")
             for k, m in enumerate(members, start=1)]
    return "; ".join(parts)
