"""The search space of a controller file (docs/benchmark.md): which parameters of a controller FMU from any tool
the tuning protocol of issue 49 explores, and over what.

A controller file's ``[search]`` table names one of the FMU's parameters per entry, with a range ``{ low, high,
log }`` (``log`` false when left out) or a list ``{ choices = [...] }``. Its shape is the JSON schema's
(``scenario.SEARCH_SCHEMA``, checked wherever a controller file is read); what it asks of the FMU is checked here,
against the modelDescription, before any trial runs: a trial that sets a value the FMU refuses fails, and the
protocol would score that as the controller's failure, not the file's. So the rules are those of the file's fixed
``parameters`` (``parameter_check``: a parameter a host may set, of a type a run sets, within its declared range,
whole for an integer), applied to every value the search may suggest: both bounds of a range (each value between
lies within the declared range when they do) and every choice.

The FMU, not the file, decides how a range is searched: a real parameter (FMI 2.0 ``Real``, FMI 3.0 ``Float64``) as
a float, an integer one (``Integer``, ``Int32``) as whole numbers (Optuna's ``suggest_int``), which is why its
bounds must be whole. A port is refused with its own message, before the general one: it is what the controller
reads or writes under the contract, and naming it in the search is a mix-up of the map, not a parameter to fix.
"""
from __future__ import annotations

import difflib
from dataclasses import dataclass

from orchestration.run.parameter_check import WHOLE_TYPES, settable_problem, value_problems
from orchestration.run.ported import element, port_map

# the benchmark tunes a controller by its search space: a file without one has nothing to tune (search_problems
# takes a table as it is, since a scenario or a sweep runs a controller file with none)
NOTHING_SEARCHED = ("search: no parameter to tune; a controller file for the benchmark searches at least one "
                    "([search] Kp = { low = 1.0, high = 1000.0, log = true } or Kp = { choices = [30.0, 60.0] })")


@dataclass(frozen=True)
class Dimension:
    """One parameter the tuning explores: ``kind`` "float" or "int" over [low, high] (on a log scale where ``log``),
    or "choice" among ``choices``. The values are ints for an integer parameter, so that they reach the FMU whole."""

    name: str
    kind: str
    low: float | None = None
    high: float | None = None
    log: bool = False
    choices: tuple[float, ...] = ()


def dimensions(md, table: dict) -> dict[str, Dimension]:
    """The dimensions of a ``[search]`` table that ``search_problems`` passed against the FMU ``md`` describes, in
    the table's order; the parameter's type makes a range "float" or "int"."""
    variables = {v.name: v for v in md.modelVariables}
    found = {}
    for name, entry in table.items():
        whole = variables[name].type in WHOLE_TYPES
        cast = int if whole else float
        if "choices" in entry:
            found[name] = Dimension(name, "choice", choices=tuple(cast(c) for c in entry["choices"]))
        else:
            found[name] = Dimension(name, "int" if whole else "float", cast(entry["low"]), cast(entry["high"]),
                                    bool(entry.get("log", False)))
    return found


def search_problems(md, table: dict, ports: dict[str, str] | None, parameters: dict[str, float] | None) -> list[str]:
    """A line per problem of a schema-valid ``[search]`` table against the FMU ``md`` describes, each naming its key
    (``search.Kp``, ``search.Kp.low``): a variable the FMU lacks, a port of ``ports`` (None: the contract's own
    names the FMU has), a variable a host may not set, one also fixed in ``parameters``, an empty or reversed range,
    a log scale from 0 or below, a value outside the declared range or not whole for an integer."""
    variables = {v.name: v for v in md.modelVariables}
    mapped = {}  # the FMU's variable -> the contract name and map entry that make it a port
    for key, name in port_map(variables, ports).items():
        variable = element(variables, name)
        if variable is not None:
            mapped[variable.name] = f"ports.{key} = '{name}'" if ports else f"the contract's {key}"
    settable = [v.name for v in md.modelVariables if settable_problem(v) is None]
    found = []
    for name, entry in table.items():
        where = f"search.{name}"
        variable = variables.get(name)
        if variable is None:
            found.append(f"{where}: the FMU has no variable '{name}'{_near(name, settable)}")
        elif name in mapped:
            found.append(f"{where}: a port ({mapped[name]}): a search tunes parameters, not what the controller "
                         "reads or writes")
        elif problem := settable_problem(variable):
            found.append(f"{where}: {problem}")
        else:
            found += _value_problems(where, variable, entry, (parameters or {}).get(name))
    return found


def _near(name: str, settable: list[str]) -> str:
    """The FMU's settable parameters whose names are close to ``name`` (case aside), as a hint."""
    by_lower = {n.lower(): n for n in settable}
    near = difflib.get_close_matches(name.lower(), by_lower, n=3, cutoff=0.5)
    return f"; near: {', '.join(by_lower[n] for n in near)}" if near else ""


def _value_problems(where: str, variable, entry: dict, fixed: float | None) -> list[str]:
    """The entry of a settable ``variable``: not fixed as well, a range that holds values (positive ones on a log
    scale), and every value the search may suggest one the FMU takes."""
    found = []
    if fixed is not None:
        found.append(f"{where}: also fixed in parameters ({variable.name} = {fixed:g}): a parameter is searched or "
                     "fixed, not both")
    if "choices" in entry:
        values = {f"{where}.choices[{i}]": value for i, value in enumerate(entry["choices"])}
    else:
        low, high = entry["low"], entry["high"]
        if low >= high:
            found.append(f"{where}: low = {low:g}, high = {high:g}: an empty or reversed range (low < high)")
        if entry.get("log", False) and low <= 0:
            found.append(f"{where}.low = {low:g}: a log scale needs low > 0")
        values = {f"{where}.low": low, f"{where}.high": high}
    return found + [f"{key} = {value:g}: {p}" for key, value in values.items() for p in value_problems(variable, value)]
