"""One FMI 2.0 co-simulation instance in the master (``orchestration.run.master``), as
``fmi3_instance.Instance3`` is one of FMI 3.0: the same interface (outputs read with one fmi2GetReal into a
preallocated buffer, inputs set by the master's ``_Inputs`` through ``raw_set``, ``do_step``, parameters), built
from the model description the master parsed once."""
from __future__ import annotations

from pathlib import Path

import numpy as np
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import FMU2Slave, fmi2Real, fmi2True, fmi2ValueReference, fmi2Warning

from orchestration.run.fmi_direct import make_callbacks
from orchestration.run.parameter_check import parameter_values, set_parameters
from orchestration.run.scenario import ScenarioError
from orchestration.run.unpacked import unpacked


class Instance2:
    """One FMI 2.0 co-simulation instance with its value references and preallocated ctypes buffers
    (``sink.append((status, message))`` receives its log; ``md``: its model description, parsed once)."""

    def __init__(self, name: str, fmu_file: Path, md, sink):
        self.name, self.md = name, md
        if self.md.coSimulation is None:
            raise ScenarioError(f"{fmu_file} does not support co-simulation")
        self.unzipdir = unpacked(fmu_file)
        self.vars = {v.name: v for v in self.md.modelVariables}
        self.output_names = [v.name for v in self.md.modelVariables if v.causality == "output" and v.type == "Real"]
        self.inputs = {v.name for v in self.md.modelVariables if v.causality == "input"}
        self.feedthrough = any(u.dependencies for u in self.md.outputs)
        self.out_vr = (fmi2ValueReference * len(self.output_names))(*(self.vars[n].valueReference for n in self.output_names))
        self.out_buf = (fmi2Real * len(self.output_names))()
        self.out_view = np.ctypeslib.as_array(self.out_buf)
        self.fmu = FMU2Slave(
            guid=self.md.guid, unzipDirectory=self.unzipdir,
            modelIdentifier=self.md.coSimulation.modelIdentifier, instanceName=name,
        )
        # fmpy keeps one process-wide logger: fmi_direct routes each instance's messages to its sink
        self.callbacks = make_callbacks(sink)
        self.fmu.instantiate(callbacks=self.callbacks, loggingOn=True)
        self.instantiated = True
        self.initialized = False

        # fmpy's raw ctypes functions: its per-call wrapper costs more than the call; each status is
        # checked as it checks it (anything worse than a warning raises)
        self.raw_get = self.fmu._functions["fmi2GetReal"]
        self.raw_set = self.fmu._functions["fmi2SetReal"]
        self.raw_step = self.fmu._functions["fmi2DoStep"]
        self.n_out = len(self.output_names)
        self.get_args = (self.fmu.component, self.out_vr, self.n_out, self.out_buf)  # looked up once, not per call

    def initialize(self, stop_time: float) -> None:
        self.fmu.setupExperiment(startTime=0.0, stopTime=stop_time)
        self.fmu.enterInitializationMode()
        self.fmu.exitInitializationMode()

    def read_outputs(self) -> None:
        status = self.raw_get(*self.get_args)
        if status > fmi2Warning:
            raise FMICallException(function="fmi2GetReal", status=status)

    def do_step(self, t: float, h: float) -> None:
        status = self.raw_step(self.fmu.component, t, h, fmi2True)
        if status > fmi2Warning:
            raise FMICallException(function="fmi2DoStep", status=status)

    def parameter_values(self) -> dict[str, float]:
        """Every Real and Integer parameter as the instance holds it now."""
        return parameter_values(self.md, {"Real": self.fmu.getReal, "Integer": self.fmu.getInteger})

    def set_parameters(self, values: dict[str, float]) -> None:
        set_parameters(self.md, self.name, values, {"Real": (self.fmu.setReal, float),
                                                     "Integer": (self.fmu.setInteger, int)})
