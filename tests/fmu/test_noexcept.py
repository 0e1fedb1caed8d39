"""The cores' ``.pxd`` declare ``noexcept`` the C functions that cannot raise, so that their callers test no
Python error after each call (for a function returning a C tuple or nothing, Cython's test calls
``PyErr_Occurred`` every time). Cython gives a ``noexcept`` function that can raise an unraisable-exception
path instead: the error would be printed and the step would go on with a made-up number. In the C Cython
generates for the cores, with the build's directives, no function declared ``noexcept`` may have a path
that raises (and none that returns a Python object, for which Cython ignores ``noexcept``)."""
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
_DECLARATION = re.compile(r"^(\s*)(?:cdef class (\w+)|c?p?def\s+(?:\([^()]*\)|[\w\[\]:]+)\s+(\w+)\()", re.M)


def _noexcept_functions(pxd: str, module: str) -> list[str]:
    """The C names of the functions ``pxd`` declares ``noexcept`` (Cython's: __pyx_f_ and the qualified name,
    each part prefixed by its length)."""
    prefix = "".join(f"{len(part)}{part}_" for part in module.split("."))
    names, cls = [], ""
    for m in _DECLARATION.finditer(pxd):
        if m.group(2):
            cls = f"{len(m.group(2))}{m.group(2)}_"
            continue
        depth, i = 0, m.end() - 1
        while True:  # the argument list's closing parenthesis, over several lines if need be
            depth += {"(": 1, ")": -1}.get(pxd[i], 0)
            i += 1
            if depth == 0:
                break
        if pxd[i:].startswith(" noexcept"):
            names.append(f"__pyx_f_{prefix}{cls if m.group(1) else ''}{m.group(3)}")
    return names


def _body(c: str, name: str) -> str:
    m = re.search(r"\nstatic [^\n;]*\b" + re.escape(name) + r"\([^;{]*\) \{\n", c)
    assert m, f"{name} is not defined in the generated C"
    return c[m.end():c.index("\n}\n", m.end())]


def test_no_function_declared_noexcept_can_raise(tmp_path):
    for package in {rel.split("/")[0] for rel in compiled.HOT}:
        shutil.copytree(PACKAGE_ROOT / package, tmp_path / package, ignore=shutil.ignore_patterns("__pycache__", "*.so"))
    proc = subprocess.run([sys.executable, "-c", _CYTHONIZE, *compiled.HOT], cwd=tmp_path, capture_output=True,
                          text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert "noexcept clause is ignored" not in proc.stderr  # declared on a function returning a Python object
    raising, declared = [], 0
    for rel in compiled.HOT:
        c = (tmp_path / rel).with_suffix(".c").read_text()
        assert "__Pyx_WriteUnraisable(" not in c, rel
        names = _noexcept_functions((tmp_path / compiled.declarations(rel)).read_text(), rel[:-3].replace("/", "."))
        raising += [name for name in names if "__PYX_ERR(" in _body(c, name)]
        declared += len(names)
    assert declared >= 20 and raising == []  # the elementary functions' helpers and the small linear algebra at least
