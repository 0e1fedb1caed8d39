"""The cores' ``.pxd`` declare ``noexcept`` the C functions that cannot raise, so that their callers test no
Python error after each call (for a function returning a C tuple or nothing, Cython's test calls
``PyErr_Occurred`` every time). Cython gives a ``noexcept`` function that can raise an unraisable-exception
path instead: the error would be printed and the step would go on with a made-up number. The C Cython
generates for the cores, with the build's directives, must hold no such path."""
from __future__ import annotations

import re
import shutil
import subprocess
import sys

import pytest

from orchestration.fmu_build import compiled
from orchestration.fmu_build.build import PACKAGE_ROOT

pytest.importorskip("Cython", reason="Cython is not installed: the cores are not compiled here")

_CYTHONIZE = ("import sys\nfrom Cython.Build import cythonize\n"
              f"cythonize(sys.argv[1:], quiet=True, compiler_directives={compiled.DIRECTIVES!r})\n")


def _noexcept_declarations(pxd: str) -> int:
    return len(re.findall(r"\)\s*noexcept\b", pxd))


def test_no_function_declared_noexcept_can_raise(tmp_path):
    for package in {rel.split("/")[0] for rel in compiled.HOT}:
        shutil.copytree(PACKAGE_ROOT / package, tmp_path / package, ignore=shutil.ignore_patterns("__pycache__", "*.so"))
    proc = subprocess.run([sys.executable, "-c", _CYTHONIZE, *compiled.HOT], cwd=tmp_path, capture_output=True,
                          text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-2000:]
    declared = sum(_noexcept_declarations((tmp_path / compiled.declarations(rel)).read_text()) for rel in compiled.HOT)
    assert declared >= 20  # the elementary functions' helpers and the small linear algebra at least
    unraisable = {rel: re.findall(r'__Pyx_WriteUnraisable\("([^"]+)"', (tmp_path / rel).with_suffix(".c").read_text())
                  for rel in compiled.HOT}
    assert {rel: names for rel, names in unraisable.items() if names} == {}
