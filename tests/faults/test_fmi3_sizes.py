"""FMI 3 arrays set with the wrong number of values (fmpy's low-level FMI 3 API, whose nValues is the
length of the values given): refused before anything is set, with a logged Error naming each variable
and its size; the instance keeps its values and goes on (was: "zip() argument 2 is shorter ..."; too
many values were set in part). pythonfmu3 0.3.4's binary turns the refusal into fmi3Fatal (it has no
path from Python to fmi3Error) and does not hand nValues of a get to Python: docs/reliability.md."""
from __future__ import annotations

import shutil
import tempfile
from pathlib import Path

import pytest
from fmpy import extract, read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.fmi3 import FMU3Slave

MODEL = "ArmPlant"
ARRAY, SIZE = "tau", 2  # an input array of the arm


@pytest.fixture
def arm(fmi3_paths):
    path = fmi3_paths[MODEL]
    md = read_model_description(str(path))
    folder = Path(tempfile.mkdtemp(prefix="sotc_test_"))
    fmu = FMU3Slave(guid=md.guid, unzipDirectory=extract(str(path), unzipdir=str(folder)),
                    modelIdentifier=md.coSimulation.modelIdentifier, instanceName="sizes")
    messages: list[tuple[int, str]] = []
    fmu.instantiate(loggingOn=True, logMessage=lambda env, status, category, message: messages.append(
        (int(status), (message or b"").decode(errors="replace"))))
    fmu.enterInitializationMode(startTime=0.0)
    fmu.exitInitializationMode()
    vr = next(v.valueReference for v in md.modelVariables if v.name == ARRAY)
    yield fmu, vr, messages
    fmu.terminate()
    fmu.freeInstance()
    shutil.rmtree(folder, ignore_errors=True)


@pytest.mark.parametrize("given", [1, 3])
def test_a_set_of_the_wrong_size_is_refused_naming_the_array_and_changes_nothing(arm, given):
    fmu, vr, messages = arm
    fmu.setFloat64([vr], [0.5, -0.25])
    messages.clear()
    with pytest.raises(FMICallException):
        fmu.setFloat64([vr], [9.0] * given)
    assert any(status >= 3 and f"'{ARRAY}' ({SIZE})" in text and f"{given} values" in text
               for status, text in messages), messages
    assert list(fmu.getFloat64([vr], nValues=SIZE)) == [0.5, -0.25]  # unchanged
    fmu.doStep(currentCommunicationPoint=0.0, communicationStepSize=0.01)  # and it goes on
