"""One FMI 3.0 co-simulation instance in the master (``orchestration.run.master``), with the
interface of the master's FMI 2.0 instance: outputs and inputs by their FMI 2 scalar names, so a
scenario, its connections, the summaries and the recordings are the same for either version.

An FMI 3 array ``x`` of n elements is read and recorded as the scalars ``x1 .. xn``
(``fmi3_slave.arrays.element_names``); an input array is set whole, its connected elements from
their sources and the others at their start values. As in FMI 2, every output is read with one
fmi3GetFloat64 and each target's inputs are set with one fmi3SetFloat64, from preallocated buffers.
"""
from __future__ import annotations

import ctypes
from pathlib import Path
from types import SimpleNamespace

import numpy as np
from fmpy.fmi1 import FMICallException
from fmpy.fmi3 import FMU3Slave, fmi3Boolean, fmi3Float64, fmi3ValueReference

from fmi3_slave.arrays import element_names
from orchestration.run.fmi3_direct import element_count, element_starts
from orchestration.run.parameter_check import parameter_values, set_parameters
from orchestration.run.scenario import ScenarioError
from orchestration.run.unpacked import unpacked

_WARNING = 1  # fmi3Warning: anything worse fails the call


def _checked(status: int, function: str) -> None:
    if status > _WARNING:
        raise FMICallException(function=function, status=status)


class Instance3:
    """``fmi2_instance.Instance2`` for an FMI 3.0 FMU (``sink.append((status, message))`` receives its log; ``md``:
    its model description, parsed once by the master)."""

    def __init__(self, name: str, fmu_file: Path, md, sink):
        self.name, self.md = name, md
        if getattr(self.md, self.INTERFACE) is None:
            raise ScenarioError(f"{fmu_file} does not support {self.INTERFACE}")
        self.unzipdir = unpacked(fmu_file)
        floats = [v for v in self.md.modelVariables if v.type == "Float64" and v.causality in ("input", "output")]
        outputs = [v for v in floats if v.causality == "output"]
        self.output_names = [n for v in outputs for n in element_names(v.name, element_count(v))]
        self.out_vr = (fmi3ValueReference * len(outputs))(*(v.valueReference for v in outputs))
        self.n_out = len(self.output_names)
        self.out_buf = (fmi3Float64 * self.n_out)()
        self.out_view = np.ctypeslib.as_array(self.out_buf)
        # every input element: its scalar name -> (array variable, index); ``vars`` gives each a slot
        self._elements = {n: (v, i) for v in floats if v.causality == "input"
                          for i, n in enumerate(element_names(v.name, element_count(v)))}
        self.inputs = set(self._elements)
        self.vars = {n: SimpleNamespace(valueReference=slot) for slot, n in enumerate(self._elements)}
        self._by_name = {v.name: v for v in self.md.modelVariables}
        self.feedthrough = any(u.dependencies for u in self.md.outputs)
        self._plans: dict[int, tuple] = {}
        # FMI 3 hands each instance its own logger (fmpy keeps it): FMI 2's routing (fmi_direct) is not needed
        self.callbacks = SimpleNamespace(componentEnvironment=None)
        self.fmu = self._open(name, lambda env, status, category, message: sink.append(
            (int(status), (message or b"").decode(errors="replace"))))
        self.instantiated = True
        self.initialized = False
        # as ``Instance2``'s: the raw ctypes get and its arguments looked up once (``foreign_loop`` calls them)
        self.raw_get = self.fmu._functions["fmi3GetFloat64"]
        self.get_args = (self.fmu.component, self.out_vr, len(self.out_vr), self.out_buf, self.n_out)
        self._set = self.fmu._functions["fmi3SetFloat64"]

    INTERFACE = "coSimulation"  # the modelDescription element this instance uses

    def _open(self, name: str, log):
        fmu = FMU3Slave(guid=self.md.guid, unzipDirectory=self.unzipdir,
                        modelIdentifier=self.md.coSimulation.modelIdentifier, instanceName=name)
        fmu.instantiate(loggingOn=True, logMessage=log)
        self._step = fmu._functions["fmi3DoStep"]
        # where fmi3DoStep writes eventHandlingNeeded, terminateSimulation, earlyReturn and lastSuccessfulTime
        self._step_refs = tuple(ctypes.byref(x) for x in (fmi3Boolean(), fmi3Boolean(), fmi3Boolean(), fmi3Float64()))
        return fmu

    def initialize(self, stop_time: float) -> None:
        self.fmu.enterInitializationMode(startTime=0.0, stopTime=stop_time)
        self.fmu.exitInitializationMode()

    def read_outputs(self) -> None:
        _checked(self.raw_get(*self.get_args), "fmi3GetFloat64")

    def raw_set(self, component, slots, n: int, buf) -> None:
        """``fmi2SetReal``'s call of ``master._Inputs``: the input slots ``slots`` (``vars``) get ``buf``;
        each array they belong to is set whole."""
        plan = self._plans.get(ctypes.addressof(slots))
        if plan is None:
            plan = self._plans[ctypes.addressof(slots)] = self._plan([slots[k] for k in range(n)])
        vrs, values, view, where = plan
        view[where] = np.ctypeslib.as_array(buf)[:n]
        return self._set(component, vrs, len(vrs), values, len(view))  # the master checks the status

    def _plan(self, slots: list[int]) -> tuple:
        names = list(self._elements)
        arrays = list(dict.fromkeys(self._elements[names[s]][0].name for s in slots))
        variables = [self._by_name[a] for a in arrays]
        sizes = [element_count(v) for v in variables]
        start = [float(x or 0.0) for v, n in zip(variables, sizes) for x in element_starts(v, n)]
        values = (fmi3Float64 * sum(sizes))(*start)
        offsets = dict(zip(arrays, np.cumsum([0] + sizes[:-1]).tolist()))
        where = np.array([offsets[self._elements[names[s]][0].name] + self._elements[names[s]][1] for s in slots])
        vrs = (fmi3ValueReference * len(variables))(*(v.valueReference for v in variables))
        return vrs, values, np.ctypeslib.as_array(values), where

    def do_step(self, t: float, h: float) -> None:
        _checked(self.raw_step(self.fmu.component, t, h, True), "fmi3DoStep")

    def raw_step(self, component, t: float, h: float, no_set_state_prior: bool) -> int:
        """fmi3DoStep in the shape of ``Instance2.raw_step`` (fmi2DoStep's four arguments; its status returned):
        the flags it writes back go into the instance's own (``foreign_loop`` calls either alike)."""
        return self._step(component, t, h, no_set_state_prior, *self._step_refs)

    def parameter_values(self) -> dict[str, float]:
        return parameter_values(self.md, {"Float64": self.fmu.getFloat64, "Int32": self.fmu.getInt32})

    def set_parameters(self, values: dict[str, float]) -> None:
        set_parameters(self.md, self.name, values, {"Float64": (self.fmu.setFloat64, float),
                                                     "Int32": (self.fmu.setInt32, int)})
