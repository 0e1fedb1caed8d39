"""Scenario files: which FMUs, their parameters, how outputs connect to inputs, and for how long.

A scenario is TOML (``orchestration/run/scenarios/<name>.toml``, shipped as package data, or any path):

    name = "paper-ct"
    extends = "paper"                 # optional: start from another scenario, then override
    description = "..."
    stop_time = 100.0                 # s
    step_size = 0.01                  # s, the communication step T
    [instances.controller]
    fmu = "CtController"              # model identifier of a built FMU
    parameters = { kp = 100.0 }
    # or a controller FMU from any tool (docs/benchmark.md): a .fmu path, relative to the scenario file
    # that writes it, and its port map (contract name -> the FMU's variable); its parameters are its own
    # fmu = "vendor/MyController.fmu"
    # ports = { phi1 = "q1", tau1 = "u1", tau2 = "u2" }
    # or a controller file that holds these three (below), relative to the scenario file; parameters here override
    # its own: controller = "mine.toml"
    interface = "CoSimulation"        # optional; "ModelExchange": an FMI 3.0 FMU integrated by the master
    [[connect]]                       # every output of `from` feeds the same-named input of `to`
    from = "plant"
    to = "controller"
    [[connection]]                    # or one explicit link
    from = "reference.x_d"
    to = "other.x_in"

Instances named ``plant``, ``reference`` and ``controller`` are what the summary metrics read. A
``controller`` given as a .fmu file is held to the controller contract: checked against it before anything
runs (``orchestration.compliance.contract.check_scenario``), its ports renamed and its torques bounded by
the actuator (``orchestration.run.ported``). A path is only taken from a scenario file: a shipped scenario
names built FMUs by model.

A controller file (docs/benchmark.md) holds such a controller on its own, for a scenario's ``controller`` key and
a sweep's controller axis, and the search space issue 49's tuning explores (``[search]``)::

    fmu = "vendor/MyController.fmu"   # relative to this file
    ports = { phi1 = "q1", tau1 = "u1", tau2 = "u2" }
    parameters = { umax = 4.0 }
    [search]
    Kp = { low = 1.0, high = 1000.0, log = true }
    Kd = { choices = [5.0, 10.0, 20.0] }

A scenario and a sweep run the fixed ``parameters`` and leave ``[search]`` to the tuning, but its shape is checked
here as the rest of the file is (``SEARCH_SCHEMA``), so a file a sweep took is not refused later by the tuning for
its form; what it asks of the FMU is checked by ``search_space``.
"""
from __future__ import annotations

import math
import os
from dataclasses import dataclass, field, replace
from importlib import resources
from pathlib import Path
from typing import Any, Callable

from fmu_controller.ports import CONTRACT_NAMES
from fmu_plant.paper_setting import STEP_SIZE, TORQUE_LIMIT
from orchestration.exit_codes import UsageError
from orchestration.toml_files import parse_toml, read_toml, unknown_file

# a run holds every sample of every output in memory: 10^6 steps (10,000 s at T = 0.01 s, 100 paper
# runs) of ~60 outputs is ~0.5 GB per instance; more is refused before anything is allocated
MAX_STEPS = 1_000_000
NANOSECOND = 1e-9  # the recordings' time resolution: a step must be a whole number of nanoseconds

_NAME = {"type": "string", "pattern": r"^[A-Za-z_][A-Za-z0-9_-]*$"}
FMU_FILE = ".fmu"  # an instance's ``fmu`` ending so is a file, else the model identifier of a built FMU
CONTROLLER = "controller"  # the instance the controller contract (and the summary's torque) is about
INTERFACES = ("CoSimulation", "ModelExchange")  # an instance's ``interface`` key (FMI 3.0 FMUs may offer both)
_PORT = {"type": "string", "pattern": r"^[A-Za-z_][A-Za-z0-9_-]*\.[A-Za-z_][A-Za-z0-9_]*$"}
_TIME = {"type": "number", "exclusiveMinimum": 0}
# a controller file's port map: contract name -> its variable (docs/benchmark.md)
PORTS_SCHEMA = {"type": "object", "propertyNames": {"enum": list(CONTRACT_NAMES)},
                "additionalProperties": {"type": "string", "minLength": 1}}
CONTROLLER_FILE = ".toml"  # a controller named so is a controller file (``FMU_FILE``: an FMU file alone)
_FINITE = {"type": "number", "format": "finite"}
_PARAMETERS = {"type": "object", "propertyNames": _NAME, "additionalProperties": _FINITE}
# a controller file's search space (orchestration/run/search_space.py checks it against the FMU): per parameter a
# range, or with ``choices`` a list of values; ``if`` picks the form so that a message names that form's keys
SEARCH_SCHEMA = {"type": "object", "propertyNames": _NAME, "additionalProperties": {
    "type": "object",
    "if": {"required": ["choices"]},
    "then": {"additionalProperties": False, "properties": {
        "choices": {"type": "array", "items": _FINITE, "minItems": 2, "uniqueItems": True}}},
    "else": {"additionalProperties": False, "required": ["low", "high"],
             "properties": {"low": _FINITE, "high": _FINITE, "log": {"type": "boolean"}}},
}}
CONTROLLER_FILE_SCHEMA: dict[str, Any] = {
    "type": "object",
    "additionalProperties": False,
    "required": ["fmu"],
    "properties": {"fmu": {"type": "string", "pattern": r"^.+\.fmu$"}, "ports": PORTS_SCHEMA, "parameters": _PARAMETERS,
                   "search": SEARCH_SCHEMA},
}
# one scenario file as written (``extends`` resolved later, so nothing is required here but shapes)
SCENARIO_SCHEMA: dict[str, Any] = {
    "type": "object",
    "additionalProperties": False,
    "properties": {
        "name": _NAME,
        "extends": {"type": "string", "minLength": 1},
        "description": {"type": "string"},
        "stop_time": _TIME,
        "step_size": _TIME,
        "instances": {
            "type": "object",
            "propertyNames": _NAME,
            "additionalProperties": {
                "type": "object",
                "additionalProperties": False,
                "properties": {
                    "fmu": {"type": "string", "pattern": r"^([A-Za-z_][A-Za-z0-9_-]*|.+\.fmu)$"},
                    "controller": {"type": "string", "pattern": r"^.+\.toml$"},
                    "ports": PORTS_SCHEMA,
                    "parameters": {"type": "object", "propertyNames": _NAME,
                                   "additionalProperties": {"type": "number"}},
                    "interface": {"enum": list(INTERFACES)},
                },
            },
        },
        "connect": {"type": "array", "items": {
            "type": "object", "additionalProperties": False, "required": ["from", "to"],
            "properties": {"from": _NAME, "to": _NAME}}},
        "connection": {"type": "array", "items": {
            "type": "object", "additionalProperties": False, "required": ["from", "to"],
            "properties": {"from": _PORT, "to": _PORT}}},
    },
}


class ScenarioError(UsageError):
    """A scenario that cannot be run as written; the message says where and why."""


@dataclass(frozen=True)
class Instance:
    name: str
    fmu: str
    parameters: dict[str, float] = field(default_factory=dict)
    # "ModelExchange": an FMI 3.0 FMU's Model Exchange interface, integrated by the master over each T
    interface: str = "CoSimulation"
    # a controller from a file: contract name -> its variable (empty: its variables of the contract's names)
    ports: dict[str, str] = field(default_factory=dict)
    # the controller file (``controller_instance``) it was read from, as the check's messages name it; empty: the scenario
    source: str = ""

    @property
    def file(self) -> Path | None:
        """The FMU file this instance runs (an absolute path), or None for a built FMU of ours."""
        return Path(self.fmu) if self.fmu.endswith(FMU_FILE) else None

    @property
    def contract(self) -> bool:
        """Held to the controller contract: the controller instance, from a file (ours bound themselves)."""
        return self.name == CONTROLLER and self.file is not None


@dataclass(frozen=True)
class Connection:
    source: str  # instance
    output: str
    target: str  # instance
    input: str


@dataclass(frozen=True)
class Scenario:
    name: str
    description: str
    stop_time: float
    step_size: float
    instances: dict[str, Instance]
    by_name: tuple[tuple[str, str], ...]  # (from instance, to instance): connect same-named ports
    links: tuple[Connection, ...]  # explicit connections
    source: str = ""  # the scenario file or shipped name it was loaded from (what its errors name)

    @property
    def steps(self) -> int:
        return int(round(self.stop_time / self.step_size))

    def with_stop_time(self, stop_time: float) -> "Scenario":
        return _validated({**self.__dict__, "stop_time": stop_time})

    def with_step_size(self, step_size: float) -> "Scenario":
        return _validated({**self.__dict__, "step_size": step_size})

    def with_parameters(self, overrides: dict[str, float], name: str | None = None) -> "Scenario":
        """A copy with ``{"instance.parameter": value}`` overrides (an unknown parameter name is
        refused later, by the FMU's modelDescription, when the run loads it)."""
        instances = dict(self.instances)
        for key, value in overrides.items():
            inst_name, _, pname = key.partition(".")
            if inst_name not in instances or not pname:
                raise ScenarioError(
                    f"scenario '{self.name}': override '{key}' must be instance.parameter with an instance "
                    f"in {sorted(instances)}"
                )
            inst = instances[inst_name]
            instances[inst_name] = replace(inst, parameters={**inst.parameters, pname: value})
        return _validated({**self.__dict__, "instances": instances, "name": name or self.name})

    def controller_fmu(self) -> str | None:
        """The controller's model, or the name of its FMU file."""
        inst = self.instances.get(CONTROLLER)
        return (inst.file.name if inst.file else inst.fmu) if inst else None

    def resolve_connections(self, outputs: dict[str, list[str]], inputs: dict[str, set[str]]) -> list[Connection]:
        """Every output -> input link of the scenario, given each instance's Real outputs and its
        inputs (from its modelDescription). ``[[connect]]`` pairs link same-named ports and must
        match at least one; an unknown port or an input fed twice is refused."""
        resolved: list[Connection] = []
        fed: dict[tuple[str, str], str] = {}

        def add(c: Connection) -> None:
            where = f"connection {c.source}.{c.output} -> {c.target}.{c.input}"
            if c.output not in outputs[c.source]:
                raise ScenarioError(f"{where}: {c.source} has no Real output '{c.output}'")
            if c.input not in inputs[c.target]:
                raise ScenarioError(f"{where}: {c.target} has no input '{c.input}'")
            if (c.target, c.input) in fed:
                raise ScenarioError(f"input {c.target}.{c.input} is fed twice: from {fed[(c.target, c.input)]} "
                                    f"and {c.source}.{c.output}")
            fed[(c.target, c.input)] = f"{c.source}.{c.output}"
            resolved.append(c)

        for src, dst in self.by_name:
            matched = [n for n in outputs[src] if n in inputs[dst]]
            # a controller from a file reads what its port map names: a group it leaves out is not fed
            if not matched and not (self.instances[dst].contract or self.instances[src].contract):
                raise ScenarioError(f"[[connect]] {src} -> {dst}: no output of {src} matches an input of {dst}")
            for name in matched:
                add(Connection(src, name, dst, name))
        for c in self.links:
            add(c)
        return resolved

    def torque_limit(self) -> float:
        """The controller's torque bound ``rho`` as the scenario sets it, else the paper's rho = 4 N.m
        (section 4), which every controller FMU uses by default. A controller from a file is held to the
        paper's: a parameter of its own named ``rho`` sets nothing of the harness (it would set its own bound)."""
        inst = self.instances.get(CONTROLLER)
        params = inst.parameters if inst and not inst.contract else {}
        return float(params.get("rho", TORQUE_LIMIT))


def available_scenarios() -> list[str]:
    folder = resources.files("orchestration.run.scenarios")
    return sorted(p.name[:-5] for p in folder.iterdir() if p.name.endswith(".toml"))


def _read_raw(name_or_path: str, seen: tuple[str, ...] = ()) -> dict[str, Any]:
    path = Path(name_or_path)
    resource = resources.files("orchestration.run.scenarios") / f"{name_or_path}.toml"
    if path.suffix == ".toml" and path.is_file():
        label, read, folder = str(path), lambda where: read_toml(path, where, ScenarioError), path.parent
    elif resource.is_file():
        label, read, folder = name_or_path, lambda where: parse_toml(resource.read_bytes(), where, ScenarioError), None
    else:
        raise unknown_file(name_or_path, "scenario", available_scenarios(), ScenarioError)
    if label in seen:
        raise ScenarioError(f"scenario '{label}' extends itself through {' -> '.join(seen)}")
    raw = read(f"scenario '{label}'")
    check_schema(raw, SCENARIO_SCHEMA, f"scenario '{label}'")
    _files_from(raw, folder, label)
    parent = raw.pop("extends", None)
    if parent is None:
        return raw
    if folder is not None and parent.endswith(".toml") and not Path(parent).is_absolute():
        parent = os.path.normpath(folder / parent)  # relative to the file that writes it, as its fmu paths are
    return _merge(_read_raw(parent, seen + (label,)), raw)


_KINDS = {"number": "a number", "integer": "a whole number", "string": "a string", "boolean": "true or false",
          "object": "a table", "array": "a list"}


def check_schema(raw: dict[str, Any], schema: dict[str, Any], what: str, error: type[Exception] = ScenarioError,
                 where: Callable[[list], str] | None = None) -> None:
    """Refuse a file whose shape is wrong in one line naming the file (``what``), the key (``where`` of
    its path; default dotted) and what it may be (the first error). ``"format": "finite"`` refuses
    nan and inf."""
    from jsonschema import Draft202012Validator, FormatChecker
    from jsonschema.exceptions import best_match

    formats = FormatChecker(formats=())
    formats.checks("finite")(lambda value: not isinstance(value, float) or math.isfinite(value))
    found = best_match(Draft202012Validator(schema, format_checker=formats).iter_errors(raw))
    if found is not None:
        key = (where or dotted)(list(found.absolute_path))
        raise error(f"{what}: {key or 'the file'}: {_schema_message(found)}")


def dotted(path: list) -> str:
    """A key's path as written in TOML: ``axis[0].range.stop``, ``set."plant.f1"``."""
    return "".join(f"[{p}]" if isinstance(p, int) else (f'."{p}"' if "." in p else f".{p}") for p in path).lstrip(".")


def _schema_message(found) -> str:
    value, rule = found.instance, found.validator
    if rule == "pattern":
        also = f", or a path ending in {FMU_FILE}" if list(found.absolute_path)[-1:] == ["fmu"] else ""
        return f"{value!r} is not a name (letters, digits, _ and -; 'instance.port' for a port{also})"
    if rule == "exclusiveMinimum":
        return f"{value!r} must be a number > 0"
    if rule == "format":
        return f"{value!r} is not finite"
    if rule == "minItems":
        return f"{value!r}: at least {found.validator_value} value{'s' if found.validator_value > 1 else ''}"
    if rule == "uniqueItems":
        return f"{value!r}: each value once"
    if rule == "type" and isinstance(found.validator_value, str):
        return f"{value!r} is not {_KINDS.get(found.validator_value, found.validator_value)}"
    if rule == "additionalProperties":
        known = sorted(found.schema.get("properties", {}))
        return f"unknown keys {sorted(set(value) - set(known))}; known: {known}"
    return found.message if len(found.message) <= 200 else found.message[:200] + "..."


def is_file(controller: str) -> bool:
    """Whether a controller named so is a file (a controller file or an FMU file), not one of our models."""
    return controller.endswith((CONTROLLER_FILE, FMU_FILE))


def controller_instance(path: Path, what: str, error: type[Exception] = ScenarioError) -> Instance:
    """The controller the file at ``path`` describes: a controller file, or an FMU file run by the contract's names
    with its own defaults; ``what`` names it in every message (``error``, one line), the contract's check's too."""
    if path.name.endswith(FMU_FILE) and path.is_file():
        return _instance(CONTROLLER, {"fmu": os.path.abspath(path), "source": what})
    return _instance(CONTROLLER, _controller_file(path, what, error))


def _controller_file(path: Path, what: str, error: type[Exception] = ScenarioError) -> dict[str, Any]:
    """A controller file as an instance's table: its ``fmu`` made absolute from its folder, and ``source``."""
    if not path.is_file():
        raise error(f"{what}: {'not a file' if path.exists() else 'no such file'}")
    raw = read_toml(path, what, error)
    check_schema(raw, CONTROLLER_FILE_SCHEMA, what, error)
    return {"fmu": os.path.abspath(path.parent / Path(raw["fmu"]).expanduser()), "ports": raw.get("ports", {}),
            "parameters": raw.get("parameters", {}), "source": what}


def _files_from(raw: dict[str, Any], folder: Path | None, label: str) -> None:
    """Each ``fmu`` that is a file made absolute from ``folder``, the scenario file's own (None: a shipped
    scenario, which names built FMUs only); a ``controller`` file read into its instance's table, whose
    ``parameters`` override the file's."""
    for name, spec in raw.get("instances", {}).items():
        if "controller" in spec:
            where = f"scenario '{label}': instances.{name}.controller"
            if name != CONTROLLER or folder is None or {"fmu", "ports"} & set(spec):
                raise ScenarioError(f"{where}: a controller file is for instances.{CONTROLLER} of a scenario file, "
                                    "in place of its fmu and ports")
            value = spec.pop("controller")
            own = _controller_file(folder / Path(value).expanduser(), f"{where} = {value!r}")
            spec.update({**own, "parameters": {**own["parameters"], **spec.get("parameters", {})}})
            continue
        fmu = spec.get("fmu", "")
        if not fmu.endswith(FMU_FILE):
            continue
        if folder is None:
            raise ScenarioError(f"scenario '{label}': instances.{name}.fmu: a shipped scenario names a built FMU "
                                "by model, not a file")
        spec["fmu"] = os.path.abspath(folder / Path(fmu).expanduser())


def _merge(base: dict[str, Any], override: dict[str, Any]) -> dict[str, Any]:
    """Deep-merge tables; an instance whose ``fmu`` changes starts from that FMU's defaults: its parameters
    and its port map are not carried over."""
    out = dict(base)
    for key, value in override.items():
        if key == "instances":
            merged = dict(base.get("instances", {}))
            for inst, spec in value.items():
                old = merged.get(inst, {})
                if "fmu" in spec and spec["fmu"] != old.get("fmu"):
                    old = {}
                merged[inst] = {**old, **spec, "parameters": {**old.get("parameters", {}), **spec.get("parameters", {})}}
            out["instances"] = merged
        else:
            out[key] = value
    return out


def load_scenario(name_or_path: str) -> Scenario:
    raw = _read_raw(name_or_path)
    raw.setdefault("name", Path(name_or_path).stem)
    try:
        return _validated({**_from_raw(raw), "source": name_or_path})
    except ScenarioError as exc:
        if raw["name"] == name_or_path:
            raise
        raise ScenarioError(f"{name_or_path}: {exc}") from None


def _from_raw(raw: dict[str, Any]) -> dict[str, Any]:
    known = {"name", "description", "stop_time", "step_size", "instances", "connect", "connection"}
    unknown = set(raw) - known
    if unknown:
        raise ScenarioError(f"scenario '{raw['name']}': unknown keys {sorted(unknown)}; known: {sorted(known)}")
    instances = {}
    for name, spec in raw.get("instances", {}).items():
        if "fmu" not in spec:
            raise ScenarioError(f"scenario '{raw['name']}': instance '{name}' needs an 'fmu' key")
        instances[name] = _instance(name, spec)
        if instances[name].ports and not instances[name].contract:
            raise ScenarioError(f"scenario '{raw['name']}': instances.{name}.ports: a port map is for a controller "
                                f"from a file (instances.{CONTROLLER}.fmu = \"....fmu\")")
    links = []
    for item in raw.get("connection", []):
        try:
            src, out = item["from"].split(".", 1)
            dst, inp = item["to"].split(".", 1)
        except (KeyError, ValueError):
            raise ScenarioError(f"scenario '{raw['name']}': a [[connection]] needs from = 'inst.output', to = 'inst.input'") from None
        links.append(Connection(src, out, dst, inp))
    by_name = tuple((c["from"], c["to"]) for c in raw.get("connect", []))
    return {
        "name": raw["name"],
        "description": raw.get("description", ""),
        "stop_time": raw.get("stop_time", 100.0),
        "step_size": raw.get("step_size", STEP_SIZE),
        "instances": instances,
        "by_name": by_name,
        "links": tuple(links),
    }


def _instance(name: str, spec: dict[str, Any]) -> Instance:
    return Instance(name, spec["fmu"], dict(spec.get("parameters", {})), spec.get("interface", INTERFACES[0]),
                    dict(spec.get("ports", {})), spec.get("source", ""))


def _validated(fields: dict[str, Any]) -> Scenario:
    name = fields["name"]
    for key in ("stop_time", "step_size"):
        value = fields[key]
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value <= 0:
            raise ScenarioError(f"scenario '{name}': {key} must be a finite number > 0, got {value!r}")
    step_ns = fields["step_size"] / NANOSECOND
    if step_ns < 1.0 or abs(step_ns - round(step_ns)) > 1e-3:
        raise ScenarioError(f"scenario '{name}': step_size {fields['step_size']!r} must be a whole number of "
                            "nanoseconds (the recordings' time unit), at least 1e-09 s")
    steps = fields["stop_time"] / fields["step_size"]
    if steps > MAX_STEPS:
        raise ScenarioError(f"scenario '{name}': stop_time / step_size = {steps:.6g} steps; at most {MAX_STEPS:,} "
                            "per run are allowed (a bound on how long one run may go on; run and sweep stream their samples, "
                            "compare and reproduce keep them in memory)")
    if round(steps) < 1:
        raise ScenarioError(f"scenario '{name}': stop_time {fields['stop_time']!r} is shorter than one step of "
                            f"{fields['step_size']!r}")
    if abs(steps - round(steps)) > 1e-9 * max(1.0, steps):
        raise ScenarioError(
            f"scenario '{name}': stop_time {fields['stop_time']} is not a whole number of steps of {fields['step_size']}"
        )
    if not fields["instances"]:
        raise ScenarioError(f"scenario '{name}': no instances; give at least one [instances.<name>] with an fmu")
    for src, dst in fields["by_name"]:
        for inst in (src, dst):
            if inst not in fields["instances"]:
                raise ScenarioError(f"scenario '{name}': [[connect]] names unknown instance '{inst}'")
    for link in fields["links"]:
        for inst in (link.source, link.target):
            if inst not in fields["instances"]:
                raise ScenarioError(f"scenario '{name}': [[connection]] names unknown instance '{inst}'")
    for inst in fields["instances"].values():
        for pname, value in inst.parameters.items():
            if not isinstance(value, (int, float)) or isinstance(value, bool):
                raise ScenarioError(f"scenario '{name}': {inst.name}.{pname} must be a number, got {value!r}")
    return Scenario(**{**fields, "stop_time": float(fields["stop_time"]), "step_size": float(fields["step_size"])})
