"""The FMI 3.0 modelDescription of a ``WrappedSlave``, completed from the wrapped FMI 2 class's own
declarations (``fmi_slave.model_description.VariableMeta``): the same units with their SI bases, the
same min/max, start values that round-trip (``repr``), the declared output dependencies, and the
interface flags (pythonfmu3 0.3.4 writes each flag from one leftover value)."""
from __future__ import annotations

from xml.etree.ElementTree import Element, SubElement

from fmi_slave.model_description import UNIT_BASES

_ORDER = ("ModelExchange", "CoSimulation", "ScheduledExecution", "UnitDefinitions", "TypeDefinitions",
          "LogCategories", "DefaultExperiment", "Annotations", "ModelVariables", "ModelStructure")
_INTERFACE_FLAGS = {
    "CoSimulation": ("needsExecutionTool", "canBeInstantiatedOnlyOncePerProcess", "canGetAndSetFMUState",
                     "canSerializeFMUState", "canHandleVariableCommunicationStepSize"),
    "ModelExchange": ("needsExecutionTool", "canBeInstantiatedOnlyOncePerProcess", "canGetAndSetFMUState",
                      "canSerializeFMUState", "needsCompletedIntegratorStep"),
}


def _number(x: float) -> str:
    return repr(float(x))  # round-trips a double (pythonfmu3 writes 16 digits)


def complete_model_description(root: Element, slave, inner) -> Element:
    """Complete pythonfmu3's ``fmiModelDescription`` of ``slave`` (a ``WrappedSlave``) in place."""
    for tag, flags in _INTERFACE_FLAGS.items():
        element = root.find(tag)
        if element is not None:
            for flag in flags:
                element.set(flag, str(slave.OPTIONS[flag]).lower())
    meta, inner_vars = inner._meta, inner.vars
    fmi3_of = {s: vr for vr, scalars in slave._scalars.items() for s in scalars}  # wrapped vr -> FMI 3 vr
    units: set[str] = set()
    for element in root.find("ModelVariables"):
        if element.get("unit"):
            units.add(element.get("unit"))
        vr = int(element.get("valueReference"))
        scalars = [inner_vars[s] for s in slave._scalars.get(vr, ())]
        if not scalars:
            continue
        if element.tag == "Float64" and element.get("start") is not None:  # the values the instance starts with
            element.set("start", " ".join(_number(s.getter()) for s in scalars))
        for key, attr in (("min", "low"), ("max", "high")):
            bounds = {getattr(meta[s.name], attr) for s in scalars}
            if len(bounds) == 1 and None not in bounds:
                bound = bounds.pop()
                element.set(key, _number(bound) if element.tag == "Float64" else str(int(bound)))
    for old in root.findall("UnitDefinitions"):
        root.remove(old)
    unit_defs = Element("UnitDefinitions")
    for unit in sorted(units):
        SubElement(SubElement(unit_defs, "Unit", name=unit), "BaseUnit",
                   {k: str(v) for k, v in UNIT_BASES[unit].items()})
    root.append(unit_defs)
    _structure(root, slave, inner, fmi3_of)
    root[:] = sorted(root, key=lambda e: _ORDER.index(e.tag))  # stable: the schema's element order
    return root


def _structure(root: Element, slave, inner, fmi3_of: dict[int, int]) -> None:
    """Outputs with their declared dependencies (FMI 3 value references of the inputs), the
    state derivatives of a Model Exchange slave, and the initial unknowns."""
    structure = root.find("ModelStructure")
    structure[:] = []
    by_name = {v.name: v for v in inner.vars.values()}
    derivatives = list(getattr(slave, "derivative_references", tuple)())
    outputs = []
    for element in root.find("ModelVariables"):
        if element.get("causality") != "output":
            continue
        vr = int(element.get("valueReference"))
        deps = sorted({fmi3_of[by_name[d].value_reference]
                       for s in slave._scalars[vr] for d in inner._meta[inner.vars[s].name].depends_on})
        SubElement(structure, "Output", valueReference=str(vr), dependencies=" ".join(map(str, deps)))
        outputs.append(vr)
    for vr in derivatives:
        SubElement(structure, "ContinuousStateDerivative", valueReference=str(vr))
    for vr in outputs + [d for d in derivatives if d not in outputs]:
        SubElement(structure, "InitialUnknown", valueReference=str(vr))
