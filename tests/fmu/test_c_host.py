"""A non-Python host (docs/c_host/host.c) runs the ArmPlant FMU, gets fmpy's trajectory bit for bit,
and exits cleanly wherever the FMU was extracted; so does the FMI 3 host (docs/c_host/host3.c) with
the FMI 3 arm, after gets and sets of the wrong size were answered fmi3Error.

The pythonfmu binary does not link libpython (no NEEDED entry; it references ``_Py_NoneStruct`` and
the C API as undefined symbols), so the host process must provide them: here through LD_PRELOAD of
the libpython this test runs on. The embedded interpreter then finds its standard library from
libpython's build prefix and imports numpy from that interpreter's site-packages; PYTHONPATH adds
the site-packages this test process uses, so both sides run the same numpy.

Exit: pythonfmu 0.7.0's binary frees its interpreter keeper in a C++ static destructor and then
decrements a counter inside the freed block from its unload hook (docs/interop.md, "A non-Python
host"). Whether that corrupts the heap enough to abort depends on the heap's history, which the
extraction path's length changes: before the fix the host aborted (rc 134) at some of the lengths
below and not at others. ``DescribedSlave`` now releases the keeper first; the Python-host test
checks that no keeper is left for the exit path, which does not depend on heap luck.
"""
import json
import os
import shutil
import subprocess
import sys
import sysconfig
import tempfile
import zipfile
from pathlib import Path

import numpy as np
import pytest
from support.fmu_driver import DrivenFmu

HOST_SOURCE = Path(__file__).resolve().parents[2] / "docs" / "c_host" / "host.c"
STEPS, TAU = 100, (1.0, -0.5)
T = 0.01
# lengths of the extraction folder's absolute path: short, the two bands reported to abort
# (25-44, 104-114), in between and long; pytest's own tmp_path is run as well
PATH_LENGTHS = (20, 25, 30, 35, 40, 44, 50, 60, 80, 104, 108, 110, 114, 130, 200)
KEEPER_SYMBOL = "_ZN12_GLOBAL__N_17pyStateE"  # the binary's file-static shared_ptr<PyState>


def _libpython() -> Path | None:
    if not sysconfig.get_config_var("Py_ENABLE_SHARED"):
        return None
    name = sysconfig.get_config_var("INSTSONAME") or sysconfig.get_config_var("LDLIBRARY")
    path = Path(sysconfig.get_config_var("LIBDIR")) / name
    return path if path.exists() else None


pytestmark = [
    pytest.mark.skipif(sys.platform != "linux", reason="the C host loads binaries/linux64"),
    pytest.mark.skipif(shutil.which("gcc") is None, reason="gcc is not installed"),
    pytest.mark.skipif(_libpython() is None, reason="this Python has no shared libpython to preload"),
]


@pytest.fixture(scope="module")
def host(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("c_host") / "host"
    subprocess.run(["gcc", "-O2", "-Wall", "-Werror", "-o", str(out), str(HOST_SOURCE), "-ldl"], check=True)
    return out


@pytest.fixture(scope="module")
def host_args(fmu_paths, tmp_path_factory) -> list[str]:
    """GUID and value references of tau1, tau2, phi1, phi2, the torques and the step count."""
    plant = DrivenFmu(fmu_paths["ArmPlant"], tmp_path_factory.mktemp("ids"))
    guid = plant.md.guid
    vrs = [str(plant.vr[n]) for n in ("tau1", "tau2", "phi1", "phi2")]
    plant.free()
    return [guid, *vrs, *map(repr, TAU), str(STEPS)]


@pytest.fixture(scope="module")
def fmpy_phi(fmu_paths, tmp_path_factory) -> np.ndarray:
    """(phi1, phi2) after every step, from fmpy in this process."""
    plant = DrivenFmu(fmu_paths["ArmPlant"], tmp_path_factory.mktemp("fmpy"))
    plant.initialize()
    plant.set(tau1=TAU[0], tau2=TAU[1])
    phi = []
    for k in range(STEPS):
        plant.fmu.doStep(k * T, T)
        phi.append(plant.get("phi1", "phi2"))
    plant.free()
    phi = np.array(phi)
    assert np.ptp(phi[:, 0]) > 0.01  # the torque moved the arm
    return phi


@pytest.fixture(scope="module")
def short_root():
    """A folder directly under /tmp, so that extraction paths as short as 20 characters exist."""
    root = Path(tempfile.mkdtemp(prefix="ch", dir="/tmp"))
    yield root
    shutil.rmtree(root, ignore_errors=True)


def _extract(fmu: Path, unzip: Path) -> Path:
    with zipfile.ZipFile(fmu) as z:
        z.extractall(unzip)
    return unzip


def _at_length(root: Path, length: int) -> Path:
    """A not yet existing folder under ``root`` whose absolute path has exactly ``length`` characters."""
    pad = length - len(str(root)) - 1
    assert pad >= 1, f"{root} is too long for a path of {length} characters"
    path = root / ("p" * pad)
    assert len(str(path)) == length and not path.exists()
    return path


def _base_env() -> dict:
    env = {k: v for k, v in os.environ.items() if k not in ("LD_PRELOAD", "PYTHONHOME", "PYTHONPATH")}
    return env


def _preload_env() -> dict:
    numpy_site = str(Path(np.__file__).resolve().parent.parent)
    return _base_env() | {"LD_PRELOAD": str(_libpython()), "PYTHONPATH": numpy_site}


def _run_host(host: Path, unzip: Path, args: list[str], env: dict) -> subprocess.CompletedProcess:
    return subprocess.run([str(host), str(unzip), *args], capture_output=True, text=True, env=env, timeout=120)


def _check_run(proc: subprocess.CompletedProcess, fmpy_phi: np.ndarray) -> None:
    assert proc.returncode == 0, f"rc {proc.returncode}: {proc.stderr[-2000:]}"
    rows = [line.split() for line in proc.stdout.splitlines()]
    assert len(rows) == STEPS
    c_phi = np.array([[float(r[1]), float(r[2])] for r in rows])
    assert np.array_equal(c_phi, fmpy_phi)


def test_without_libpython_the_host_is_told_why(host, host_args, fmu_paths, tmp_path):
    proc = _run_host(host, _extract(fmu_paths["ArmPlant"], tmp_path / "ArmPlant"), host_args, _base_env())
    assert proc.returncode == 2
    assert "undefined symbol" in proc.stderr and "Py" in proc.stderr


@pytest.mark.parametrize("length", PATH_LENGTHS)
def test_c_host_matches_fmpy_bitwise_and_exits_cleanly(length, host, host_args, fmpy_phi, fmu_paths, short_root):
    unzip = _extract(fmu_paths["ArmPlant"], _at_length(short_root, length))
    try:
        _check_run(_run_host(host, unzip, host_args, _preload_env()), fmpy_phi)
    finally:
        shutil.rmtree(unzip, ignore_errors=True)


def test_c_host_in_pytest_tmp_path(host, host_args, fmpy_phi, fmu_paths, tmp_path):
    unzip = _extract(fmu_paths["ArmPlant"], tmp_path / "ArmPlant")
    _check_run(_run_host(host, unzip, host_args, _preload_env()), fmpy_phi)


PYTHON_HOST = r"""
import ctypes, json, shutil, sys, zipfile
from pathlib import Path
from fmpy import read_model_description
from fmpy.fmi2 import FMU2Slave

fmu, root, offset = Path(sys.argv[1]), Path(sys.argv[2]), int(sys.argv[3], 16)
md = read_model_description(str(fmu))
for i in range(3):  # each instance from its own folder, freed, folder deleted (fmpy unloads the library)
    unzip = root / f"x{i}"
    zipfile.ZipFile(fmu).extractall(unzip)
    s = FMU2Slave(guid=md.guid, unzipDirectory=str(unzip),
                  modelIdentifier=md.coSimulation.modelIdentifier, instanceName=f"i{i}")
    s.instantiate()
    s.setupExperiment(startTime=0.0)
    s.enterInitializationMode()
    s.exitInitializationMode()
    s.doStep(0.0, 0.01)
    s.terminate()
    s.freeInstance()
    shutil.rmtree(unzip)
bases = {}  # every pythonfmu binary still mapped: its load address
for line in open("/proc/self/maps"):
    fields = line.split(maxsplit=5)
    if len(fields) == 6 and "/binaries/linux64/" in fields[5] and int(fields[2], 16) == 0:
        bases.setdefault(fields[5].strip(), int(fields[0].split("-")[0], 16))
keepers = {path: ctypes.string_at(base + offset, 16).hex() for path, base in bases.items()}
print(json.dumps(keepers))
"""


@pytest.mark.skipif(shutil.which("nm") is None, reason="nm (binutils) is not installed")
def test_python_host_leaves_no_keeper_for_the_exit_path(fmu_paths, tmp_path):
    """In a fresh Python process, after three instances from three folders (the first library stays
    mapped to the end: it provides the binary's GNU-unique symbols, so glibc never unloads it), every
    mapped binary's keeper pointer is already empty: the exit path has nothing to free or touch."""
    fmu = fmu_paths["ArmPlant"]
    binary = _extract(fmu, tmp_path / "nm") / "binaries" / "linux64" / "ArmPlant.so"
    symbols = subprocess.run(["nm", str(binary)], capture_output=True, text=True, check=True).stdout
    offset = next((line.split()[0] for line in symbols.splitlines() if line.endswith(" " + KEEPER_SYMBOL)), None)
    assert offset is not None, f"{KEEPER_SYMBOL} not in {binary}: not the pythonfmu 0.7 binary this checks"
    proc = subprocess.run([sys.executable, "-c", PYTHON_HOST, str(fmu), str(tmp_path / "run"), offset],
                          capture_output=True, text=True, timeout=120, env=_base_env(), cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr[-2000:]
    keepers = json.loads(proc.stdout.splitlines()[-1])
    assert keepers, "no pythonfmu binary left mapped: nothing was checked"
    assert all(words == "00" * 16 for words in keepers.values()), keepers


HOST3_SOURCE = HOST_SOURCE.with_name("host3.c")
FMI3_ERROR = 3


@pytest.fixture(scope="module")
def host3(tmp_path_factory) -> Path:
    """docs/c_host/host3.c, compiled against the FMI 3.0 headers fmpy ships for its own C code."""
    import fmpy

    out = tmp_path_factory.mktemp("c_host3") / "host3"
    subprocess.run(["gcc", "-O2", "-Wall", "-Werror", "-I", str(Path(fmpy.__file__).parent / "c-code"), "-o", str(out),
                    str(HOST3_SOURCE), "-ldl"], check=True)
    return out


@pytest.fixture(scope="module")
def arm3(fmi3_paths, tmp_path_factory) -> tuple[Path, list[str], np.ndarray]:
    """The FMI 3 arm (skipped without the size-checking binary), host3's arguments and fmpy's angles
    after every step."""
    from fmpy import read_model_description
    from fmpy.fmi3 import FMU3Slave

    from orchestration.fmu_build import shim

    fmu = fmi3_paths["ArmPlant"]
    if f"resources/{shim.SIZES_FILE}" not in zipfile.ZipFile(fmu).namelist():
        pytest.skip("the FMI 3 FMUs were built without the size-checking binary here (no C compiler)")
    md = read_model_description(str(fmu))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    slave = FMU3Slave(guid=md.guid, unzipDirectory=str(_extract(fmu, tmp_path_factory.mktemp("fmpy3") / "arm")),
                      modelIdentifier="ArmPlant", instanceName="fmpy")
    slave.instantiate()
    slave.enterInitializationMode(startTime=0.0)
    slave.exitInitializationMode()
    slave.setFloat64([vr["tau"]], list(TAU))
    phi = []
    for k in range(STEPS):
        slave.doStep(k * T, T)
        phi.append(slave.getFloat64([vr["phi"]], nValues=2))
    slave.terminate()
    slave.freeInstance()
    phi = np.array(phi)
    assert np.ptp(phi[:, 0]) > 0.01  # the torque moved the arm
    args = [md.instantiationToken, str(vr["tau"]), str(vr["phi"]), *map(repr, TAU), str(STEPS)]
    return fmu, args, phi


@pytest.mark.parametrize("length", PATH_LENGTHS[::2])
def test_fmi3_c_host_gets_fmi3error_for_wrong_sizes_and_fmpys_trajectory(length, host3, arm3, short_root):
    """The FMI 3 arm in a C host: a set of 3 torques and a read of 1 angle are fmi3Error with a logged
    message naming the array, the instance goes on to give fmpy's trajectory bit for bit, and the host
    exits cleanly wherever the FMU was extracted (its binary is the size-checking shim,
    orchestration/fmu_build/shim.py; pythonfmu3's keeper beside it is settled as pythonfmu's is)."""
    fmu, args, fmpy_phi = arm3
    unzip = _extract(fmu, _at_length(short_root, length))
    try:
        proc = _run_host(host3, unzip, args, _preload_env())
    finally:
        shutil.rmtree(unzip, ignore_errors=True)
    assert proc.returncode == 0, f"rc {proc.returncode}: {proc.stderr[-2000:]}"
    lines = proc.stdout.splitlines()
    assert lines[:2] == [f"size set {FMI3_ERROR}", f"size get {FMI3_ERROR}"], lines[:2]
    assert "'tau' (2 values) was given 3 values" in proc.stderr and "'phi' (2 values) was given 1 value" in proc.stderr
    c_phi = np.array([[float(x) for x in line.split()[1:]] for line in lines[2:]])
    assert np.array_equal(c_phi, fmpy_phi)
