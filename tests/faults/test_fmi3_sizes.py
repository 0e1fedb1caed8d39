"""FMI 3 gets and sets with the wrong number of values (fmpy's low-level FMI 3 API: nValues is the
length of the values given, or ``nValues=`` of a get): answered fmi3Error, not fmi3Fatal, with a logged
Error naming the variable, its size and the number of values given; nothing is read or set, and the
instance goes on. pythonfmu3 0.3.4's binary alone cannot do this (a get with too many values left a
Python exception set, fmpy raised SystemError; too few were silently truncated; a refused set was
Fatal): the FMU's binary is the size-checking shim in front of it (``orchestration/fmu_build/shim.py``,
docs/reliability.md)."""
from __future__ import annotations

import shutil
import sys
import tempfile
import zipfile
from pathlib import Path

import pytest
from fmpy import extract, read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.fmi3 import FMU3Slave

from orchestration.fmu_build import shim

MODEL = "ArmPlant"
ERROR = 3  # fmi3Error
# an input array, an output array, an input scalar, an output scalar of the arm, with their sizes
INPUT, OUTPUT, SCALAR_IN, SCALAR_OUT = ("tau", 2), ("phi", 2), ("d1", 1), ("ee_x", 1)


@pytest.fixture
def arm(shimmed_arm3):
    path = shimmed_arm3
    md = read_model_description(str(path))
    folder = Path(tempfile.mkdtemp(prefix="sotc_test_"))
    fmu = FMU3Slave(guid=md.guid, unzipDirectory=extract(str(path), unzipdir=str(folder)),
                    modelIdentifier=md.coSimulation.modelIdentifier, instanceName="sizes")
    messages: list[tuple[int, str]] = []
    fmu.instantiate(loggingOn=True, logMessage=lambda env, status, category, message: messages.append(
        (int(status), (message or b"").decode(errors="replace"))))
    fmu.enterInitializationMode(startTime=0.0)
    fmu.exitInitializationMode()
    vrs = {v.name: v.valueReference for v in md.modelVariables}
    yield fmu, vrs, messages
    fmu.terminate()
    fmu.freeInstance()
    shutil.rmtree(folder, ignore_errors=True)


def _refused(call, messages, name: str, size: int, given: int) -> None:
    """``call`` fails with fmi3Error and a logged Error naming ``name``, its size and ``given``."""
    messages.clear()
    with pytest.raises(FMICallException) as failed:
        call()
    assert failed.value.status == ERROR
    plural = lambda n: f"{n} value{'' if n == 1 else 's'}"  # noqa: E731
    assert any(status == ERROR and f"'{name}' ({plural(size)})" in text and f"given {plural(given)}" in text
               for status, text in messages), messages


def _goes_on(fmu, vrs, set_values) -> None:
    """The values set before are still there, and the instance steps."""
    assert list(fmu.getFloat64([vrs[INPUT[0]]], nValues=INPUT[1])) == set_values
    fmu.doStep(currentCommunicationPoint=0.0, communicationStepSize=0.01)
    assert len(fmu.getFloat64([vrs[OUTPUT[0]]], nValues=OUTPUT[1])) == OUTPUT[1]


@pytest.mark.parametrize("name,size,given", [(*INPUT, 1), (*INPUT, 3), (*SCALAR_IN, 0), (*SCALAR_IN, 2)])
def test_a_set_of_the_wrong_size_is_an_error_naming_the_variable_and_changes_nothing(arm, name, size, given):
    fmu, vrs, messages = arm
    fmu.setFloat64([vrs[INPUT[0]]], [0.5, -0.25])
    _refused(lambda: fmu.setFloat64([vrs[name]], [9.0] * given), messages, name, size, given)
    _goes_on(fmu, vrs, [0.5, -0.25])


@pytest.mark.parametrize("name,size,given", [(*INPUT, 1), (*INPUT, 3), (*OUTPUT, 1), (*OUTPUT, 3), (*SCALAR_OUT, 2)])
def test_a_get_of_the_wrong_size_is_an_error_naming_the_variable(arm, name, size, given):
    fmu, vrs, messages = arm
    fmu.setFloat64([vrs[INPUT[0]]], [0.5, -0.25])
    _refused(lambda: fmu.getFloat64([vrs[name]], nValues=given), messages, name, size, given)
    _goes_on(fmu, vrs, [0.5, -0.25])


def test_several_variables_are_counted_together(arm):
    fmu, vrs, messages = arm
    both = [vrs[OUTPUT[0]], vrs[SCALAR_OUT[0]]]
    _refused(lambda: fmu.getFloat64(both, nValues=2), messages, OUTPUT[0], OUTPUT[1], 2)
    assert len(fmu.getFloat64(both, nValues=3)) == 3


def test_an_int32_of_the_wrong_size_is_an_error(arm):
    fmu, vrs, messages = arm
    _refused(lambda: fmu.getInt32([vrs["substeps"]], nValues=2), messages, "substeps", 1, 2)
    assert len(fmu.getInt32([vrs["substeps"]], nValues=1)) == 1


def test_without_a_c_compiler_the_build_says_so_and_ships_pythonfmu3s_binary_alone(tmp_path, monkeypatch):
    from orchestration.fmu_build import compiled
    from orchestration.fmu_build.build import build_fmus

    if shim.platform_folder() is None:
        pytest.skip(f"the size-checking binary is built on Linux only, not {sys.platform}")
    monkeypatch.setenv("PATH", str(Path(sys.executable).parent))  # the interpreter, no C compiler
    if compiled.c_compiler() is not None:
        pytest.skip(f"{compiled.compiler_name()} is found beside the interpreter: cannot hide it")
    lines: list[str] = []
    with compiled.switched(False):
        fmu = build_fmus([MODEL], tmp_path, fmi=3, report=lines.append)[0]
    assert [line for line in lines if "no C compiler" in line and "sizes" in line], lines
    with zipfile.ZipFile(fmu) as z:
        names = z.namelist()
    assert f"binaries/{shim.platform_folder()}/{MODEL}.so" in names
    assert not [n for n in names if shim.INNER_SUFFIX in n or n.endswith(shim.SIZES_FILE)], names


@pytest.mark.parametrize("damage", ["no pythonfmu3 binary", "no size table", "a torn size table"])
def test_an_fmu_missing_a_part_of_the_shim_fails_instantiation_naming_it(shimmed_arm3, tmp_path, damage):
    path = shimmed_arm3
    md = read_model_description(str(path))
    folder = Path(extract(str(path), unzipdir=str(tmp_path / "fmu")))
    inner = folder / "binaries" / shim.platform_folder() / f"{MODEL}{shim.INNER_SUFFIX}.so"
    table = folder / "resources" / shim.SIZES_FILE
    if damage == "no pythonfmu3 binary":
        inner.unlink()
    elif damage == "no size table":
        table.unlink()
    else:
        table.write_text(table.read_text()[:-1])  # the last line loses its end
    fmu = FMU3Slave(guid=md.guid, unzipDirectory=str(folder), modelIdentifier=MODEL, instanceName="damaged")
    messages: list[str] = []
    with pytest.raises(Exception, match="instantiate"):
        fmu.instantiate(loggingOn=True, logMessage=lambda env, status, category, message: messages.append(
            (message or b"").decode(errors="replace")))
    named = inner.name if damage == "no pythonfmu3 binary" else shim.SIZES_FILE
    assert any(named in text for text in messages), messages
