"""Fixtures of the fault tests: small file systems that are full or read-only (tmpfs, where this
process may mount one; the tests that need one skip otherwise, and the file-size limit stands in)."""
from __future__ import annotations

import subprocess
from pathlib import Path

import pytest


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
