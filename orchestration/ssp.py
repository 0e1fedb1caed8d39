"""``sotc-cosim export-ssp``: a scenario as an SSP 1.0 archive (System Structure and Parameterization).

The archive holds:

- ``SystemStructure.ssd``: one system with a component per scenario instance (``source`` =
  ``resources/<Model>.fmu``), each listing its connected Real inputs and all its Real outputs as
  connectors (with units,
  defined in ``ssd:Units`` from the FMUs' UnitDefinitions), the connections of the scenario (the
  same resolution as the master: ``[[connect]]`` links same-named ports), a DefaultExperiment with
  the scenario's start/stop time and, as an Open Simulation Platform annotation, a fixed-step
  algorithm with the scenario's step size;
- ``resources/<Model>.fmu``: the FMUs, once each;
- ``resources/<instance>.ssv``: the scenario's parameter values of each instance (an SSV parameter
  set bound to its component; names are the FMU's variable names, as SSP 1.0 specifies for a
  binding without prefix).

Inputs nothing feeds (the plant's disturbances) are left out of the connectors on purpose:
fmpy 0.3.32's ``fmpy.ssp.ssd.get_connections`` keeps the source found for the previous input when an
input connector has no connection, so it would feed ``d1``/``d2`` with the controller's ``tau2``.
Left out, they keep their start value in every engine.

The XML uses the prefixes ``ssd``/``ssc``/``ssv``/``osp`` literally: libcosim's parser matches element
names with their prefix. The SSD and the SSVs validate against the SSP 1.0 schemas fmpy ships.
"""
from __future__ import annotations

import zipfile
from pathlib import Path
from xml.etree import ElementTree as ET

from orchestration.scenario import Connection, Scenario, ScenarioError

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
    """The scenario's connections, resolved exactly as ``orchestration.master`` resolves them."""
    def ports(md, causality: str) -> list[str]:
        return [v.name for v in md.modelVariables if v.causality == causality and v.type == "Real"]

    return scenario.resolve_connections(
        {n: ports(md, "output") for n, md in model_descriptions.items()},
        {n: set(ports(md, "input")) for n, md in model_descriptions.items()},
    )


def _ssv(instance: str, values: dict[str, float], md) -> bytes:
    types = {v.name: v.type for v in md.modelVariables}
    root = ET.Element(_q("ssv:ParameterSet"), {"version": "1.0", "name": f"{instance}-parameters"})
    params = ET.SubElement(root, _q("ssv:Parameters"))
    for name, value in values.items():
        p = ET.SubElement(params, _q("ssv:Parameter"), {"name": name})
        if types[name] == "Integer":
            ET.SubElement(p, _q("ssv:Integer"), {"value": str(int(value))})
        else:
            ET.SubElement(p, _q("ssv:Real"), {"value": repr(float(value))})
    return ET.tostring(root, encoding="utf-8", xml_declaration=True)


def _ssd(scenario: Scenario, mds: dict, links: list[Connection]) -> bytes:
    root = ET.Element(_q("ssd:SystemStructureDescription"), {"version": "1.0", "name": scenario.name})
    system = ET.SubElement(root, _q("ssd:System"), {"name": scenario.name,
                                                     "description": scenario.description or scenario.name})
    elements = ET.SubElement(system, _q("ssd:Elements"))
    units: dict[str, dict[str, str]] = {}
    for inst in scenario.instances.values():
        md = mds[inst.name]
        comp = ET.SubElement(elements, _q("ssd:Component"), {
            "name": inst.name, "type": "application/x-fmu-sharedlibrary", "source": f"resources/{inst.fmu}.fmu"})
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
            ET.SubElement(bindings, _q("ssd:ParameterBinding"), {
                "type": "application/x-ssp-parameter-set", "source": f"resources/{inst.name}.ssv"})
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
    out.parent.mkdir(parents=True, exist_ok=True)
    with zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr("SystemStructure.ssd", _ssd(scenario, mds, links))
        for model in sorted({i.fmu for i in scenario.instances.values()}):
            z.write(fmu_paths[model], f"resources/{model}.fmu")
        for inst in scenario.instances.values():
            if inst.parameters:
                z.writestr(f"resources/{inst.name}.ssv", _ssv(inst.name, inst.parameters, mds[inst.name]))
    return out


def parameter_set_for_fmpy(ssp: Path):
    """The SSD's component parameter bindings as the one prefixed ParameterSet ``fmpy.ssp.simulate_ssp``
    takes: fmpy reads the bindings but never applies them, and expects names '<component>.<variable>'."""
    from fmpy.ssp.ssd import Parameter, ParameterSet, find_components, read_ssd

    merged = ParameterSet(name="bindings")
    for component in find_components(read_ssd(str(ssp)).system):
        for binding in component.parameterBindings:
            for parameter_set in binding.parameterValues:
                for p in parameter_set.parameters:
                    merged.parameters.append(Parameter(name=f"{component.name}.{p.name}", type=p.type, value=p.value))
    return merged
