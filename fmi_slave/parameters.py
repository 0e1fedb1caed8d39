"""Validated parameter sets: one table per component gives default, unit, range and description.

The same table drives the pure core (``validate``), the FMU's modelDescription (units, min/max,
descriptions) and the FMU's refusal messages, so a range is written exactly once.
"""
from __future__ import annotations

import math
from dataclasses import dataclass


class ParameterError(ValueError):
    """An invalid parameter value; the message names the parameter and its valid range."""

    def __init__(self, name: str, message: str):
        super().__init__(f"parameter '{name}': {message}")
        self.name = name


@dataclass(frozen=True)
class ParameterSpec:
    """One parameter: its default, unit, closed/open range and description.

    ``low_open``/``high_open`` make the bound strict (e.g. an inertia must be > 0, not >= 0).
    """

    name: str
    default: float
    unit: str
    description: str
    low: float = -math.inf
    high: float = math.inf
    low_open: bool = False
    high_open: bool = False
    integer: bool = False  # an integer code: an FMI Integer variable, refused unless whole

    def range_text(self) -> str:
        left = "(" if self.low_open or math.isinf(self.low) else "["
        right = ")" if self.high_open or math.isinf(self.high) else "]"
        return f"{left}{_fmt(self.low)}, {_fmt(self.high)}{right}"

    def check(self, value: float) -> float:
        """Return ``value`` as float or raise ParameterError naming this parameter and its range."""
        try:
            value = float(value)
        except (TypeError, ValueError):
            raise ParameterError(self.name, f"{value!r} is not a number; valid range {self.range_text()}") from None
        if not math.isfinite(value):
            raise ParameterError(self.name, f"{value} is not finite; valid range {self.range_text()}")
        too_low = value <= self.low if self.low_open else value < self.low
        too_high = value >= self.high if self.high_open else value > self.high
        if too_low or too_high:
            raise ParameterError(self.name, f"{value:g} is outside the valid range {self.range_text()}")
        if self.integer and value != int(value):
            raise ParameterError(self.name, f"{value:g} is not an integer; valid codes {self.range_text()}")
        return value


def _fmt(x: float) -> str:
    if math.isinf(x):
        return "-inf" if x < 0 else "inf"
    return f"{x:g}"


def positive(name: str, default: float, unit: str, description: str, high: float = math.inf) -> ParameterSpec:
    """A strictly positive parameter (inertia, length, gain, ...)."""
    return ParameterSpec(name, default, unit, description, low=0.0, high=high, low_open=True)


def nonnegative(name: str, default: float, unit: str, description: str, high: float = math.inf) -> ParameterSpec:
    return ParameterSpec(name, default, unit, description, low=0.0, high=high)


def any_real(name: str, default: float, unit: str, description: str) -> ParameterSpec:
    return ParameterSpec(name, default, unit, description)


def integer_code(name: str, default: int, count: int, description: str) -> ParameterSpec:
    """An integer switch with codes 0 .. count - 1 (FMI Integer; the description lists the codes)."""
    return ParameterSpec(name, float(default), "1", description, low=0.0, high=float(count - 1), integer=True)


def check_all(specs: tuple[ParameterSpec, ...], values: dict[str, float]) -> dict[str, float]:
    """Check every value against its spec; unknown names are refused too."""
    by_name = {s.name: s for s in specs}
    for name in values:
        if name not in by_name:
            raise ParameterError(name, f"unknown parameter; known: {', '.join(by_name)}")
    return {s.name: s.check(values.get(s.name, s.default)) for s in specs}
