"""Direct FMI 3.0 access to one built FMU through fmpy, with the interface of
``fmi_direct.FmuInstance``: variables by their FMI 2 scalar names (an array ``x`` is ``x1 .. xn``,
``fmi3_slave.arrays``), and ``md``/``fmu`` views in FMI 2 terms (``getReal``/``setReal`` on scalar
slots, ``Real``/``Integer`` types), so the tools that call FMI functions one by one (validation
experiments, cross-check reference runs) drive either version with the same code.

Like ``fmi_direct``, this module must not import ``fmu_plant``/``fmu_controller``.
"""
from __future__ import annotations

import shutil
import tempfile
from pathlib import Path
from types import SimpleNamespace

import numpy as np
from fmpy import extract, read_model_description
from fmpy.fmi3 import FMU3Slave

from fmi3_slave.arrays import element_names
from orchestration.run.fmi_direct import ByName, removed_on_error

_TYPES = {"Float64": "Real", "Int32": "Integer"}


def element_count(variable) -> int:
    """How many elements an FMI 3 variable of fmpy's modelDescription has (a scalar: 1)."""
    return int(np.prod(variable.shape)) if variable.shape else 1


def element_starts(variable, size: int) -> list:
    """The start value of each element, as the XML gives it (None where it gives none)."""
    if variable.start is None:
        return [None] * size
    text = variable.start if isinstance(variable.start, str) else " ".join(map(str, np.ravel(variable.start)))
    values = text.split()
    return values if len(values) == size else [None] * size


def flat_view(md) -> tuple[SimpleNamespace, list[tuple]]:
    """An FMI 2-like view of an FMI 3 modelDescription (scalar variables with slots for value
    references), and per slot its (FMI 3 variable, element index)."""
    variables, slots, of = [], [], {}
    for v in md.modelVariables:
        if v.type not in _TYPES or v.causality not in ("parameter", "input", "output"):
            continue
        size = element_count(v)
        of[v.name] = []
        for index, (name, start) in enumerate(zip(element_names(v.name, size), element_starts(v, size))):
            flat = SimpleNamespace(name=name, type=_TYPES[v.type], causality=v.causality, valueReference=len(slots),
                                   start=start, unit=v.unit, min=v.min, max=v.max, description=v.description)
            variables.append(flat)
            slots.append((v, index))
            of[v.name].append(flat)
    outputs = [SimpleNamespace(variable=flat, dependencies=[d for dep in (u.dependencies or []) for d in of.get(dep.name, [])])
               for u in md.outputs for flat in of.get(u.variable.name, [])]
    view = SimpleNamespace(modelVariables=variables, outputs=outputs, description=md.description,
                           defaultExperiment=md.defaultExperiment, coSimulation=md.coSimulation,
                           modelName=md.modelName, fmiVersion=md.fmiVersion)
    return view, slots


class _ScalarCalls:
    """FMI 2's per-scalar calls on an FMU3Slave (``slots``: slot -> (FMI 3 variable, index))."""

    def __init__(self, fmu: FMU3Slave, slots: list[tuple]):
        self.fmu, self.slots = fmu, slots

    def _arrays(self, slots) -> list:
        return list({id(self.slots[s][0]): self.slots[s][0] for s in slots}.values())

    def _read(self, slots, get) -> list:
        arrays = self._arrays(slots)
        values = get([a.valueReference for a in arrays], nValues=sum(element_count(a) for a in arrays))
        offset = dict(zip((id(a) for a in arrays), np.cumsum([0] + [element_count(a) for a in arrays[:-1]]).tolist()))
        return [values[offset[id(self.slots[s][0])] + self.slots[s][1]] for s in slots]

    def _write(self, slots, values, get, set_) -> None:
        for array in self._arrays(slots):
            current = list(get([array.valueReference], nValues=element_count(array)))
            for s, value in zip(slots, values):
                if self.slots[s][0] is array:
                    current[self.slots[s][1]] = value
            set_([array.valueReference], current)

    def getReal(self, slots):  # noqa: N802 (fmpy's FMI 2 names)
        return self._read(slots, self.fmu.getFloat64)

    def setReal(self, slots, values):  # noqa: N802
        self._write(slots, values, self.fmu.getFloat64, self.fmu.setFloat64)

    def getInteger(self, slots):  # noqa: N802
        return self._read(slots, self.fmu.getInt32)

    def setInteger(self, slots, values):  # noqa: N802
        self._write(slots, values, self.fmu.getInt32, self.fmu.setInt32)

    def doStep(self, currentCommunicationPoint: float, communicationStepSize: float):  # noqa: N802, N803
        return self.fmu.doStep(currentCommunicationPoint, communicationStepSize)

    def terminate(self):
        return self.fmu.terminate()


class FmuInstance3(ByName):
    """One FMI 3.0 co-simulation instance, addressed by FMI 2 scalar names (``fmi_direct.FmuInstance``)."""

    def __init__(self, fmu_file: Path, instance_name: str = "instance", workdir: Path | None = None):
        self.path = Path(fmu_file)
        self.fmi3_md = read_model_description(str(fmu_file), validate=False)
        self.md, slots = flat_view(self.fmi3_md)
        self.vars = {v.name: v for v in self.md.modelVariables}
        self.messages: list[tuple[int, str]] = []
        self._own_dir = workdir is None
        self.unzipdir = Path(tempfile.mkdtemp(prefix="sotc_fmu_")) if workdir is None else Path(workdir)
        with removed_on_error(self.unzipdir, self._own_dir):
            extract(str(fmu_file), unzipdir=str(self.unzipdir))
            self._fmu3 = FMU3Slave(guid=self.fmi3_md.guid, unzipDirectory=str(self.unzipdir),
                                   modelIdentifier=self.fmi3_md.coSimulation.modelIdentifier, instanceName=instance_name)
            self._fmu3.instantiate(loggingOn=True, logMessage=lambda env, status, category, message: self.messages.append(
                (int(status), (message or b"").decode(errors="replace"))))
        self.fmu = _ScalarCalls(self._fmu3, slots)
        self._freed = False

    def initialize(self, start_time: float = 0.0, inputs: dict[str, float] | None = None, **parameters: float) -> None:
        """Parameters, enter/exit initialization (inputs, if given, set in between)."""
        self.set(**parameters)
        self._fmu3.enterInitializationMode(startTime=start_time)
        if inputs:
            self.set(**inputs)
        self._fmu3.exitInitializationMode()

    def free(self) -> None:
        if self._freed:
            return
        self._freed = True
        self._fmu3.freeInstance()
        if self._own_dir:
            shutil.rmtree(self.unzipdir, ignore_errors=True)


def open_instance(fmu_file: Path, instance_name: str = "instance", workdir: Path | None = None):
    """``fmi_direct.FmuInstance`` for an FMI 2.0 FMU, ``FmuInstance3`` for an FMI 3.0 one."""
    from orchestration.run.fmi_direct import FmuInstance

    version = read_model_description(str(fmu_file), validate=False).fmiVersion
    cls = FmuInstance3 if version.startswith("3") else FmuInstance
    return cls(fmu_file, instance_name, workdir)
