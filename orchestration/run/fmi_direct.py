"""Direct FMI 2.0 access to one built FMU through fmpy, for the tools that call FMI functions one by
one (validation experiments, cross-check reference runs, the Jacobi loop of the interop check).

fmpy's ``fmpy.logging.addLoggerProxy`` keeps ONE process-wide pointer to a Python logger (the last
one registered). A logger per instance would therefore send every instance's messages to the newest
logger, and into freed memory once that logger is garbage-collected. Every instance made here shares
one logger that lives as long as the process and routes each message by the ``componentEnvironment``
the instance was created with; ``orchestration.run.master`` uses the same routing.

Like ``orchestration.compliance.validate``, this module must not import ``fmu_plant``/``fmu_controller``.
"""
from __future__ import annotations

import ctypes
import itertools
import shutil
import tempfile
from contextlib import contextmanager
from pathlib import Path

from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave, defaultCallbacks, fmi2CallbackFunctions, fmi2CallbackLoggerTYPE
from fmpy.logging import addLoggerProxy

_SINKS: dict[int, list[tuple[int, str]]] = {}
_KEYS = itertools.count(1)


def _route(env, instance, status, category, message):
    sink = _SINKS.get(env or 0)
    if sink is not None:
        sink.append((int(status), message.decode(errors="replace") if message else ""))


_LOGGER = fmi2CallbackLoggerTYPE(_route)


def make_callbacks(messages: list[tuple[int, str]]) -> fmi2CallbackFunctions:
    """Callbacks whose log messages (status, text) are appended to ``messages``."""
    key = next(_KEYS)
    _SINKS[key] = messages
    callbacks = fmi2CallbackFunctions()
    callbacks.logger = _LOGGER
    # fmpy's calloc and free: FMI 2.0 requires them, and an FMU written to it (a C one) refuses to instantiate without
    callbacks.allocateMemory, callbacks.freeMemory = defaultCallbacks.allocateMemory, defaultCallbacks.freeMemory
    callbacks.componentEnvironment = key
    addLoggerProxy(ctypes.byref(callbacks))
    return callbacks


def forget_callbacks(callbacks: fmi2CallbackFunctions) -> None:
    """Stop routing messages for an instance that was freed."""
    _SINKS.pop(callbacks.componentEnvironment or 0, None)


@contextmanager
def removed_on_error(unzipdir: Path, own: bool):
    """A constructor's error path: an FMU that cannot be extracted or instantiated leaves no
    ``sotc_fmu_*`` folder behind (the folder is removed only if the instance made it)."""
    try:
        yield
    except BaseException:
        if own:
            shutil.rmtree(unzipdir, ignore_errors=True)
        raise


class ByName:
    """Variables addressed by their FMI 2 names (``md``, ``vars`` and an ``fmu`` with FMI 2's scalar calls),
    and the messages the instance logged."""

    def names(self, causality: str, types: tuple[str, ...] = ("Real",)) -> list[str]:
        return [v.name for v in self.md.modelVariables if v.causality == causality and v.type in types]

    def set(self, **values: float) -> None:
        for name, value in values.items():
            var = self.vars[name]
            if var.type == "Integer":
                self.fmu.setInteger([var.valueReference], [int(value)])
            else:
                self.fmu.setReal([var.valueReference], [float(value)])

    def get(self, *names: str) -> list[float]:
        return self.fmu.getReal([self.vars[n].valueReference for n in names])

    def logged(self) -> str:
        return "\n".join(m for _, m in self.messages)


class FmuInstance(ByName):
    """One co-simulation instance of an FMU file, addressed by variable names."""

    def __init__(self, fmu_file: Path, instance_name: str = "instance", workdir: Path | None = None):
        self.path = Path(fmu_file)
        self.md = read_model_description(str(fmu_file), validate=False)
        self.vars = {v.name: v for v in self.md.modelVariables}
        self.messages: list[tuple[int, str]] = []
        self._own_dir = workdir is None
        self.unzipdir = Path(tempfile.mkdtemp(prefix="sotc_fmu_")) if workdir is None else Path(workdir)
        self._callbacks = make_callbacks(self.messages)
        try:
            with removed_on_error(self.unzipdir, self._own_dir):
                extract(str(fmu_file), unzipdir=str(self.unzipdir))
                self.fmu = FMU2Slave(guid=self.md.guid, unzipDirectory=str(self.unzipdir),
                                     modelIdentifier=self.md.coSimulation.modelIdentifier, instanceName=instance_name)
                self.fmu.instantiate(callbacks=self._callbacks, loggingOn=True)
        except BaseException:
            forget_callbacks(self._callbacks)
            raise
        self._freed = False

    def initialize(self, start_time: float = 0.0, inputs: dict[str, float] | None = None, **parameters: float) -> None:
        """setupExperiment, parameters, enter/exit initialization (inputs, if given, set in between)."""
        self.fmu.setupExperiment(startTime=start_time)
        self.set(**parameters)
        self.fmu.enterInitializationMode()
        if inputs:
            self.set(**inputs)
        self.fmu.exitInitializationMode()

    def free(self) -> None:
        if self._freed:
            return
        self._freed = True
        self.fmu.freeInstance()
        forget_callbacks(self._callbacks)
        if self._own_dir:
            shutil.rmtree(self.unzipdir, ignore_errors=True)
