"""What an FMU needs from the Python that hosts it, checked before anything needs it.

Each built FMU's script starts by calling ``require_host_packages`` with the requirements written
into its ``resources/requirements.txt`` (e.g. ``"numpy>=2.0,<3"``). A package that is missing or
outside its range then stops ``fmi2Instantiate`` with one message naming the FMU, the package, the
range, the interpreter and how to install it, instead of a bare traceback from deep in an import.

Standard library only: this runs before numpy is known to be importable.
"""
from __future__ import annotations

import importlib
import importlib.metadata
import re
import sys
from typing import Iterable

_REQUIREMENT = re.compile(r"^\s*([A-Za-z0-9_.-]+)\s*((?:[<>=!]=?\s*[^,\s]+\s*,?\s*)*)$")
_SPECIFIER = re.compile(r"(<=|>=|==|!=|<|>)\s*([^,\s]+)")
_TESTS = {"<": lambda c: c < 0, "<=": lambda c: c <= 0, ">": lambda c: c > 0, ">=": lambda c: c >= 0,
          "==": lambda c: c == 0, "!=": lambda c: c != 0}


def _release(version: str) -> tuple[int, ...]:
    """The numeric release part of a version ("2.1.0rc1" -> (2, 1, 0)), padded for comparison."""
    match = re.match(r"\d+(?:\.\d+)*", version.strip())
    return tuple(int(p) for p in match.group(0).split(".")) if match else ()


def _compare(a: tuple[int, ...], b: tuple[int, ...]) -> int:
    n = max(len(a), len(b))
    a, b = a + (0,) * (n - len(a)), b + (0,) * (n - len(b))
    return (a > b) - (a < b)


def satisfies(version: str, specifiers: str) -> bool:
    """Whether ``version`` meets every comparison in ``specifiers`` (e.g. ">=2.0,<3"), release parts only."""
    have = _release(version)
    return all(_TESTS[op](_compare(have, _release(bound))) for op, bound in _SPECIFIER.findall(specifiers))


def parse_requirement(line: str) -> tuple[str, str]:
    """("numpy", ">=2.0,<3") from "numpy>=2.0,<3"."""
    match = _REQUIREMENT.match(line)
    if not match:
        raise ValueError(f"not a requirement: {line!r}")
    return match.group(1), match.group(2).replace(" ", "")


def installed_version(name: str) -> str | None:
    """The version of distribution ``name`` that this interpreter imports, or None if it has none."""
    try:
        return importlib.metadata.version(name)
    except importlib.metadata.PackageNotFoundError:
        try:
            module = importlib.import_module(name)
        except ImportError:
            return None
        return str(getattr(module, "__version__", "0"))


def host_problems(requirements: Iterable[str]) -> list[str]:
    """One sentence per requirement this interpreter does not meet."""
    problems = []
    for line in requirements:
        name, spec = parse_requirement(line)
        version = installed_version(name)
        if version is None:
            problems.append(f"the package '{name}' ({name}{spec}) is not installed")
        elif not satisfies(version, spec):
            problems.append(f"the package '{name}' is version {version}, outside the range {name}{spec}")
    return problems


def require_host_packages(model: str, requirements: Iterable[str]) -> None:
    """Raise ImportError with one message if the hosting interpreter lacks a required package."""
    requirements = tuple(requirements)
    problems = host_problems(requirements)
    if problems:
        raise ImportError(
            f"{model} FMU: {'; '.join(problems)} in the Python that hosts this FMU "
            f"({sys.executable or 'embedded interpreter'}, Python {sys.version.split()[0]}). "
            f"Install them there with: python -m pip install {' '.join(repr(r) for r in requirements)} "
            f"(or: pythonfmu deploy -f {model}.fmu)"
        )
