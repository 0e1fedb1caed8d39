"""A tiny direct fmpy driver for tests that call FMI functions one by one (outside the master)."""
from __future__ import annotations

import ctypes
from pathlib import Path

from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave, fmi2CallbackFunctions, fmi2CallbackLoggerTYPE
from fmpy.logging import addLoggerProxy


class DrivenFmu:
    """One instance of an FMU, with its log messages collected in ``messages``."""

    def __init__(self, fmu_file: Path, unzipdir: Path, instance_name: str = "instance"):
        self.md = read_model_description(str(fmu_file))
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        self.messages: list[tuple[int, str]] = []

        def log(env, inst, status, category, message):
            self.messages.append((status, message.decode()))

        self._callbacks = fmi2CallbackFunctions()
        self._callbacks.logger = fmi2CallbackLoggerTYPE(log)
        addLoggerProxy(ctypes.byref(self._callbacks))
        directory = extract(str(fmu_file), unzipdir=str(unzipdir))
        self.fmu = FMU2Slave(guid=self.md.guid, unzipDirectory=directory,
                             modelIdentifier=self.md.coSimulation.modelIdentifier, instanceName=instance_name)
        self.fmu.instantiate(callbacks=self._callbacks, loggingOn=True)

    def set(self, **values: float) -> None:
        for name, value in values.items():
            var = next(v for v in self.md.modelVariables if v.name == name)
            if var.type == "Integer":
                self.fmu.setInteger([self.vr[name]], [int(value)])
            else:
                self.fmu.setReal([self.vr[name]], [float(value)])

    def get(self, *names: str) -> list[float]:
        return self.fmu.getReal([self.vr[n] for n in names])

    def initialize(self, start_time: float = 0.0, **params: float) -> None:
        self.set(**params)
        self.fmu.setupExperiment(startTime=start_time)
        self.fmu.enterInitializationMode()
        self.fmu.exitInitializationMode()

    def logged(self) -> str:
        return "\n".join(m for _, m in self.messages)

    def free(self) -> None:
        self.fmu.freeInstance()
