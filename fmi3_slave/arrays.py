"""Which FMI 2 scalars an FMI 3 FMU declares as one array, and how an array's elements are named.

An array ``stem`` of n elements stands for the FMI 2 scalars ``stem1 .. stemn`` (the same names,
the same order): a master that flattens FMI 3 arrays with ``element_names`` reads and records the
FMI 2 series unchanged. Standard library only: the master imports it too.
"""
from __future__ import annotations

import re
from typing import Iterable

# the arm's joint angles and velocities, the torques, the SOTC's errors z and critic weights W
ARRAY_STEMS = ("phi", "dphi", "tau", "z", "W")
_ELEMENT = re.compile(r"^(" + "|".join(ARRAY_STEMS) + r")([1-9][0-9]*)$")


def element_names(name: str, size: int) -> list[str]:
    """The FMI 2 scalar names of the elements of array ``name`` (a scalar: itself)."""
    return [name] if size == 1 else [f"{name}{k}" for k in range(1, size + 1)]


def group(names: Iterable[str], kind_of) -> list[tuple[str, list[str]]]:
    """The FMI 3 variables for FMI 2 scalars ``names`` in declaration order: (name, its scalars). A
    stem's scalars form an array only if all of ``stem1 .. stemn`` are there (n >= 2) and share
    ``kind_of(name)`` (causality, type); the array takes the place of its first element."""
    names = list(names)
    present = set(names)
    out: list[tuple[str, list[str]]] = []
    taken: set[str] = set()
    for name in names:
        if name in taken:
            continue
        match = _ELEMENT.match(name)
        members = [name]
        if match and match.group(2) == "1":
            stem, n = match.group(1), 1
            while f"{stem}{n + 1}" in present:
                n += 1
            candidates = element_names(stem, n)
            if n >= 2 and len({kind_of(c) for c in candidates}) == 1:
                out.append((stem, candidates))
                taken.update(candidates)
                continue
        out.append((name, members))
        taken.add(name)
    return out
