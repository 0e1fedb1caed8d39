"""Shared fixtures: the FMUs are built once per test run (once for all pytest-xdist workers: ``support.once``),
in a child process (never in the test process itself, so the tests exercise the built FMUs and not the
imported source tree)."""
from __future__ import annotations

import os
from pathlib import Path

import pytest
from hypothesis import settings

# CI (the env var CI set, as CI services do) draws the same examples on every run, so a result never
# flips between two runs of one commit; elsewhere each run explores new examples (a failure found
# there is kept as an explicit @example). Profiles load here, before any test module builds its settings.
settings.register_profile("ci", derandomize=True)
settings.register_profile("explore", derandomize=False)
settings.load_profile("ci" if os.environ.get("CI") else "explore")

from support.once import made_once
from support.schedule import longest_first

from orchestration.fmu_build.build import FMU_SOURCES, ensure_built


def pytest_collection_modifyitems(items) -> None:
    longest_first(items)  # the order xdist hands the files out in (support.schedule)


@pytest.fixture(scope="session")
def fmu_dir(tmp_path_factory) -> Path:
    with made_once(tmp_path_factory, "fmus") as (out, fill):
        if fill:
            ensure_built(list(FMU_SOURCES), out)
    return out


@pytest.fixture(scope="session")
def fmu_paths(fmu_dir) -> dict[str, Path]:
    """The FMUs as a default build makes them: cores compiled where Cython and a C compiler are found."""
    return {m: fmu_dir / f"{m}.fmu" for m in FMU_SOURCES}


@pytest.fixture(scope="session")
def python_fmu_paths(fmu_dir, tmp_path_factory) -> dict[str, Path]:
    """The same FMUs built with ``SOTC_COSIM_COMPILE=0`` (cores in Python)."""
    from orchestration.bench.speed import python_fmus

    with made_once(tmp_path_factory, "python-fmus") as (_, fill):  # into fmu_dir/python, once
        return python_fmus(list(FMU_SOURCES), fmu_dir) if fill else {m: fmu_dir / "python" / f"{m}.fmu"
                                                                      for m in FMU_SOURCES}


@pytest.fixture(scope="session")
def shipped(tmp_path_factory):
    """The project installed from a wheel into a fresh virtualenv (``tests/shipped.py``)."""
    from support.shipped import install, installed

    with made_once(tmp_path_factory, "shipped") as (root, fill):
        return install(root) if fill else installed(root)


@pytest.fixture(scope="session")
def shipped_fmu_dir(shipped, tmp_path_factory) -> Path:
    """The FMUs as the installed ``sotc-cosim build`` makes them."""
    out = shipped.root / "fmus"
    with made_once(tmp_path_factory, "shipped-fmus") as (_, fill):
        if fill:
            proc = shipped.cli("build", "--out", str(out), cwd=shipped.workdir("build"))
            assert proc.returncode == 0, proc.stderr
    return out


@pytest.fixture(scope="session")
def fmi3_paths(tmp_path_factory) -> dict[str, Path]:
    """The FMI 3.0 FMUs, cores in Python (compiling them again would double the suite's build time;
    the compiled FMI 3 build is exercised by tests/shipped/test_shipped_fmi3.py's `paper` FMUs)."""
    from orchestration.fmu_build.compiled import switched

    with made_once(tmp_path_factory, "fmus3") as (out, _), switched(False):
        return ensure_built(list(FMU_SOURCES), out, fmi=3)  # current already: found, not built again
