"""``sotc-cosim export-ssp``: a scenario as an SSP 1.0 archive (System Structure and Parameterization).

The archive holds:

- ``SystemStructure.ssd``: one system with a component per scenario instance (``source`` =
  ``resources/<Model>.fmu``), each listing its connected Real inputs and all its Real outputs as
  connectors (with units,
  defined in ``ssd:Units`` from the FMUs' UnitDefinitions), the connections of the scenario (the
  same resolution as the master: ``[[connect]]`` links same-named ports), a DefaultExperiment with
  the scenario's start/stop time and, as an Open Simulation Platform annotation, a fixed-step
  algorithm with the scenario's step size;
- ``resources/<Model>.fmu``: the FMUs of the instances that keep every default, once each;
- ``resources/<instance>.fmu``: for an instance with parameters, a *parameterised copy* of its FMU:
  the scenario's values are its start values, in its modelDescription and in
  ``resources/parameter_starts.json``, which the FMU reads when instantiated (``fmi_slave.slave``),
  with a GUID of its own. SSP engines differ in how they apply parameters: ``fmpy.ssp.simulate_ssp``
  ignores the SSD's bindings, ecospy applies a parameter set only when it is named at
  initialisation. An FMU's own start values reach every engine;
- the same values as an inline ``ssd:ParameterBinding`` of each component (SSP 1.0's own way, for
  engines and tools that read bindings; they agree with the copies' start values).

Inputs nothing feeds (the plant's disturbances) are left out of the connectors on purpose:
fmpy 0.3.32's ``fmpy.ssp.ssd.get_connections`` keeps the source found for the previous input when an
input connector has no connection, so it would feed ``d1``/``d2`` with the controller's ``tau2``.
Left out, they keep their start value in every engine.

The XML uses the prefixes ``ssd``/``ssc``/``ssv``/``osp`` literally: libcosim's parser matches element
names with their prefix. The SSD, its inline parameter sets included, validates against the SSP 1.0 schemas
fmpy ships (the archive holds no separate .ssv file).
"""
from __future__ import annotations

import io
import json
import uuid
import zipfile
from pathlib import Path
from xml.etree import ElementTree as ET

from orchestration.outputs import atomic_file
from orchestration.paths import zip_kind
from orchestration.run.scenario import Connection, Scenario, ScenarioError

SSD = "SystemStructure.ssd"  # the archive's system structure, at its root
ARCHIVE = zip_kind("an SSP archive", SSD)  # what export-ssp --out replaces without --force
NS = {
    "ssd": "http://ssp-standard.org/SSP1/SystemStructureDescription",
    "ssc": "http://ssp-standard.org/SSP1/SystemStructureCommon",
    "ssv": "http://ssp-standard.org/SSP1/SystemStructureParameterValues",
    "osp": "http://opensimulationplatform.com/SSP/OSPAnnotations",
}
for _prefix, _uri in NS.items():
    ET.register_namespace(_prefix, _uri)


def _q(tag: str) -> str:
    prefix, name = tag.split(":")
    return f"{{{NS[prefix]}}}{name}"


def resolve_links(scenario: Scenario, model_descriptions: dict) -> list[Connection]:
    """The scenario's connections, resolved exactly as ``orchestration.run.master`` resolves them."""
    def ports(md, causality: str) -> list[str]:
        return [v.name for v in md.modelVariables if v.causality == causality and v.type == "Real"]

    return scenario.resolve_connections(
        {n: ports(md, "output") for n, md in model_descriptions.items()},
        {n: set(ports(md, "input")) for n, md in model_descriptions.items()},
    )


def _parameter_set(instance: str, values: dict[str, float], md) -> ET.Element:
    types = {v.name: v.type for v in md.modelVariables}
    root = ET.Element(_q("ssv:ParameterSet"), {"version": "1.0", "name": f"{instance}-parameters"})
    params = ET.SubElement(root, _q("ssv:Parameters"))
    for name, value in values.items():
        p = ET.SubElement(params, _q("ssv:Parameter"), {"name": name})
        if types[name] == "Integer":
            ET.SubElement(p, _q("ssv:Integer"), {"value": str(int(value))})
        else:
            ET.SubElement(p, _q("ssv:Real"), {"value": repr(float(value))})
    return root


def parameterised_copy(fmu: Path, values: dict[str, float], md) -> bytes:
    """The FMU with ``values`` as its parameters' start values (modelDescription and
    ``resources/parameter_starts.json``) and a GUID derived from the original one and the values."""
    from fmi_slave.slave import PARAMETER_STARTS

    types = {v.name: v.type for v in md.modelVariables}
    starts = {n: int(v) if types[n] == "Integer" else float(v) for n, v in values.items()}
    guid = "{" + str(uuid.uuid5(uuid.NAMESPACE_OID, md.guid + json.dumps(starts, sort_keys=True))) + "}"
    out = io.BytesIO()
    with zipfile.ZipFile(fmu) as src, zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as dst:
        for item in src.infolist():
            data = src.read(item)
            if item.filename == "modelDescription.xml":
                root = ET.fromstring(data)
                root.set("guid", guid)
                for sv in root.iter("ScalarVariable"):
                    if sv.get("name") in starts:
                        next(iter(sv)).set("start", repr(starts[sv.get("name")]))
                data = ET.tostring(root, encoding="utf-8", xml_declaration=True)
            dst.writestr(item, data)
        dst.writestr(f"resources/{PARAMETER_STARTS}", json.dumps(starts, indent=1))
    return out.getvalue()


def _source(inst) -> str:
    """Where a component's FMU lies in the archive: its own copy if it has parameters."""
    return f"resources/{inst.name}.fmu" if inst.parameters else f"resources/{inst.fmu}.fmu"


def _ssd(scenario: Scenario, mds: dict, links: list[Connection]) -> bytes:
    root = ET.Element(_q("ssd:SystemStructureDescription"), {"version": "1.0", "name": scenario.name})
    system = ET.SubElement(root, _q("ssd:System"), {"name": scenario.name,
                                                     "description": scenario.description or scenario.name})
    elements = ET.SubElement(system, _q("ssd:Elements"))
    units: dict[str, dict[str, str]] = {}
    for inst in scenario.instances.values():
        md = mds[inst.name]
        comp = ET.SubElement(elements, _q("ssd:Component"), {
            "name": inst.name, "type": "application/x-fmu-sharedlibrary", "source": _source(inst)})
        connectors = ET.SubElement(comp, _q("ssd:Connectors"))
        fed = {link.input for link in links if link.target == inst.name}
        for v in md.modelVariables:
            if v.type != "Real" or v.causality not in ("input", "output"):
                continue
            if v.causality == "input" and v.name not in fed:
                continue  # see the module docstring: fmpy.ssp would wire it to another input's source
            c = ET.SubElement(connectors, _q("ssd:Connector"), {"name": v.name, "kind": v.causality})
            real = ET.SubElement(c, _q("ssc:Real"))
            if v.unit:
                real.set("unit", v.unit)
                units.setdefault(v.unit, next(
                    ({k: str(getattr(u.baseUnit, k)) for k in ("kg", "m", "s", "A", "K", "mol", "cd", "rad")
                      if getattr(u.baseUnit, k, 0)} for u in md.unitDefinitions if u.name == v.unit), {}))
        if inst.parameters:
            bindings = ET.SubElement(comp, _q("ssd:ParameterBindings"))
            binding = ET.SubElement(bindings, _q("ssd:ParameterBinding"), {"type": "application/x-ssp-parameter-set"})
            ET.SubElement(binding, _q("ssd:ParameterValues")).append(_parameter_set(inst.name, inst.parameters, md))
    connections = ET.SubElement(system, _q("ssd:Connections"))
    for link in links:
        ET.SubElement(connections, _q("ssd:Connection"), {
            "startElement": link.source, "startConnector": link.output,
            "endElement": link.target, "endConnector": link.input})
    if units:
        unit_root = ET.SubElement(root, _q("ssd:Units"))
        for name, base in sorted(units.items()):
            unit = ET.SubElement(unit_root, _q("ssc:Unit"), {"name": name})
            ET.SubElement(unit, _q("ssc:BaseUnit"), base)
    experiment = ET.SubElement(root, _q("ssd:DefaultExperiment"),
                               {"startTime": "0.0", "stopTime": repr(scenario.stop_time)})
    annotations = ET.SubElement(experiment, _q("ssd:Annotations"))
    annotation = ET.SubElement(annotations, _q("ssc:Annotation"), {"type": "com.opensimulationplatform"})
    algorithm = ET.SubElement(annotation, _q("osp:Algorithm"))
    ET.SubElement(algorithm, _q("osp:FixedStepAlgorithm"), {"baseStepSize": repr(scenario.step_size)})
    ET.indent(root)
    return ET.tostring(root, encoding="utf-8", xml_declaration=True)


def export_ssp(scenario: Scenario, fmu_paths: dict[str, Path], out: Path) -> Path:
    """Write ``scenario`` with its FMUs (``fmu_paths``: model -> .fmu) as an SSP 1.0 archive."""
    from fmpy import read_model_description

    missing = sorted({i.fmu for i in scenario.instances.values()} - set(fmu_paths))
    if missing:
        raise ScenarioError(f"no built FMU for {missing}")
    mds = {i.name: read_model_description(str(fmu_paths[i.fmu])) for i in scenario.instances.values()}
    for inst in scenario.instances.values():
        params = {v.name for v in mds[inst.name].modelVariables if v.causality == "parameter"}
        unknown = sorted(set(inst.parameters) - params)
        if unknown:
            raise ScenarioError(f"{inst.name}: {unknown} are not parameters of {inst.fmu}")
    links = resolve_links(scenario, mds)
    out = Path(out)
    with atomic_file(out, "wb") as f, zipfile.ZipFile(f, "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr(SSD, _ssd(scenario, mds, links))
        for model in sorted({i.fmu for i in scenario.instances.values() if not i.parameters}):
            z.write(fmu_paths[model], f"resources/{model}.fmu")
        for inst in scenario.instances.values():
            if inst.parameters:
                z.writestr(_source(inst), parameterised_copy(fmu_paths[inst.fmu], inst.parameters, mds[inst.name]))
    return out
