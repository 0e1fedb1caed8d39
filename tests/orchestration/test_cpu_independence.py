"""One result on every machine: the reference runs of ``support/bit_runs.py`` give the same
bits under every OpenBLAS kernel, with numpy's CPU dispatch limited and with glibc's libm on the code
paths of a CPU without FMA or AVX, for the compiled build of the cores (each mask in a kernel's child:
``COMPILED_ENVIRONMENTS``; the Python build under two of the kernels and both masks, the masks together:
``PYTHON_ENVIRONMENTS``; its cases: ``bit_runs.in_python_subset``), and equal the
stored ``tests/data/reference_bits.json``.

A kernel is forced with ``OPENBLAS_CORETYPE`` (numpy's and scipy's OpenBLAS both read it); numpy's own
SIMD loops are held to the baseline with ``NPY_DISABLE_CPU_FEATURES`` (the features this machine's numpy
dispatches to beyond it); glibc's CPU-specific variants (its libm's exp, sin ... among them) are switched
off with ``GLIBC_TUNABLES=glibc.cpu.hwcaps=...`` (the cores call no libm function but sqrt, which IEEE 754
rounds correctly: ``fmu_numerics/elementary.py``). The compiled build is the installed package (its pure loop) and the default
FMU build; the Python build is the source tree's ``.py`` on PYTHONPATH and the FMUs built with
``SOTC_COSIM_COMPILE=0``. The generated docs blocks that print linear algebra, and every quick block but
the fair comparison's three bootstrap tables (``KERNEL_RENDERED_ONCE``),
are rendered under other kernels too (``test_generated_docs_are_the_same_under_every_kernel``)."""
from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy._core._multiarray_umath as numpy_dispatch
import pytest
from support.bit_runs import DATA, in_python_subset

from fmu_controller.saturation import ACCEL
from orchestration.fmu_build.build import compiles
from orchestration.study.fair import SETS

REPO = Path(__file__).resolve().parents[2]
SCRIPT = REPO / "tests" / "support" / "bit_runs.py"
KERNELS = ("Prescott", "Sandybridge", "Haswell", "SkylakeX", "Zen")
NUMPY_BASELINE = " ".join(numpy_dispatch.__cpu_dispatch__)  # every target beyond numpy's compiled-in baseline
NO_FMA = "glibc.cpu.hwcaps=-AVX2,-FMA,-AVX,-AVX512F"  # glibc as on a CPU without FMA, AVX2, AVX, AVX-512
ENVIRONMENTS = {**{k: {"OPENBLAS_CORETYPE": k} for k in KERNELS}, "numpy baseline": {"NPY_DISABLE_CPU_FEATURES": NUMPY_BASELINE},
                "glibc without FMA": {"GLIBC_TUNABLES": NO_FMA}}
# the Python build, 30 times slower, in two children: the oldest kernel with both masks at once, and the newest
# kernel as it dispatches. It calls no BLAS (tests/docs/test_no_blas.py scans for it) and the same numpy
# elementwise loops under every kernel; a child per environment, as the compiled build has, added 200 s of the
# suite and no case that these two do not cover (a mask that changed a bit would change it in the first child)
PYTHON_ENVIRONMENTS = (("Prescott", "numpy baseline", "glibc without FMA"), ("SkylakeX",))
# the compiled build: a child per kernel, each mask with one of them (a mask that changed a bit would change it
# there too; 9 s of the suite less than a child of its own each)
COMPILED_ENVIRONMENTS = (("Prescott", "numpy baseline"), ("Sandybridge", "glibc without FMA"), ("Haswell",),
                         ("SkylakeX",), ("Zen",))
REFERENCE = json.loads((DATA / "reference_bits.json").read_text())


def first_difference(got: dict, want: dict) -> str | None:
    for case in sorted(set(got) | set(want)):
        if case not in got or case not in want:
            return f"{case}: only in {'the run' if case in got else 'the reference'}"
        for key in sorted(set(got[case]) | set(want[case])):
            a, b = got[case].get(key), want[case].get(key)
            if a != b:
                return (f"{case} / {key}: {float.fromhex(a) if a else None!r} here, "
                        f"{float.fromhex(b) if b else None!r} stored")
    return None


def bits(environment: dict[str, str], build: str, fmu_dir: Path | None) -> dict:
    """The reference runs in a child under ``environment``; without ``fmu_dir``, the Python build's subset."""
    env = {k: v for k, v in os.environ.items() if k not in ("OPENBLAS_CORETYPE", "NPY_DISABLE_CPU_FEATURES", "GLIBC_TUNABLES")}
    env.pop("PYTHONPATH", None)
    if build == "python":
        env["PYTHONPATH"] = str(REPO)  # the source tree's .py before the installed (compiled) package
    proc = subprocess.run([sys.executable, str(SCRIPT), str(fmu_dir) if fmu_dir else "--python"], env=env | environment,
                          capture_output=True, text=True, timeout=900, cwd=REPO)
    assert proc.returncode == 0, proc.stderr[-2000:]
    return json.loads(proc.stdout)


def combined(names: tuple[str, ...]) -> dict[str, str]:
    """The environment of one child: the variables of every one of ``ENVIRONMENTS`` named (none shares a variable)."""
    out: dict[str, str] = {}
    for name in names:
        assert not set(out) & set(ENVIRONMENTS[name]), f"{name} sets a variable another environment of its child sets"
        out |= ENVIRONMENTS[name]
    return out


# the FMU cases (100 s of paper and of its radial variant through the FMUs) in the compiled build only: with
# the cores in Python they are a third of a child's time, and add no arithmetic to the pure loop's (the FMU
# wrapper passes values through); test_reference_runs runs the Python build's FMUs against the stored runs.
# The fair cases of the Python build: under accel only (support/bit_runs.py, ``in_python_subset``)


@pytest.mark.slow
@pytest.mark.parametrize("build", ["compiled", "python"])
def test_reference_runs_have_the_same_bits_everywhere(build, fmu_dir):
    """Each child's environments (``COMPILED_ENVIRONMENTS``, ``PYTHON_ENVIRONMENTS``), two children at a time
    (the children are single-threaded)."""
    if build == "compiled" and not compiles():
        pytest.skip("no compiled build here (Cython or a C compiler missing): the Python build is the one tested")
    # without a compiler the default build's FMUs are the Python build's: the FMU cases run there
    folder = fmu_dir if build == "compiled" or not compiles() else None
    children = list(COMPILED_ENVIRONMENTS if build == "compiled" else PYTHON_ENVIRONMENTS)
    want = REFERENCE if folder else {k: v for k, v in REFERENCE.items() if in_python_subset(k)}
    assert folder or 0 < len(want) < len(REFERENCE)
    with ThreadPoolExecutor(max_workers=2) as pool:
        results = dict(zip((" + ".join(c) for c in children),
                           pool.map(lambda c: bits(combined(c), build, folder), children)))
    for environment, got in results.items():
        difference = first_difference(got, want)
        assert difference is None, f"{environment}, {build} build: {difference}"


def test_the_python_builds_cases_are_every_pure_loop_case_and_a_fair_case_of_each_set():
    subset = [k for k in REFERENCE if in_python_subset(k)]
    assert [k for k in REFERENCE if k.startswith("loop ")] == [k for k in subset if k.startswith("loop ")]
    fair = [k for k in subset if k.startswith("fair ")]
    assert len(fair) == 2 and all(f" handling {ACCEL} " in k for k in fair) and not any(k.startswith("fmu ") for k in subset)
    marker = f" handling {ACCEL} "
    assert {k[k.index(marker) + len(marker):k.rindex(" point")] for k in fair} == set(SETS), fair


def test_the_compiled_build_runs_every_kernel_and_mask():
    named = [n for child in COMPILED_ENVIRONMENTS for n in child]
    assert sorted(named) == sorted(ENVIRONMENTS) and all(combined(child) for child in COMPILED_ENVIRONMENTS)
    assert all(len(set(child) & set(KERNELS)) == 1 for child in COMPILED_ENVIRONMENTS)  # a kernel each


def test_the_python_build_keeps_two_kernels_and_both_masks():
    named = [n for child in PYTHON_ENVIRONMENTS for n in child]
    assert set(named) <= set(ENVIRONMENTS)
    assert {"numpy baseline", "glibc without FMA"} < set(named)
    assert len(set(named) & set(KERNELS)) >= 2
    first = combined(PYTHON_ENVIRONMENTS[0])  # every mask and a kernel, in one child
    assert set(first) == {"OPENBLAS_CORETYPE", "NPY_DISABLE_CPU_FEATURES", "GLIBC_TUNABLES"}


def test_a_changed_bit_is_reported():
    case = sorted(REFERENCE)[0]
    key = sorted(REFERENCE[case])[0]
    value = float.fromhex(REFERENCE[case][key])
    doctored = {**REFERENCE, case: {**REFERENCE[case], key: math.nextafter(value, math.inf).hex()}}
    assert first_difference(doctored, REFERENCE).startswith(f"{case} / {key}")
    assert first_difference(REFERENCE, REFERENCE) is None


# The docs' own numbers: the blocks that take linear algebra of printed figures (the value study's LQR row
# and norms, the learned W's eigenvalues) and every quick block (but KERNEL_RENDERED_ONCE), rendered under two other OpenBLAS kernels
# than this environment's (which tests/docs/test_docgen.py renders), a child each, by the installed
# package (compiled where the build compiles) from this checkout's docs.
DOC_KERNELS = ("Haswell", "SkylakeX")
DOC_BLOCKS = ("value", "learned-w")
# quick blocks not rendered again under the kernels: the fair comparison's summary and appendix tables, a minute
# of bootstraps each time, whose statistics (BCa of means, no linear algebra) the fair-verdict and readme-verdict
# blocks rendered here compute on the same stored runs
KERNEL_RENDERED_ONCE = ("fair-initial", "fair-perturbed", "fair-paired")
DOCGEN_CHECK = """import sys
from pathlib import Path
from orchestration.reports import docgen
docgen.ROOT = Path(sys.argv[1])
sys.exit(docgen.main(["check", *sys.argv[2:]]))"""


@pytest.mark.slow
def test_generated_docs_are_the_same_under_every_kernel():
    from orchestration.reports import docgen

    names = [*DOC_BLOCKS, *(n for n, b in docgen.BLOCKS.items() if not b.slow and n not in KERNEL_RENDERED_ONCE)]
    assert {"fair-verdict", "readme-verdict"} <= set(names)
    env = {k: v for k, v in os.environ.items() if k not in ("OPENBLAS_CORETYPE", "PYTHONPATH")}

    def check(kernel: str) -> subprocess.CompletedProcess:
        return subprocess.run([sys.executable, "-c", DOCGEN_CHECK, str(REPO), *names],
                              env=env | {"OPENBLAS_CORETYPE": kernel}, capture_output=True, text=True,
                              timeout=1800, cwd=REPO.parent)

    with ThreadPoolExecutor(max_workers=2) as pool:
        for kernel, proc in zip(DOC_KERNELS, pool.map(check, DOC_KERNELS)):
            assert proc.returncode == 0, f"OPENBLAS_CORETYPE={kernel}: {(proc.stdout + proc.stderr)[-1500:]}"
