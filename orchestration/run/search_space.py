"""The search space of a tuning search: one ``Dimension`` per design parameter (placeholder: the controller
file's ``[search]`` reading lands beside it)."""
from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Dimension:
    """One searched parameter: ``kind`` "float" or "int" (a range from ``low`` to ``high``, log-scaled if
    ``log``), or "choice" (one of ``choices``)."""

    name: str
    kind: str
    low: float | None = None
    high: float | None = None
    log: bool = False
    choices: tuple[float, ...] = ()


def dimensions(table: dict, md) -> dict[str, Dimension]:
    """Placeholder until the [search] reading lands."""
    types = {v.name: v.type for v in md.modelVariables}
    out = {}
    for name, spec in table.items():
        if "choices" in spec:
            out[name] = Dimension(name, "choice", choices=tuple(spec["choices"]))
        else:
            kind = "int" if types.get(name) in ("Integer", "Int32") else "float"
            out[name] = Dimension(name, kind, float(spec["low"]), float(spec["high"]), bool(spec.get("log", False)))
    return out


def search_problems(md, table: dict, ports, parameters) -> list[str]:
    """Placeholder until the [search] reading lands."""
    return []
