"""Shared fixtures: the FMUs are built once per test session, in a child process (never in the
test process itself, so the tests exercise the built FMUs and not the imported source tree)."""
from __future__ import annotations

from pathlib import Path

import pytest

from orchestration.build import FMU_SOURCES, ensure_built


@pytest.fixture(scope="session")
def fmu_dir(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("fmus")
    ensure_built(list(FMU_SOURCES), out)
    return out


@pytest.fixture(scope="session")
def fmu_paths(fmu_dir) -> dict[str, Path]:
    return {m: fmu_dir / f"{m}.fmu" for m in FMU_SOURCES}
