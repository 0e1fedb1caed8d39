"""A controller file (docs/benchmark.md): a controller FMU from any tool, its port map and its parameters, in a TOML
file of its own that a sweep's ``controller`` axis names like one of our controllers::

    fmu = "vendor/MyController.fmu"   # relative to this file
    ports = { phi1 = "q1", phi2 = "q2", dphi1 = "dq1", dphi2 = "dq2", phi1_d = "q1_ref", phi2_d = "q2_ref", tau1 = "u1", tau2 = "u2" }
    parameters = { Kp = 60.0, Kd = 15.0 }

``ports`` and ``parameters`` may be left out (the FMU's variables of the contract's names, its own defaults). A
``[search]`` table is taken and not read here (it is the tuning search's, issue 49). Its shape is checked by a
JSON schema like every other file, one line naming the file and the key; the FMU against the contract is checked
with the scenario it runs in (``orchestration.compliance.contract.check_scenario``), its messages naming this
file's keys.
"""
from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from orchestration.run.scenario import CONTROLLER, FMU_FILE, PORTS_SCHEMA, Instance, ScenarioError, check_schema
from orchestration.toml_files import read_toml

SUFFIX = ".toml"  # a controller axis value ending so is a controller file (``FMU_FILE``: an FMU file alone)
CONTROLLER_FILE_SCHEMA: dict[str, Any] = {
    "type": "object",
    "additionalProperties": False,
    "required": ["fmu"],
    "properties": {
        "fmu": {"type": "string", "pattern": r"^.+\.fmu$"},
        "ports": PORTS_SCHEMA,
        "parameters": {"type": "object", "propertyNames": {"type": "string", "pattern": r"^[A-Za-z_][A-Za-z0-9_]*$"},
                       "additionalProperties": {"type": "number", "format": "finite"}},
        "search": {"type": "object"},
    },
}


def is_file(value: str) -> bool:
    """Whether a controller named so is a file (a controller file or an FMU file), not one of our models."""
    return value.endswith((SUFFIX, FMU_FILE))


def controller_instance(path: Path, what: str, error: type[Exception] = ScenarioError) -> Instance:
    """The controller instance the file at ``path`` (a controller file, or an FMU file run by the contract's names)
    describes, its FMU's path made absolute from the file's folder; ``what`` names it in every message (``error``,
    one line)."""
    if not path.is_file():
        raise error(f"{what}: {'not a file' if path.exists() else 'no such file'}")
    if path.name.endswith(FMU_FILE):
        return Instance(CONTROLLER, os.path.abspath(path), source=what)
    raw = read_toml(path, what, error)
    check_schema(raw, CONTROLLER_FILE_SCHEMA, what, error)
    fmu = os.path.abspath(path.parent / Path(raw["fmu"]).expanduser())
    parameters = {k: float(v) for k, v in raw.get("parameters", {}).items()}
    return Instance(CONTROLLER, fmu, parameters, ports=dict(raw.get("ports", {})), source=what)
