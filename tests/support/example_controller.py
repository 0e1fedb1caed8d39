"""examples/pd_controller, built by its own script as a user builds it: for the tests of the example itself and
of what takes a foreign controller FMU (``sotc-cosim check-controller``)."""
from __future__ import annotations

import os
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from support import REPO

from orchestration.bench.foreign import FMU_NAME, PORTS  # noqa: F401  its file's name; its port map (docs/benchmark.md)

EXAMPLE = REPO / "examples" / "pd_controller"
BUILD = EXAMPLE / "build.py"


def compiler() -> str | None:
    """What build.py would compile with: $CC, else cc or gcc on PATH."""
    if os.environ.get("CC"):
        return shutil.which(shlex.split(os.environ["CC"])[0])
    return shutil.which("cc") or shutil.which("gcc")


def run_build(cwd: Path, *args: str, script: Path = BUILD, env: dict | None = None) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(script), *args], cwd=cwd, env=env, capture_output=True, text=True,
                          timeout=300)


def skip_without_compiler() -> None:
    if compiler() is None:
        pytest.skip("no C compiler ($CC, cc or gcc) to build examples/pd_controller")


def built_fmu(folder: Path) -> Path:
    """The example's FMU built into ``folder`` (the test skips where no C compiler is found)."""
    skip_without_compiler()
    done = run_build(folder, "--out", str(folder))
    assert done.returncode == 0, done.stderr
    return folder / FMU_NAME
