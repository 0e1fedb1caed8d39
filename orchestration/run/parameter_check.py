"""Scenario parameters checked against the FMUs' modelDescriptions before anything runs.

Every parameter an FMU declares carries its type and valid [min, max] in the modelDescription. A
value that is not a parameter, not whole for an Integer, or outside that range would otherwise
only be refused by the FMU at ``fmi2ExitInitializationMode``, after the FMUs were loaded (or a Dask
cluster started and a failed point stored). ``check_scenarios`` refuses it up front with one
``ScenarioError`` naming the scenario, the instance, the parameter, the value and the range.
"""
from __future__ import annotations

import math
from functools import lru_cache
from pathlib import Path
from typing import Any

from fmu_controller.base import RENAMED_PARAMETERS
from orchestration.run.scenario import Scenario, ScenarioError


@lru_cache(maxsize=64)
def _model_description(path: str, mtime_ns: int):
    from fmpy import read_model_description

    return read_model_description(path)


def model_description(fmu: Path):
    """The modelDescription of ``fmu`` (cached while the file is unchanged); ``ScenarioError`` if it
    is no readable FMU."""
    try:
        return _model_description(str(fmu), Path(fmu).stat().st_mtime_ns)
    except Exception as exc:  # fmpy raises zip, XML and its own errors alike
        raise ScenarioError(f"{fmu}: not a readable FMU ({type(exc).__name__}: {exc})") from None


SETTABLE_TYPES = ("Real", "Integer", "Float64", "Int32")  # the parameter types the master sets (FMI 2.0, 3.0)
WHOLE_TYPES = ("Integer", "Int32")
SETTABLE_VARIABILITIES = ("fixed", "tunable")  # a parameter's, set before initialization (FMI 2.0 section 2.2.7)


def settable_problem(variable) -> str | None:
    """Why a host may not set ``variable`` before a run, or None: the one rule of a controller file's ``parameters``
    and of its ``[search]`` (orchestration/run/search_space.py), so that what the check lets through a run can set."""
    if variable.causality != "parameter" or variable.variability not in SETTABLE_VARIABILITIES:
        return (f"causality '{variable.causality}', variability '{variable.variability}': not a parameter a host may "
                "set (a fixed or tunable parameter)")
    if variable.type not in SETTABLE_TYPES:  # what the master's runs can set
        return f"type {variable.type}: a run sets parameters of type {', '.join(SETTABLE_TYPES)} only"
    return None


def declared_range(variable) -> tuple[float, float]:
    """The [min, max] its modelDescription declares, -inf or inf where it declares none."""
    low, high = (float(b) if b not in (None, "") else None for b in (variable.min, variable.max))
    return -math.inf if low is None else low, math.inf if high is None else high


def value_problems(variable, value: float) -> list[str]:
    """Why a settable parameter cannot take the finite ``value``: not whole for an integer, outside the range its
    modelDescription declares (one line each, without the key: the caller names it)."""
    found = []
    if variable.type in WHOLE_TYPES and value != int(value):
        found.append(f"{variable.name} is an integer ({variable.type})")
    low, high = declared_range(variable)
    if not low <= value <= high:
        found.append(f"outside [{low:g}, {high:g}], the range its modelDescription declares")
    return found


def parameter_problem(md, name: str, value: float, check_range: bool = True) -> str | None:
    """Why ``value`` cannot be given to parameter ``name`` of the FMU described by ``md``, or None.
    ``check_range=False``: name and type only, the range is left to the FMU (the master's own
    check, so that an API caller still sees the FMU's refusal as a failed run)."""
    var = next((v for v in md.modelVariables if v.name == name), None)
    if var is None or var.causality != "parameter":
        known = sorted(v.name for v in md.modelVariables if v.causality == "parameter")
        if RENAMED_PARAMETERS.get(name) in known:
            return f"'{name}' was renamed '{RENAMED_PARAMETERS[name]}' in 0.2.0 (see CHANGELOG.md)"
        return f"'{name}' is not a parameter of {md.modelName}; known: {', '.join(known)}"
    if var.type not in SETTABLE_TYPES:
        return f"'{name}': parameters of type {var.type} are not supported"
    if var.type in WHOLE_TYPES and (not math.isfinite(value) or float(value) != int(value)):
        return f"'{name}' must be a whole number, got {value!r}"
    if not check_range:
        return None
    low, high = declared_range(var)
    if not low <= float(value) <= high:
        return f"'{name}' = {value!r} is outside its valid range [{var.min}, {var.max}]"
    return None


def check_scenarios(scenarios: list[Scenario], fmu_paths: dict[str, Path]) -> None:
    """Raise ScenarioError for the first parameter value any FMU would refuse."""
    for scenario in scenarios:
        for inst in scenario.instances.values():
            if inst.fmu not in fmu_paths:
                continue  # the master says which FMU is missing
            md = model_description(fmu_paths[inst.fmu])
            for name, value in inst.parameters.items():
                problem = parameter_problem(md, name, value)
                if problem:
                    raise ScenarioError(f"scenario '{scenario.name}', instance '{inst.name}': {problem}")


def parameter_values(md, getters: dict[str, Any]) -> dict[str, float]:
    """Every parameter of a type in ``getters`` (type name -> the FMU's getter) as the instance holds it."""
    return {v.name: getters[v.type]([v.valueReference])[0] for v in md.modelVariables
            if v.causality == "parameter" and v.type in getters}


def set_parameters(md, instance: str, values: dict[str, float], setters: dict[str, Any]) -> None:
    """Set parameters by name, each checked first (``parameter_problem``; ScenarioError naming the
    instance); ``setters``: type name -> (the FMU's setter, the Python type it takes)."""
    by_name = {v.name: v for v in md.modelVariables}
    for pname, value in values.items():
        problem = parameter_problem(md, pname, value, check_range=False)
        if problem:
            raise ScenarioError(f"{instance}: {problem}")
        var = by_name[pname]
        setter, kind = setters[var.type]
        setter([var.valueReference], [kind(value)])
