"""examples/pd_controller: a controller FMU in plain C, outside the project's FMU framework, built by the
script a user runs (from outside the repository) and checked through fmpy: a valid modelDescription, the
saturated PD law to 1e-12 inside and on the bound, its parameters, refusals with fmi2Error rather than a
crash, two instances that share nothing, and a build that leaves no half-written FMU.

fmpy's co-simulation samples the outputs after each fmi2DoStep, with the inputs it applied at the start of
that step: the recorded inputs of row k + 1 are the signal's row k, and each row's outputs are those of
its own inputs (direct feedthrough)."""
from __future__ import annotations

import ast
import math
import os
import shutil
import signal
import subprocess
import sys
import zipfile
from pathlib import Path

import fmpy
import numpy as np
import pytest
from fmpy import read_model_description, simulate_fmu
from fmpy.fmi2 import FMU2Slave
from fmpy.validation import validate_fmu

from support.example_controller import BUILD, EXAMPLE, FMU_NAME, run_build, skip_without_compiler

INPUTS = ("q1", "q2", "dq1", "dq2", "q1_ref", "q2_ref")
# rows of (q1, q2, dq1, dq2, q1_ref, q2_ref), one every 0.01 s: with the defaults (Kp 60, Kd 15, umax 4)
# rows 0, 2 and 4 stay inside the bound and rows 1 (just: u = (3, 3)), 3 and 5 are cut to it
SIGNAL = [(0.0, 0.0, 0.0, 0.0, 0.01, -0.02),
          (0.05, -0.03, 0.1, 0.2, 0.125, 0.07),
          (0.3, 0.1, -0.1, 0.05, 0.31, 0.08),
          (-0.4, 0.2, 0.0, -1.0, 0.5, -0.7),
          (1.0, -1.0, 0.01, 0.0, 1.0, -1.0),
          (0.0, 0.0, 3.0, -2.0, 0.0, 0.0)]
STEP = 0.01


@pytest.fixture(scope="module")
def built(tmp_path_factory) -> tuple[Path, subprocess.CompletedProcess]:
    """The folder the script ran in (no --out: the FMU goes there) and how it ended."""
    skip_without_compiler()
    folder = tmp_path_factory.mktemp("pd_build")
    return folder, run_build(folder)


@pytest.fixture(scope="module")
def fmu(built) -> Path:
    assert built[1].returncode == 0, built[1].stderr
    return Path(built[1].stdout.strip())


def pd_law(row: dict, kp: float, kd: float, umax: float) -> np.ndarray:
    """u = Kp (q_ref - q) + Kd (dq_ref - dq), shortened to umax along its own direction (dq_ref = 0 here)."""
    u = np.array([kp * (row["q1_ref"] - row["q1"]) - kd * row["dq1"],
                  kp * (row["q2_ref"] - row["q2"]) - kd * row["dq2"]])
    norm = math.hypot(*u)
    return u * (umax / norm) if norm > umax else u


def _signal() -> np.ndarray:
    """SIGNAL at t = k STEP, as fmpy computes its communication points."""
    return np.array([(k * STEP, *row) for k, row in enumerate(SIGNAL)],
                    dtype=[("time", float), *((name, float) for name in INPUTS)])


def _simulate(fmu: Path, **start_values: float) -> np.ndarray:
    """One sample per step up to one step past the signal's last row, so that every row is applied."""
    return simulate_fmu(str(fmu), fmi_type="CoSimulation", input=_signal(), stop_time=len(SIGNAL) * STEP,
                        output_interval=STEP, output=[*INPUTS, "u1", "u2"], start_values=start_values)


def _starts(fmu: Path) -> dict[str, float]:
    return {v.name: float(v.start) for v in read_model_description(str(fmu)).modelVariables
            if v.causality == "parameter"}


@pytest.mark.slow
def test_the_script_builds_the_fmu_from_outside_the_repository(built, fmu):
    folder, done = built
    assert done.stderr == ""  # the compiler warned about nothing
    assert fmu == folder / FMU_NAME and sorted(p.name for p in folder.iterdir()) == [FMU_NAME]  # no temporary file
    with zipfile.ZipFile(fmu) as zf:
        assert sorted(zf.namelist()) == ["binaries/%s/PdController%s" % (fmpy.platform, fmpy.sharedLibraryExtension),
                                         "modelDescription.xml", "sources/pd_controller.c"]


@pytest.mark.slow
def test_the_model_description_is_valid_and_declares_the_ports(fmu):
    assert validate_fmu(str(fmu)) == []
    md = read_model_description(str(fmu))
    assert md.coSimulation.modelIdentifier == "PdController" and md.modelExchange is None
    assert md.fmiVersion == "2.0" and md.generationTool and md.guid
    declared = {v.name: (v.causality, v.variability, v.unit) for v in md.modelVariables}
    assert declared == {
        **{q: ("input", "continuous", "rad") for q in ("q1", "q2", "q1_ref", "q2_ref")},
        **{dq: ("input", "continuous", "rad/s") for dq in ("dq1", "dq2", "dq1_ref", "dq2_ref")},
        "Kp": ("parameter", "tunable", "N.m/rad"), "Kd": ("parameter", "tunable", "N.m.s/rad"),
        "umax": ("parameter", "tunable", "N.m"), "u1": ("output", "continuous", "N.m"),
        "u2": ("output", "continuous", "N.m")}
    assert {u.name for u in md.unitDefinitions} >= {"rad", "rad/s", "N.m"}
    assert _starts(fmu) == {"Kp": 60.0, "Kd": 15.0, "umax": 4.0}
    inputs = sorted(v.name for v in md.modelVariables if v.causality == "input")
    assert {o.variable.name: sorted(d.name for d in o.dependencies) for o in md.outputs} == {"u1": inputs, "u2": inputs}


@pytest.mark.slow
def test_the_outputs_are_the_saturated_pd_law_inside_and_on_the_bound(fmu):
    result = _simulate(fmu)
    applied = np.column_stack([result[n] for n in INPUTS])
    np.testing.assert_allclose(applied[1:], np.array(SIGNAL), rtol=0, atol=1e-15)
    starts = _starts(fmu)
    inside = cut = 0
    for row in result:
        u = np.array([row["u1"], row["u2"]])
        raw = pd_law(row, starts["Kp"], starts["Kd"], math.inf)
        assert np.abs(u - pd_law(row, starts["Kp"], starts["Kd"], starts["umax"])).max() <= 1e-12, row
        if math.hypot(*raw) > starts["umax"]:
            cut += 1
            assert abs(math.hypot(*u) - starts["umax"]) <= 1e-12
            assert abs(u[0] * raw[1] - u[1] * raw[0]) <= 1e-12 * math.hypot(*raw) and u @ raw > 0  # same direction
        else:
            inside += 1
            assert np.abs(u - raw).max() <= 1e-12
    assert (inside, cut) == (4, 3)  # row 0 of the signal is sampled twice (at t = 0 and 0.01)


@pytest.mark.slow
@pytest.mark.parametrize("starts", [{"Kp": 10.0, "Kd": 2.0, "umax": 100.0}, {"Kp": 200.0, "Kd": 0.0, "umax": 0.5}])
def test_start_values_of_the_parameters_change_the_outputs_as_the_law_says(fmu, starts):
    result = _simulate(fmu, **starts)
    expected = np.array([pd_law(row, **{k.lower(): v for k, v in starts.items()}) for row in result])
    assert np.abs(np.column_stack([result["u1"], result["u2"]]) - expected).max() <= 1e-12
    assert np.abs(expected - np.array([pd_law(row, 60.0, 15.0, 4.0) for row in result])).max() > 0.1


# a host process that could crash: each refused call must come back as fmi2Error (3), the instance unchanged
REFUSALS_CHILD = r"""
import sys
from fmpy import read_model_description, simulate_fmu
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import FMU2Slave

fmu, unzipdir = sys.argv[1:]
for start in ({"umax": 0.0}, {"umax": float("inf")}, {"Kp": -1.0}, {"Kp": float("nan")}, {"Kd": float("inf")}):
    try:
        simulate_fmu(fmu, start_values=start, stop_time=0.02, output_interval=0.01)
        print("simulate", start, "accepted")
    except FMICallException as error:
        print("simulate", start, "refused", error.status, error)
md = read_model_description(fmu)
vr = {v.name: v.valueReference for v in md.modelVariables}
slave = FMU2Slave(guid=md.guid, unzipDirectory=unzipdir, modelIdentifier="PdController", instanceName="child")
slave.instantiate()
calls = {
    "set q1 and umax=-4": lambda: slave.setReal([vr["q1"], vr["umax"]], [0.5, -4.0]),
    "set u1": lambda: slave.setReal([vr["u1"]], [1.0]),
    "get vr 99": lambda: slave.getReal([99]),
    "set vr 13": lambda: slave.setReal([13], [1.0]),
    "getInteger vr 0": lambda: slave.getInteger([0]),
    "setBoolean vr 0": lambda: slave.setBoolean([0], [True]),
    "doStep before initialization": lambda: slave.doStep(0.0, 0.01),
    "getFMUstate": lambda: slave.getFMUstate(),
}
for name, call in calls.items():
    try:
        call()
        print(name, "accepted")
    except FMICallException as error:
        print(name, "refused", error.status)
print("kept", slave.getReal([vr["q1"], vr["Kp"], vr["Kd"], vr["umax"]]))
slave.setupExperiment(startTime=0.0)
slave.enterInitializationMode()
slave.exitInitializationMode()
slave.setReal([vr["q1_ref"]], [0.01])
slave.doStep(0.0, 0.01)
print("steps", slave.getReal([vr["u1"], vr["u2"]]))
slave.terminate()
slave.freeInstance()
"""


@pytest.mark.slow
def test_bad_values_and_calls_are_refused_with_fmi2error_not_a_crash(fmu, tmp_path):
    fmpy.extract(str(fmu), str(tmp_path / "unzipped"))
    done = subprocess.run([sys.executable, "-c", REFUSALS_CHILD, str(fmu), str(tmp_path / "unzipped")],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    for start, logged in ((("umax", "0.0"), "umax = 0 refused: must be finite and > 0"), (("umax", "inf"), "umax = inf"),
                          (("Kp", "-1.0"), "Kp = -1 refused: must be finite and >= 0"),
                          (("Kp", "nan"), "Kp = nan refused"), (("Kd", "inf"), "Kd = inf refused")):
        assert f"simulate {{'{start[0]}': {start[1]}}} refused 3 fmi2SetReal failed with status 3 (error)." in lines
        assert f"[ERROR] fmi2SetReal: {logged}" in done.stdout
    for call in ("set q1 and umax=-4", "set u1", "get vr 99", "set vr 13", "getInteger vr 0", "setBoolean vr 0",
                 "doStep before initialization", "getFMUstate"):
        assert f"{call} refused 3" in lines
    assert "[ERROR] fmi2GetReal: no Real variable has value reference 99" in lines
    assert "[ERROR] fmi2SetReal: u1 = 1 refused: an output cannot be set" in lines
    assert "kept [0.0, 60.0, 15.0, 4.0]" in lines  # a refused set changed nothing, q1 included
    assert "steps [0.6, 0.0]" in lines


@pytest.mark.slow
def test_two_instances_in_one_process_keep_their_own_parameters_and_inputs(fmu, tmp_path):
    unzipdir = fmpy.extract(str(fmu), str(tmp_path / "unzipped"))
    md = read_model_description(str(fmu))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    slaves = [FMU2Slave(guid=md.guid, unzipDirectory=unzipdir, modelIdentifier="PdController", instanceName=name)
              for name in ("a", "b")]
    try:
        for slave in slaves:
            slave.instantiate()
        for slave, kp, q1_ref in zip(slaves, (5.0, 7.0), (0.1, 0.3)):
            slave.setReal([vr["Kp"], vr["umax"]], [kp, 100.0])
            slave.setupExperiment(startTime=0.0)
            slave.enterInitializationMode()
            slave.exitInitializationMode()
            slave.setReal([vr["q1_ref"]], [q1_ref])
        for slave in slaves:
            slave.doStep(0.0, 0.01)
        outputs = [slave.getReal([vr["u1"], vr["u2"]]) for slave in slaves]
        assert outputs == [[5.0 * 0.1, 0.0], [7.0 * 0.3, 0.0]]
    finally:
        for slave in slaves:
            slave.terminate()
            slave.freeInstance()


def test_the_build_script_imports_only_the_standard_library_and_fmpy():
    """A user copies the folder anywhere: nothing of sotc-cosim may be needed."""
    tree = ast.parse(BUILD.read_text())
    imported = {alias.name.split(".")[0] for node in ast.walk(tree) if isinstance(node, ast.Import) for alias in node.names}
    imported |= {node.module.split(".")[0] for node in ast.walk(tree) if isinstance(node, ast.ImportFrom) and node.level == 0}
    assert "fmpy" in imported and sorted(imported - sys.stdlib_module_names - {"fmpy"}) == []


def _no_compiler_env(tmp_path: Path) -> dict[str, str]:
    """PATH holds an empty folder only (no cc, no gcc) and CC is unset."""
    empty = tmp_path / "empty_path"
    empty.mkdir()
    return {**{k: v for k, v in os.environ.items() if k != "CC"}, "PATH": str(empty)}


@pytest.mark.parametrize("variant", ["CC names no file", "no compiler on PATH"])
def test_without_a_compiler_the_build_says_so_in_one_line_and_writes_nothing(tmp_path, variant):
    env = {**os.environ, "CC": "/nonexistent/cc"} if variant == "CC names no file" else _no_compiler_env(tmp_path)
    out = tmp_path / "out"
    out.mkdir()
    done = run_build(tmp_path, "--out", str(out), env=env)
    assert done.returncode == 2 and done.stdout == ""
    assert len(done.stderr.splitlines()) == 1 and done.stderr.startswith("build.py: no C compiler"), done.stderr
    assert list(out.iterdir()) == []


def test_an_out_folder_that_does_not_exist_is_refused_in_one_line(tmp_path):
    done = run_build(tmp_path, "--out", str(tmp_path / "missing"))
    assert done.returncode == 2 and done.stderr == f"build.py: --out: {tmp_path / 'missing'} is not a folder\n"
    assert list(tmp_path.iterdir()) == []


def _build_with_fake_compiler(tmp_path: Path, shell: str) -> tuple[subprocess.CompletedProcess, Path]:
    """build.py with CC a shell script running these lines, into an empty folder: how it ended, and the folder."""
    fake = tmp_path / "cc"
    fake.write_text(f"#!/bin/sh\n{shell}\n")
    fake.chmod(0o755)
    out = tmp_path / "out"
    out.mkdir()
    return run_build(tmp_path, "--out", str(out), env={**os.environ, "CC": str(fake)}), out


@pytest.mark.skipif(sys.platform == "win32", reason="a shell script stands in for the compiler")
def test_a_failure_while_zipping_leaves_no_partial_fmu(tmp_path):
    """A compiler whose output is a dangling link: the zip fails after its temporary file was made."""
    done, out = _build_with_fake_compiler(
        tmp_path, 'while [ $# -gt 0 ]; do [ "$1" = -o ] && ln -s /nonexistent/so "$2"; shift; done')
    assert done.returncode == 1 and done.stderr.startswith("build.py: ") and len(done.stderr.splitlines()) == 1
    assert list(out.iterdir()) == []


def _copied_example(tmp_path: Path) -> Path:
    """The example folder as a user copies it, away from the repository."""
    folder = tmp_path / "my_controller"
    shutil.copytree(EXAMPLE, folder, ignore=shutil.ignore_patterns("__pycache__"))
    return folder


@pytest.mark.slow
def test_a_compilation_error_exits_1_with_the_compiler_messages_and_writes_nothing(tmp_path):
    skip_without_compiler()
    folder = _copied_example(tmp_path)
    source = folder / "pd_controller.c"
    source.write_text(source.read_text().replace("r[U1] = u1;", "r[U1] = u1"))
    out = tmp_path / "out"
    out.mkdir()
    done = run_build(tmp_path, "--out", str(out), script=folder / "build.py")
    assert done.returncode == 1 and done.stdout == ""
    assert "error" in done.stderr and done.stderr.splitlines()[-1].startswith("build.py: ")
    assert list(out.iterdir()) == []


@pytest.mark.skipif(sys.platform == "win32", reason="a shell script stands in for the compiler")
def test_sigterm_during_the_build_ends_it_like_ctrl_c_with_nothing_written(tmp_path):
    """A compiler that sends the build SIGTERM: the build stops (128 + 15), no traceback, nothing written."""
    done, out = _build_with_fake_compiler(tmp_path, "kill -TERM $PPID\nexec sleep 60")
    assert done.returncode == 128 + signal.SIGTERM and "Traceback" not in done.stderr, done.stderr
    assert list(out.iterdir()) == []
