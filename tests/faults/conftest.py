"""Fixtures of the fault tests: small file systems that are full or read-only (tmpfs, where this
process may mount one; the tests that need one skip otherwise, and the file-size limit stands in), and
the FMI 3 arm with its shim."""
from __future__ import annotations

import subprocess
import zipfile
from pathlib import Path

import pytest

from orchestration.fmu_build import shim
from orchestration.fmu_build.packaging import shim_unavailable


def _mount(where: Path, options: str) -> bool:
    where.mkdir(parents=True, exist_ok=True)
    return subprocess.run(["mount", "-t", "tmpfs", "-o", options, "tmpfs", str(where)],
                          capture_output=True).returncode == 0


@pytest.fixture
def full_disk(tmp_path):
    """A 1 MB file system: a 100 s recording (about 9 MB) cannot fit."""
    where = tmp_path / "full"
    if not _mount(where, "size=1m"):
        pytest.skip("cannot mount a tmpfs here (not root?): the file-size-limit tests cover ENOSPC's path")
    yield where
    subprocess.run(["umount", "-l", str(where)], capture_output=True)


@pytest.fixture
def read_only(tmp_path):
    where = tmp_path / "ro"
    if not _mount(where, "size=1m,ro"):
        pytest.skip("cannot mount a read-only tmpfs here (not root?)")
    yield where
    subprocess.run(["umount", "-l", str(where)], capture_output=True)


@pytest.fixture(scope="session")
def shimmed_arm3(fmi3_paths) -> Path:
    """The FMI 3 ArmPlant, whose binary is the shim (``orchestration/fmu_build/fmi3_shim.c``); skipped where
    the FMI 3 FMUs were built without it."""
    with zipfile.ZipFile(fmi3_paths["ArmPlant"]) as z:
        if f"resources/{shim.SIZES_FILE}" not in z.namelist():
            pytest.skip(f"the FMI 3 FMUs were built without the shim here: {shim_unavailable() or 'not in the FMU'}")
    return fmi3_paths["ArmPlant"]
