"""Hostile controller FMUs, built by the tests from ``hostile_controller.c`` (plain C, FMI 2.0): the
example's PD controller (``examples/pd_controller``) whose fmi2DoStep misbehaves from t = 1.00 s on, under
the contract's own names, so that the master runs one in place of our controller. Compiled and zipped
by the example's own ``build.py`` (imported as a module, pointed at this source and a modelDescription
written from the example's), one FMU per fault."""
from __future__ import annotations

import dataclasses
import importlib.util
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from support.example_controller import BUILD, EXAMPLE, PORTS, compiler

from orchestration.run.scenario import Scenario, load_scenario

SOURCE = Path(__file__).resolve().parent / "hostile_controller.c"
FAULTS = {"segv": 1, "loop": 2, "nan": 3, "error": 4, "exit": 5, "abort": 6}  # HOSTILE_FAULT of the source
FAULT_SAMPLE = 100  # the sample whose doStep (t = 1.00 s) is the first to misbehave
STOP_TIME = 2.0


def identifier(fault: str) -> str:
    return f"Hostile{fault.capitalize()}"


def _description(fault: str, folder: Path) -> Path:
    """The example's modelDescription under the contract's names and this fault's model identifier."""
    tree = ET.parse(EXAMPLE / "modelDescription.xml")
    root = tree.getroot()
    contract = {own: name for name, own in PORTS.items()}
    for variable in root.iter("ScalarVariable"):
        variable.set("name", contract.get(variable.get("name"), variable.get("name")))
    root.set("modelName", identifier(fault))
    root.find("CoSimulation").set("modelIdentifier", identifier(fault))
    path = folder / f"{identifier(fault)}.xml"
    tree.write(path, encoding="UTF-8", xml_declaration=True)
    return path


def build(fault: str, folder: Path, monkeypatch: pytest.MonkeyPatch, sample: int = FAULT_SAMPLE,
          kp_above: float | None = None) -> Path:
    """``<identifier>.fmu`` in ``folder``, built by the example's build.py with ``HOSTILE_FAULT`` set; it misbehaves
    from the doStep of ``sample`` on (at T = 0.01 s), where its gain Kp is above ``kp_above`` if given."""
    cc = compiler()
    if cc is None:
        pytest.skip("no C compiler ($CC, cc or gcc) to build the hostile controller FMUs")
    spec = importlib.util.spec_from_file_location(f"hostile_build_{fault}", BUILD)
    script = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(script)
    script.SOURCE, script.DESCRIPTION, script.IDENTIFIER = SOURCE, _description(fault, folder), identifier(fault)
    start = f" -DFAULT_FROM={sample - 0.5}e-2" if sample != FAULT_SAMPLE else ""  # between two samples
    start += f" -DFAULT_KP_ABOVE={kp_above!r}" if kp_above is not None else ""
    monkeypatch.setenv("CC", f"{cc} -DHOSTILE_FAULT={FAULTS[fault]}{start}")  # build.py takes options in $CC
    return script.build(folder)


def scenario(fault: str) -> Scenario:
    """The paper's scenario for 2 s with the hostile controller in place of ours (its own gains)."""
    return controlled_by(identifier(fault))


def controlled_by(model: str) -> Scenario:
    """The paper's scenario for 2 s with the controller FMU ``model`` in place of ours, with its own defaults."""
    paper = load_scenario("paper")
    instances = {**paper.instances, "controller": dataclasses.replace(paper.instances["controller"], fmu=model,
                                                                      parameters={})}
    return dataclasses.replace(paper, instances=instances).with_stop_time(STOP_TIME)
