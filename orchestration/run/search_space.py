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
