"""The shape of a sweep file (``orchestration.sweep.spec``) as a JSON schema, checked like a scenario's
(``orchestration.run.scenario.check_schema``): one line naming the file, the key and what it may be.
What depends on the base scenario or on the stored tuning (parameter names and ranges, the
controllers a sweep runs, the number of points) is checked by ``spec`` after this."""
from __future__ import annotations

from typing import Any

from orchestration.run.scenario import check_schema, dotted

COMBINATIONS = ("grid", "paired", "one-at-a-time")
DISTRIBUTIONS = {"uniform": ("low", "high"), "normal": ("mean", "std"), "loguniform": ("low", "high"),
                 "choice": ("values",)}
TUNINGS = ("best",)  # values of controller_settings.<label>.tuning
MAX_POINTS = 100_000

_NUMBER = {"type": "number", "format": "finite"}
_POSITIVE = {**_NUMBER, "exclusiveMinimum": 0}
_COUNT = {"type": "integer", "minimum": 1, "maximum": MAX_POINTS}
_NUMBERS = {"type": "array", "minItems": 1, "items": _NUMBER}
_RANGE = {"type": "object", "additionalProperties": False, "required": ["start", "stop", "num"],
          "properties": {"start": _NUMBER, "stop": _NUMBER, "num": _COUNT}}
_RANDOM = {
    "type": "object", "additionalProperties": False, "required": ["distribution", "count"],
    "properties": {"distribution": {"enum": list(DISTRIBUTIONS)}, "count": _COUNT, "low": _NUMBER, "high": _NUMBER,
                   "mean": _NUMBER, "std": {**_NUMBER, "minimum": 0}, "values": _NUMBERS},
    "allOf": [{"if": {"required": ["distribution"], "properties": {"distribution": {"const": name}}},
               "then": {"required": list(keys)}} for name, keys in DISTRIBUTIONS.items()],
}
_AXIS = {
    "type": "object", "additionalProperties": False, "required": ["name"],
    "properties": {"name": {"type": "string", "minLength": 1}, "values": {"type": "array", "minItems": 1}, "range": _RANGE,
                   "random": _RANDOM, "scale": {"type": "boolean"}, "group": {"type": "string"}},
    # a controller axis lists controller FMUs (or named entries of controller_settings)
    "if": {"required": ["name"], "properties": {"name": {"const": "controller"}}},
    "then": {"properties": {"values": {"items": {"type": "string", "minLength": 1}}}},
    "else": {"properties": {"values": {"items": _NUMBER}}},
}
_CONTROLLER_SETTINGS = {
    "type": "object",
    "properties": {"fmu": {"type": "string"}, "tuning": {"enum": list(TUNINGS)}, "learning": {"type": "boolean"},
                   "tuning_seed": {"type": "integer"}},
    "additionalProperties": _NUMBER,  # "instance.parameter" = number
}
SWEEP_SCHEMA: dict[str, Any] = {
    "type": "object",
    "additionalProperties": False,
    "required": ["scenario"],
    "properties": {
        "name": {"type": "string", "minLength": 1},
        "description": {"type": "string"},
        "scenario": {"type": "string", "minLength": 1},
        "stop_time": _POSITIVE,
        "combine": {"enum": list(COMBINATIONS)},
        "seed": {"type": "integer", "minimum": 0},
        "time_limit": _POSITIVE,
        "state_bound": _POSITIVE,
        "set": {"type": "object", "additionalProperties": _NUMBER},
        "controller_settings": {"type": "object", "additionalProperties": _CONTROLLER_SETTINGS},
        "axis": {"type": "array", "items": _AXIS},
    },
}


def check_sweep_schema(raw: dict[str, Any], what: str, error: type[Exception]) -> None:
    """``error`` (one line: ``what``, the key, what it may be) if ``raw`` does not have a sweep file's shape."""

    def where(path: list) -> str:
        if len(path) >= 2 and path[0] == "axis":  # an axis by its name, as the file's reader knows it
            spec = raw["axis"][path[1]]
            name = spec.get("name") if isinstance(spec, dict) else None
            head = f"axis {name!r}" if isinstance(name, str) else f"axis {path[1] + 1}"
            return f"{head}: {dotted(path[2:])}" if path[2:] else head
        return dotted(path)

    check_schema(raw, SWEEP_SCHEMA, what, error, where)
