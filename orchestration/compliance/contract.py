"""The controller contract (docs/benchmark.md): what a controller FMU from any tool may read and must write to
take the place of ours, checked against its modelDescription before anything runs (``sotc-cosim
check-controller``).

A controller reads any of the contract's inputs (``fmu_controller.base``: the measurement ``phi1 phi2 dphi1
dphi2`` from the arm, the reference ``phi1_d ... ddphi2_d``) and writes both torques ``tau1 tau2`` in N.m,
as FMI 2.0 or 3.0 Co-Simulation. A port map names the FMU's own variable for each contract name it uses;
without one, the FMU's variables of the contract's names are used. Each mapped variable must exist with
the right causality, be a real (FMI 2 ``Real``, FMI 3 ``Float64``) and, where it declares a unit, carry the
contract's; an element of an FMI 3.0 array of fixed size is named ``name[i]`` (from 1). Contract inputs the FMU
does not read are left out of the map.
"""
from __future__ import annotations

import functools
import math
import zipfile
from dataclasses import dataclass, field
from pathlib import Path

from fmu_controller.ports import CONTRACT_NAMES, INPUT_UNITS, MEASUREMENT_PORTS, REFERENCE_PORTS, TORQUE_PORTS, TORQUE_UNIT
from orchestration.exit_codes import UsageError
from orchestration.run.parameter_check import settable_problem, value_problems
from orchestration.run.ported import ELEMENT, element, port_map
from orchestration.run.scenario import SEARCH_SCHEMA, check_schema
from orchestration.run.search_space import search_problems

INPUTS = MEASUREMENT_PORTS + REFERENCE_PORTS
UNITS = {**INPUT_UNITS, **dict.fromkeys(TORQUE_PORTS, TORQUE_UNIT)}
REALS = ("Real", "Float64")  # FMI 2.0, FMI 3.0
VERSIONS = ("2.0", "3.0")


class ContractError(UsageError):
    """A file that cannot be checked at all (not an FMU, a port map that is not one): one line naming it."""


@dataclass
class Check:
    """What ``check`` found: the map used (contract name -> FMU variable), the parameters to set, the search space
    (a controller file's ``[search]``), the FMU's inputs the map leaves at their start values, and the problems (each
    one line naming the key)."""

    fmu: Path
    ports: dict[str, str]
    parameters: dict[str, float] = field(default_factory=dict)
    search: dict[str, dict] = field(default_factory=dict)
    unfed: list[str] = field(default_factory=list)
    problems: list[str] = field(default_factory=list)


def read_ports(path: Path) -> tuple[dict[str, str] | None, dict[str, float], dict[str, dict]]:
    """The ``ports`` table of a TOML file (contract name -> the FMU's variable name; None without one: the FMU's
    variables of the contract's names), its ``parameters`` table, if any (the FMU's parameter -> a number to
    set it to), and its ``[search]`` table, if any (a controller file's search space, its shape checked by
    ``SEARCH_SCHEMA``); one of the three at least. A controller file (``fmu`` besides) is read so too."""
    from orchestration.toml_files import read_toml

    raw = read_toml(path, str(path), ContractError)
    unknown = sorted(set(raw) - {"ports", "parameters", "fmu", "search"})  # a controller file's keys are read too
    if unknown or not {"ports", "parameters", "search"} & set(raw):
        raise ContractError(f"{path}: a table ports = {{ contract name = \"FMU variable\", ... }} and/or parameters = "
                            f"{{ name = value, ... }} and/or [search]" + (f"; unknown keys {unknown}" if unknown else ""))
    check_schema(raw, {"type": "object", "properties": {"search": SEARCH_SCHEMA}}, str(path), ContractError)
    ports, parameters = raw.get("ports", {}), raw.get("parameters", {})
    if not isinstance(ports, dict):
        raise ContractError(f"{path}: ports: a table {{ contract name = \"FMU variable\", ... }}")
    for key, value in ports.items():
        if key not in CONTRACT_NAMES:
            raise ContractError(f"{path}: ports.{key}: not a contract name ({', '.join(CONTRACT_NAMES)})")
        if not isinstance(value, str) or not value:
            raise ContractError(f"{path}: ports.{key}: the FMU's variable name, a non-empty string")
    if not isinstance(parameters, dict):
        raise ContractError(f"{path}: parameters: a table {{ name = value, ... }}")
    for key, value in parameters.items():
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise ContractError(f"{path}: parameters.{key}: a finite number")
    # no map: the contract's own names
    return dict(ports) or None, {k: float(v) for k, v in parameters.items()}, raw.get("search", {})


def model_description(path: Path):
    """The FMU's parsed modelDescription (``ContractError`` if the file is no FMU that can be read), read once per
    file as it is (a sweep checks each point: one file, many points)."""
    if not path.is_file():
        raise ContractError(f"{path}: {'not a file' if path.exists() else 'no such file'}")
    st = path.stat()
    return _model_description(path, st.st_mtime_ns, st.st_size)


@functools.lru_cache(maxsize=32)
def _model_description(path: Path, mtime_ns: int, size: int):
    from fmpy import read_model_description

    from orchestration.compliance.validate import archive_problems

    unsafe = archive_problems(path)
    if unsafe:
        raise ContractError(f"{path}: {unsafe[0]}")
    version = _declared_version(path)
    if version is not None and version not in VERSIONS:  # fmpy reads FMI 1.0 with other rules, or fails on it
        raise ContractError(f"{path}: FMI {version}: the contract takes FMI {' or '.join(VERSIONS)} Co-Simulation")
    try:
        return read_model_description(str(path), validate=False)
    except Exception as exc:  # noqa: BLE001 - whatever a foreign archive makes fmpy raise, one line
        raise ContractError(f"{path}: cannot read its modelDescription.xml: {exc}") from None


def _declared_version(path: Path) -> str | None:
    """The ``fmiVersion`` its modelDescription.xml declares, or None where it cannot be read so."""
    import xml.etree.ElementTree as ET

    try:
        with zipfile.ZipFile(path) as z:
            return ET.fromstring(z.read("modelDescription.xml")).get("fmiVersion")
    except (OSError, KeyError, zipfile.BadZipFile, ET.ParseError):
        return None


def _binary_problems(path: Path, md) -> list[str]:
    """A Co-Simulation binary for this platform, in the folder each FMI version names it."""
    import fmpy

    platform = fmpy.platform if md.fmiVersion == "2.0" else fmpy.platform_tuple
    name = f"binaries/{platform}/{md.coSimulation.modelIdentifier}{fmpy.sharedLibraryExtension}"
    with zipfile.ZipFile(path) as z:
        if name in z.namelist():
            return []
        folders = sorted({n.split("/")[1] for n in z.namelist() if n.startswith("binaries/") and n.count("/") > 1})
    return [f"no binary for this platform: {name} is missing (binaries for: {', '.join(folders) or 'none'})"]


def _variable_problems(key: str, variable, name: str) -> list[str]:
    want = "output" if key in TORQUE_PORTS else "input"
    where = f"ports.{key} = '{name}'"
    if variable is None:
        return [f"{where}: the FMU has no variable '{name}' (an array's element: name[i], from 1)"]
    found = []
    if getattr(variable, "dimensions", None) and not ELEMENT.fullmatch(name):
        found.append(f"{where}: an array; the contract takes one value: name an element, {name}[i] from 1")
    if variable.causality != want:
        found.append(f"{where}: causality '{variable.causality}', the contract needs an {want}")
    if variable.type not in REALS:
        found.append(f"{where}: type {variable.type}, the contract needs a real (Real / Float64)")
    unit = variable.unit or (variable.declaredType.unit if variable.declaredType is not None else None)
    if unit and unit != UNITS[key]:
        found.append(f"{where}: unit '{unit}', the contract's is '{UNITS[key]}'")
    return found


def _parameter_problems(name: str, value: float, variable) -> list[str]:
    """Whether ``value`` can be set to the FMU's parameter ``name`` before a run: a parameter (fixed or
    tunable) of a numeric type, within its declared min and max, whole for an integer."""
    where = f"parameters.{name} = {value:g}"
    if variable is None:
        return [f"{where}: the FMU has no variable '{name}'"]
    problem = settable_problem(variable)
    if problem:
        return [f"{where}: {problem}"]
    if not math.isfinite(value):  # no FMU is asked to take one (TOML writes nan and inf; 1e400 reads as inf)
        return [f"{where}: not a finite number"]
    return [f"{where}: {p}" for p in value_problems(variable, value)]


def interface_problems(path: Path, md) -> list[str]:
    """An FMI version the contract takes, Co-Simulation, and a binary for this platform."""
    found = []
    if md.fmiVersion not in VERSIONS:
        found.append(f"FMI {md.fmiVersion}: the contract takes FMI {' or '.join(VERSIONS)}")
    if md.coSimulation is None:
        found.append("no Co-Simulation interface (the contract takes Co-Simulation FMUs)")
    else:
        found += _binary_problems(path, md)
    return found


def check(path: Path, ports: dict[str, str] | None = None, parameters: dict[str, float] | None = None,
          search: dict[str, dict] | None = None) -> Check:
    """``path`` against the contract through ``ports`` (None: the contract's own names, those the FMU has),
    ``parameters`` (name -> value) against its parameters, and a schema-valid ``search`` table (``search_space``)."""
    md = model_description(path)
    variables = {v.name: v for v in md.modelVariables}
    mapped = port_map(variables, ports)
    result = Check(path, dict(mapped))
    result.problems += interface_problems(path, md)
    for key in TORQUE_PORTS:
        if key not in mapped:
            result.problems.append(f"ports.{key}: missing; the contract needs both torques {' and '.join(TORQUE_PORTS)}")
    for key, name in mapped.items():
        result.problems += _variable_problems(key, element(variables, name), name)
    for name in sorted({n for n in mapped.values() if list(mapped.values()).count(n) > 1}):
        keys = [k for k, n in mapped.items() if n == name]
        result.problems.append(f"ports.{keys[1]} = '{name}': {name} is mapped to {' and '.join(keys)}; one variable each")
    for name, value in (parameters or {}).items():
        result.problems += _parameter_problems(name, value, variables.get(name))
    result.parameters, result.search = dict(parameters or {}), dict(search or {})
    result.problems += search_problems(md, result.search, ports, parameters)
    fed = {ELEMENT.sub(r"\1", n) for n in mapped.values()}
    result.unfed = [v.name for v in md.modelVariables if v.causality == "input" and v.name not in fed]
    return result


def report(result: Check) -> str:
    """The map, the inputs left at their start values, and a line per problem."""
    lines = [f"{result.fmu}:", *(f"  {k:9s} -> {v}" for k, v in result.ports.items()),
             *(f"  parameter {k} = {v:g}" for k, v in result.parameters.items()),
             *(f"  search {k} {_searched(e)}" for k, e in result.search.items())]
    if result.unfed:
        lines.append(f"  inputs no contract name feeds (left at their start values): {', '.join(result.unfed)}")
    lines += [f"  problem: {p}" for p in result.problems]
    lines.append("  meets the controller contract" if not result.problems else
                 f"  does not meet the controller contract ({len(result.problems)} "
                 f"problem{'s' if len(result.problems) > 1 else ''})")
    return "\n".join(lines)


def _searched(entry: dict) -> str:
    """A ``[search]`` entry as the report says it: ``in [1, 1000], log scale`` or ``among 30, 60``."""
    if "choices" in entry:
        return f"among {', '.join(f'{c:g}' for c in entry['choices'])}"
    return f"in [{entry['low']:g}, {entry['high']:g}]" + (", log scale" if entry.get("log", False) else "")


def check_scenario(scenario) -> None:
    """The FMU files a scenario names, checked before anything runs: the controller's against the contract
    through its port map, with its parameters; any other's that it is an FMU. ``ScenarioError`` in one line
    naming the scenario file and the key, for the first problem found."""
    from orchestration.run.scenario import ScenarioError

    for inst in scenario.instances.values():
        if inst.file is None:
            continue
        # the keys of a controller file (``scenario.controller_instance``) as written there, else the scenario's
        where = f"{inst.source}: " if inst.source else f"{scenario.source or scenario.name}: instances.{inst.name}."
        try:  # a controller against the contract; another instance's file: an FMU that can be read
            problems = check(inst.file, inst.ports or None, inst.parameters).problems if inst.contract else []
            if not inst.contract:
                model_description(inst.file)
        except ContractError as exc:
            raise ScenarioError(f"{where}fmu: {exc}") from None
        if problems:
            first, more = problems[0], len(problems) - 1
            key = first if first.startswith(("ports.", "parameters.")) else f"fmu: {inst.file}: {first}"
            also = f" (and {more} more: sotc-cosim check-controller names them)" if more else ""
            raise ScenarioError(f"{where}{key}{also}")
