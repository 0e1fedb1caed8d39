"""No number the docs, the README or a stored result prints goes through BLAS or LAPACK.

Their kernels differ per CPU (and per ``OPENBLAS_CORETYPE``) in the last bits, which once turned a
generated docs block red on a machine whose environment chose another kernel. Everything the project
prints is computed by ``orchestration/`` from the cores, so this scans every module there, and the cores
themselves, for the calls that reach BLAS or LAPACK: ``numpy.linalg`` and ``scipy.linalg`` in any
spelling, the matrix product ``@``, and numpy's ``dot``, ``matmul``, ``einsum``, ``inner``, ``vdot`` and
``tensordot``. Fixed-order replacements: ``orchestration.study.ordered``, ``fmu_numerics.fixed_linalg``,
``fmu_controller.riccati``, ``orchestration.run.metrics.ordered_sum``.
"""
from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
SCANNED = ("orchestration", "fmu_numerics", "fmu_plant", "fmu_controller")
LINALG = ("numpy.linalg", "np.linalg", "scipy.linalg")
PRODUCTS = {"dot", "matmul", "einsum", "inner", "vdot", "tensordot"}


def _dotted(node: ast.AST) -> str:
    """``a.b.c`` for an attribute chain on a name, else ''."""
    parts = []
    while isinstance(node, ast.Attribute):
        parts.append(node.attr)
        node = node.value
    if isinstance(node, ast.Name):
        parts.append(node.id)
        return ".".join(reversed(parts))
    return ""


def blas_calls(source: str) -> list[tuple[int, str]]:
    """(line, what) for every use of BLAS or LAPACK in ``source``."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            found += [(node.lineno, f"import {a.name}") for a in node.names if a.name.endswith(".linalg")]
        elif isinstance(node, ast.ImportFrom):
            names = {a.name for a in node.names}
            if (node.module or "").endswith(".linalg") or "linalg" in names:
                found.append((node.lineno, f"from {node.module} import ..."))
        elif isinstance(node, ast.BinOp) and isinstance(node.op, ast.MatMult):
            found.append((node.lineno, "@"))
        elif isinstance(node, ast.Attribute):
            name = _dotted(node)
            if name.startswith(LINALG) and name.count(".") == 2:
                found.append((node.lineno, name))
            elif node.attr in PRODUCTS and (name.split(".")[0] in ("np", "numpy") or node.attr == "dot"):
                found.append((node.lineno, f".{node.attr}"))  # numpy's, and any array's .dot
    return sorted(set(found))


def _modules() -> list[Path]:
    return sorted(p for d in SCANNED for p in (ROOT / d).rglob("*.py"))


@pytest.mark.parametrize("path", _modules(), ids=lambda p: str(p.relative_to(ROOT)))
def test_no_blas_or_lapack_call(path):
    calls = blas_calls(path.read_text(encoding="utf-8"))
    assert not calls, f"{path.relative_to(ROOT)} reaches BLAS/LAPACK at " + ", ".join(f"line {n}: {w}" for n, w in calls)


@pytest.mark.parametrize("source, what", [
    ("import scipy.linalg\nscipy.linalg.solve_continuous_are(a, b, q, r)", "scipy.linalg.solve_continuous_are"),
    ("import numpy as np\nx = np.linalg.norm(v)", "np.linalg.norm"),
    ("from numpy import linalg", "from numpy import ..."),
    ("from scipy.linalg import eigh", "from scipy.linalg import ..."),
    ("y = z ** 2 @ theta", "@"),
    ("y = np.dot(a, b)", ".dot"),
    ("y = a.dot(b)", ".dot"),
    ("y = np.einsum('ij,ij->i', a, a)", ".einsum"),
    ("import numpy\ny = numpy.matmul(a, b)", ".matmul"),
])
def test_the_scan_finds_each_spelling(source, what):
    assert what in [w for _, w in blas_calls(source)]


def test_the_scan_leaves_plain_numpy_alone():
    assert blas_calls("import numpy as np\ny = np.outer(a, b) + np.cumsum(x)[-1] * a + run.inner\n"
                      "@property\ndef f(): pass") == []
