"""The modelDescription that pythonfmu 0.7 leaves incomplete, completed for ``fmpy validate``,
fmutool and importers: capability flags, units and UnitDefinitions, min/max, exact start values,
``Outputs`` with their declared dependencies and ``InitialUnknowns``."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping
from xml.etree.ElementTree import Element, SubElement

from pythonfmu import Fmi2Causality

# SI base-unit exponents of every unit the FMUs use (FMI 2.0 UnitDefinitions/BaseUnit attributes).
UNIT_BASES: dict[str, dict[str, int]] = {
    "1": {},
    "s": {"s": 1},
    "m": {"m": 1},
    "rad": {"rad": 1},
    "rad/s": {"rad": 1, "s": -1},
    "rad/s2": {"rad": 1, "s": -2},
    "m/s": {"m": 1, "s": -1},
    "m/s2": {"m": 1, "s": -2},
    "N.m": {"kg": 1, "m": 2, "s": -2},
    "kg.m2": {"kg": 1, "m": 2},
    "N.m.s/rad": {"kg": 1, "m": 2, "s": -1, "rad": -1},
    "N.m/rad": {"kg": 1, "m": 2, "s": -2, "rad": -1},
    "1/s": {"s": -1},
    "1/s2": {"s": -2},
}


@dataclass
class VariableMeta:
    """What pythonfmu's variables do not carry: unit, range and (outputs) direct dependencies."""

    unit: str | None
    low: float | None
    high: float | None
    depends_on: tuple[str, ...] | None  # outputs only: the inputs they depend on at the same instant


def _xml_number(x: float) -> str:
    return repr(float(x))  # repr round-trips a double; pythonfmu's 16 digits do not (pi/2)


def complete_model_description(
    root: Element, variables: Mapping[int, object], meta: Mapping[str, VariableMeta], capabilities: Mapping[str, str]
) -> Element:
    """Complete pythonfmu's ``fmiModelDescription`` element in place and return it."""
    cosim = root.find("CoSimulation")
    for flag, value in capabilities.items():
        cosim.set(flag, value)

    index_of = {v.name: i + 1 for i, v in enumerate(variables.values())}
    for var, element in zip(variables.values(), root.find("ModelVariables")):
        m = meta[element.get("name")]
        typed = element[0]
        if typed.tag == "Real" and var.start is not None:
            # an importer applying XML starts must run the same model as the FMU's own defaults
            typed.set("start", _xml_number(var.start))
        if m.unit is not None:
            typed.set("unit", m.unit)
        if m.low is not None:
            typed.set("min", _xml_number(m.low) if typed.tag == "Real" else str(int(m.low)))
        if m.high is not None:
            typed.set("max", _xml_number(m.high) if typed.tag == "Real" else str(int(m.high)))

    unit_defs = Element("UnitDefinitions")
    for unit in sorted({m.unit for m in meta.values() if m.unit is not None}):
        u = SubElement(unit_defs, "Unit", name=unit)
        SubElement(u, "BaseUnit", {k: str(v) for k, v in UNIT_BASES[unit].items()})
    root.insert(list(root).index(cosim) + 1, unit_defs)

    structure = root.find("ModelStructure")
    for child in list(structure):
        structure.remove(child)
    outputs = SubElement(structure, "Outputs")
    initial = SubElement(structure, "InitialUnknowns")
    for v in variables.values():
        if v.causality != Fmi2Causality.output:
            continue
        deps = " ".join(str(index_of[n]) for n in meta[v.name].depends_on)
        SubElement(outputs, "Unknown", index=str(index_of[v.name]), dependencies=deps)
        # at initialization an output may also depend on parameters: leave dependencies open
        SubElement(initial, "Unknown", index=str(index_of[v.name]))
    return root
