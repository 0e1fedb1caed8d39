"""A non-Python host (docs/c_host/host.c) runs the ArmPlant FMU and gets fmpy's trajectory, bit for bit.

The pythonfmu binary does not link libpython (no NEEDED entry; it references ``_Py_NoneStruct`` and
the C API as undefined symbols), so the host process must provide them: here through LD_PRELOAD of
the libpython this test runs on. The embedded interpreter then finds its standard library from
libpython's build prefix and imports numpy from that interpreter's site-packages; PYTHONPATH adds
the site-packages this test process uses, so both sides run the same numpy.
"""
import os
import shutil
import subprocess
import sys
import sysconfig
import zipfile
from pathlib import Path

import numpy as np
import pytest

from fmu_driver import DrivenFmu

HOST_SOURCE = Path(__file__).resolve().parent.parent / "docs" / "c_host" / "host.c"
STEPS, TAU = 100, (1.0, -0.5)
T = 0.01


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


def _run(host: Path, fmu: Path, tmp: Path, env: dict) -> subprocess.CompletedProcess:
    unzip = tmp / "ArmPlant"
    with zipfile.ZipFile(fmu) as z:
        z.extractall(unzip)
    plant = DrivenFmu(fmu, tmp / "ids")
    md = plant.md
    plant.free()
    args = [md.guid, *(str(plant.vr[n]) for n in ("tau1", "tau2", "phi1", "phi2")), *map(repr, TAU), str(STEPS)]
    return subprocess.run([str(host), str(unzip), *args], capture_output=True, text=True, env=env, timeout=120)


def _base_env() -> dict:
    env = {k: v for k, v in os.environ.items() if k not in ("LD_PRELOAD", "PYTHONHOME", "PYTHONPATH")}
    return env


def test_without_libpython_the_host_is_told_why(host, fmu_paths, tmp_path):
    proc = _run(host, fmu_paths["ArmPlant"], tmp_path, _base_env())
    assert proc.returncode == 2
    assert "undefined symbol" in proc.stderr and "Py" in proc.stderr


def test_c_host_matches_fmpy_bitwise(host, fmu_paths, tmp_path):
    numpy_site = str(Path(np.__file__).resolve().parent.parent)
    env = _base_env() | {"LD_PRELOAD": str(_libpython()), "PYTHONPATH": numpy_site}
    proc = _run(host, fmu_paths["ArmPlant"], tmp_path, env)
    assert proc.returncode == 0, proc.stderr
    rows = [line.split() for line in proc.stdout.splitlines()]
    assert len(rows) == STEPS
    c_phi = np.array([[float(r[1]), float(r[2])] for r in rows])

    plant = DrivenFmu(fmu_paths["ArmPlant"], tmp_path / "fmpy")
    plant.initialize()
    plant.set(tau1=TAU[0], tau2=TAU[1])
    py_phi = []
    for k in range(STEPS):
        plant.fmu.doStep(k * T, T)
        py_phi.append(plant.get("phi1", "phi2"))
    plant.free()
    py_phi = np.array(py_phi)
    assert np.ptp(py_phi[:, 0]) > 0.01  # the torque moved the arm
    assert np.array_equal(c_phi, py_phi)
