"""Compiled cores (the default build where Cython and a C compiler are found): the FMU carries Cython extensions of its hot
modules beside their ``.py`` under its per-build names, loads them in a matching interpreter, and gives
the pure-Python FMU's outputs bit for bit, both builds side by side in one process."""
from __future__ import annotations

import importlib.machinery
import sys
import zipfile

import numpy as np
import pytest

from orchestration.fmu_build import compiled
from orchestration.bench.speed import compiled_fmus, python_fmus
from orchestration.run.master import run
from orchestration.run.scenario import load_scenario

pytestmark = pytest.mark.skipif(compiled.unavailable() is not None, reason=f"cannot compile here: {compiled.unavailable()}")
MODELS = ["SotcController", "ArmPlant", "ReferenceTrajectory"]  # the `paper` loop's FMUs with hot cores
SUFFIX = importlib.machinery.EXTENSION_SUFFIXES[0]


@pytest.fixture(scope="module")
def compiled_paths(fmu_dir) -> dict[str, object]:
    """The suite's own build (``fmu_dir``: compiled by default here), as ``sotc-cosim bench`` finds it."""
    return compiled_fmus(MODELS, fmu_dir)


@pytest.fixture(scope="module")
def python_paths(fmu_dir) -> dict[str, object]:
    """The same FMUs built with ``SOTC_COSIM_COMPILE=0``."""
    return python_fmus(MODELS, fmu_dir)


def _stem(fmu) -> str:
    with zipfile.ZipFile(fmu) as z:
        return z.read("resources/slavemodule.txt").decode().strip()


def _hot_modules(fmu) -> list[str]:
    """The ``HOT`` modules the FMU bundles (each one is to be compiled)."""
    stem = _stem(fmu)
    with zipfile.ZipFile(fmu) as z:
        return [rel for rel in compiled.HOT if f"resources/{stem}_lib/{rel}" in z.namelist()]


def test_the_fmu_carries_an_extension_beside_each_hot_module(compiled_paths):
    fmu = compiled_paths["SotcController"]
    stem = _stem(fmu)
    with zipfile.ZipFile(fmu) as z:
        names = set(z.namelist())
        page = z.read("documentation/index.html").decode()
    controller = _hot_modules(fmu)
    assert {"fmu_numerics/elementary.py", "fmu_controller/sotc.py", "fmu_controller/sotc_math.py",
            "fmu_plant/dynamics.py"} <= set(controller)
    for rel in controller:
        assert f"resources/{stem}_lib/{rel[:-3]}{SUFFIX}" in names, rel  # under the final stem
    assert not [n for n in names if n.endswith(".c") or "000000000000" in n]
    assert "Compiled cores" in page and compiled.target() in page


def test_the_plant_fmus_bundle_no_controller_code(compiled_paths):
    """The numerics sit below the plant (issue 50): an arm or reference FMU carries fmu_numerics and
    fmu_plant, compiled, and nothing of fmu_controller."""
    for model in ("ArmPlant", "ReferenceTrajectory"):
        stem = _stem(compiled_paths[model])
        with zipfile.ZipFile(compiled_paths[model]) as z:
            names = z.namelist()
        assert not [n for n in names if f"{stem}_lib/fmu_controller" in n], model
        assert f"resources/{stem}_lib/fmu_numerics/elementary{SUFFIX}" in names, model


def test_compiled_and_python_builds_run_side_by_side_with_the_same_outputs(compiled_paths, python_paths):
    """The whole 100 s `paper` run (whose Python build equals the stored reference run,
    tests/orchestration/test_reference_runs.py): every output of every sample, bit for bit."""
    scenario = load_scenario("paper")
    pure = run(scenario, python_paths)
    fast = run(scenario, compiled_paths)
    assert len(fast.time) == 10_001
    assert not pure.failed and not fast.failed, (pure.error, fast.error)
    for inst, outputs in pure.outputs.items():
        for var, values in outputs.items():
            assert np.array_equal(values, fast.outputs[inst][var], equal_nan=True), f"{inst}.{var}"
    # both builds of the SotcController are loaded in this process, each from its own files
    fast_core = sys.modules[f"{_stem(compiled_paths['SotcController'])}_lib.fmu_controller.sotc"]
    pure_core = sys.modules[f"{_stem(python_paths['SotcController'])}_lib.fmu_controller.sotc"]
    assert fast_core.__file__.endswith(SUFFIX) and pure_core.__file__.endswith(".py")


def test_switching_compiling_on_or_off_rebuilds(compiled_paths, python_paths, fmu_dir):
    """The build stamp names the compiled target: a Python-only FMU is not reused as a compiled one;
    the default build is the compiled one (where compiling is possible)."""
    assert compiled_paths["SotcController"] == fmu_dir / "SotcController.fmu"
    assert _stem(compiled_paths["SotcController"]) != _stem(python_paths["SotcController"])
    assert (compiled_paths["SotcController"].parent / "SotcController.sources.sha256").read_text() != \
        (python_paths["SotcController"].parent / "SotcController.sources.sha256").read_text()


def test_the_build_describes_its_cores_as_compiled(compiled_paths):
    """(``sotc-cosim validate`` passes these FMUs: tests/shipped/test_shipped_cli.py validates every FMU of the
    installed package's default build, compiled here.)"""
    fmu = compiled_paths["SotcController"]
    assert compiled.describe(fmu).startswith(f"{len(_hot_modules(fmu))} cores compiled")


def test_validate_finds_where_the_python_cores_would_differ(compiled_paths, tmp_path):
    """The ``cores`` check: a compiled FMU whose ``.py`` computes otherwise (here the inertia of (46)
    altered in the bundled dynamics) is reported with the first output that differs."""
    from orchestration.compliance import core_paths

    fmu = compiled_paths["ArmPlant"]
    stem, doctored = _stem(fmu), tmp_path / "ArmPlant.fmu"
    target = f"resources/{stem}_lib/fmu_plant/dynamics.py"
    with zipfile.ZipFile(fmu) as src, zipfile.ZipFile(doctored, "w") as out:
        for item in src.infolist():
            data = src.read(item)
            if item.filename == target:
                assert b"k[0] + 2.0 * k[2] * c2" in data
                data = data.replace(b"k[0] + 2.0 * k[2] * c2", b"k[0] + 2.5 * k[2] * c2")
            out.writestr(item, data)
    assert core_paths.problems(fmu) == []
    found = core_paths.problems(doctored)
    assert len(found) == 1 and "with the compiled cores" in found[0] and "with their .py" in found[0], found
