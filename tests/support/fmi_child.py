"""Child process of the tests of hostile FMI calls and FMUs that cannot be imported: instantiates one FMU
(FMI 2.0 or 3.0; a .fmu file or a folder it was extracted into) and, for FMI 3, makes each named call of
``CALLS`` on the initialized instance. It prints one JSON line per step as it goes (an abort or a hang of
the host shows as the lines missing): ``{"step": "instantiate", "ok": ...}``, then per call its FMI status
(0: OK) and the messages logged during it, then ``{"step": "goes on", ...}``: the instance still steps
and holds the values set before the calls.

usage: python -m support.fmi_child FMU [CALL ...]  (tests/ on PYTHONPATH: support.child_env)
"""
from __future__ import annotations

import json
import sys
import tempfile
from ctypes import byref, c_size_t
from pathlib import Path

from fmpy import extract, read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.fmi3 import fmi3DependencyKind, fmi3Float64, fmi3IntervalQualifier, fmi3UInt64, fmi3ValueReference

ARRAY = "tau"  # the arm's input array of 2 Float64: every call is made on it
# the types of get and set pythonfmu3 0.3.4 does not implement (it aborts the host), with the right nValues
UNIMPLEMENTED_TYPES = ("Float32", "Int8", "UInt8", "Int16", "UInt16", "UInt32", "Binary")
_VALUES = {"Binary": [b"\x01", b"\x02"]}


def _typed(kind: str, verb: str):
    if verb == "get":
        return lambda f, vr: getattr(f, f"get{kind}")([vr], nValues=2)
    return lambda f, vr: getattr(f, f"set{kind}")([vr], _VALUES.get(kind, [1, 1]))


def _one(ctype):
    return (ctype * 1)()


CALLS = {f"{verb}{kind}": _typed(kind, verb) for kind in UNIMPLEMENTED_TYPES for verb in ("get", "set")} | {
    "getClock": lambda f, vr: f.getClock([vr]),
    "setClock": lambda f, vr: f.setClock([vr], [True]),
    "GetNumberOfVariableDependencies": lambda f, vr: f.fmi3GetNumberOfVariableDependencies(
        f.component, vr, byref(c_size_t())),
    "GetVariableDependencies": lambda f, vr: f.fmi3GetVariableDependencies(
        f.component, vr, _one(c_size_t), _one(fmi3ValueReference), _one(c_size_t), _one(fmi3DependencyKind), 1),
    "GetAdjointDerivative": lambda f, vr: f.getAdjointDerivative([vr], [vr], [1.0], nSensitivity=2),
    "EvaluateDiscreteStates": lambda f, vr: f.fmi3EvaluateDiscreteStates(f.component),
    "ActivateModelPartition": lambda f, vr: f.fmi3ActivateModelPartition(f.component, vr, 0.0),
    "GetIntervalDecimal": lambda f, vr: f.fmi3GetIntervalDecimal(
        f.component, (fmi3ValueReference * 1)(vr), 1, _one(fmi3Float64), _one(fmi3IntervalQualifier)),
    "GetIntervalFraction": lambda f, vr: f.fmi3GetIntervalFraction(
        f.component, (fmi3ValueReference * 1)(vr), 1, _one(fmi3UInt64), _one(fmi3UInt64), _one(fmi3IntervalQualifier)),
    "GetShiftDecimal": lambda f, vr: f.fmi3GetShiftDecimal(f.component, (fmi3ValueReference * 1)(vr), 1,
                                                           _one(fmi3Float64)),
    "GetShiftFraction": lambda f, vr: f.fmi3GetShiftFraction(f.component, (fmi3ValueReference * 1)(vr), 1,
                                                             _one(fmi3UInt64), _one(fmi3UInt64)),
    "SetIntervalDecimal": lambda f, vr: f.fmi3SetIntervalDecimal(f.component, (fmi3ValueReference * 1)(vr), 1,
                                                                 _one(fmi3Float64)),
    "SetIntervalFraction": lambda f, vr: f.fmi3SetIntervalFraction(f.component, (fmi3ValueReference * 1)(vr), 1,
                                                                   _one(fmi3UInt64), _one(fmi3UInt64)),
    "SetShiftDecimal": lambda f, vr: f.fmi3SetShiftDecimal(f.component, (fmi3ValueReference * 1)(vr), 1,
                                                           _one(fmi3Float64)),
    "SetShiftFraction": lambda f, vr: f.fmi3SetShiftFraction(f.component, (fmi3ValueReference * 1)(vr), 1,
                                                             _one(fmi3UInt64), _one(fmi3UInt64)),
}


def say(step: str, **fields) -> None:
    print(json.dumps({"step": step, **fields}), flush=True)


def _instantiate(folder: str, md, messages: list[tuple[int, str]]):
    """The instance (None: refused), FMI 2 through fmi_direct's logger, FMI 3 through fmpy's."""
    if md.fmiVersion.startswith("2"):
        from fmpy.fmi2 import FMU2Slave

        from orchestration.run.fmi_direct import make_callbacks

        fmu = FMU2Slave(guid=md.guid, unzipDirectory=folder, modelIdentifier=md.coSimulation.modelIdentifier)
        instantiate = lambda: fmu.instantiate(callbacks=make_callbacks(messages), loggingOn=True)  # noqa: E731
    else:
        from fmpy.fmi3 import FMU3Slave

        fmu = FMU3Slave(guid=md.guid, unzipDirectory=folder, modelIdentifier=md.coSimulation.modelIdentifier)
        def log(env, status, category, text) -> None:
            messages.append((int(status), (text or b"").decode(errors="replace")))

        instantiate = lambda: fmu.instantiate(loggingOn=True, logMessage=log)  # noqa: E731
    try:
        instantiate()
    except Exception:  # fmpy: "Failed to instantiate"
        return None
    return fmu


def main(argv: list[str]) -> int:
    path, calls = Path(argv[0]), argv[1:]
    folder = str(path) if path.is_dir() else extract(str(path), unzipdir=tempfile.mkdtemp(prefix="sotc_test_"))
    md = read_model_description(folder)
    messages: list[tuple[int, str]] = []
    fmu = _instantiate(folder, md, messages)
    say("instantiate", ok=fmu is not None, messages=messages)
    if fmu is None or not calls:
        return 0
    vr = next(v.valueReference for v in md.modelVariables if v.name == ARRAY)
    fmu.enterInitializationMode(startTime=0.0)
    fmu.exitInitializationMode()
    fmu.setFloat64([vr], [0.5, -0.25])
    for call in calls:
        messages.clear()
        try:
            CALLS[call](fmu, vr)
            status = 0
        except FMICallException as exc:
            status = exc.status
        say(call, status=status, messages=messages)
    held = list(fmu.getFloat64([vr], nValues=2))
    fmu.doStep(currentCommunicationPoint=0.0, communicationStepSize=0.01)
    say("goes on", held=held)
    fmu.terminate()
    fmu.freeInstance()
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
