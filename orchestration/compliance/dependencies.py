"""The ``starts`` and ``dependencies`` checks of ``validate``, by experiment on an instance of the FMU.

Right after initialization and after one step, perturbing an input and reading the outputs at the same
instant must leave every output that does not declare that input exactly unchanged, restoring the input
must restore the outputs, and each output that declares dependencies must change for some perturbation of
them (unless it stays at rounding level, |y| <= ROUNDING_LEVEL, in every probe: a solver residual such as
the SOTC's ``zv_residual`` may then be exactly 0 whatever the inputs); and a fresh instance must hold
exactly the start values of the XML. Run as ``python -m orchestration.compliance.dependencies FMU``, this
module is the child process the experiment runs in (``children``): it prints the start and the dependency
problems as JSON.
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

from fmu_plant.dynamics import STEP_SIZE  # the paper's sampling period T
from orchestration.compliance import children
from orchestration.compliance.core_paths import drive, same

# inputs are at their start values at t = 0, then follow a smooth signal around them; at each probe
# instant (after that many steps) every input is perturbed in turn by each of PERTURBATIONS
PROBE_STEPS = (0, 1, 10, 40)
PERTURBATIONS = (0.05, -0.7, 3.0, -30.0)
ROUNDING_LEVEL = 1e-12  # an output never above this in the dependency probes cannot show its dependencies


def _start_problems(fmu, md) -> list[str]:
    """The start values in the XML must be exactly what a fresh instance holds (bitwise): an importer
    that applies XML starts (libcosim does) must not end up with a different model."""
    problems = []
    for v in md.modelVariables:
        if v.start is None or v.causality not in ("parameter", "input") or v.type not in ("Real", "Integer"):
            continue
        if v.type == "Real":
            actual, declared = fmu.getReal([v.valueReference])[0], float(v.start)
        else:
            actual, declared = fmu.getInteger([v.valueReference])[0], int(v.start)
        if not same(float(actual), float(declared)):
            problems.append(f"'{v.name}': start {v.start!r} in the XML, {actual!r} in a fresh instance")
    return problems


def experiment(path: Path, start_problems: list[str]) -> list[str]:
    """The dependency problems of the FMU at ``path``; its start problems are added to ``start_problems``.
    FMI 3.0 FMUs are driven element by element, in FMI 2 terms (``fmi3_direct``)."""
    from fmpy.fmi1 import FMICallException

    try:
        instance = children.open_instance(path, "validate")
    except Exception as exc:
        return [f"the experiment could not instantiate the FMU: {exc}"]
    fmu, md = instance.fmu, instance.md
    inputs = [v for v in md.modelVariables if v.causality == "input" and v.type == "Real"]
    outputs = [u for u in md.outputs if u.variable.type == "Real"]
    problems: list[str] = []
    changed_by_declared = {u.variable.name: False for u in outputs}
    largest = {u.variable.name: 0.0 for u in outputs}
    out_vr = [u.variable.valueReference for u in outputs]
    try:
        start_problems += _start_problems(fmu, md)
        step = float(md.defaultExperiment.stepSize) if md.defaultExperiment else STEP_SIZE
        instance.initialize()
        start = [float(v.start if v.start is not None else 0.0) for v in inputs]
        k = 0
        for probe in PROBE_STEPS:
            while True:
                base = {v.name: drive(s, i, k * step) if k else s for i, (v, s) in enumerate(zip(inputs, start))}
                instance.set(**base)
                if k == probe:
                    break
                fmu.doStep(currentCommunicationPoint=k * step, communicationStepSize=step)
                k += 1
            where = f"at t = {k * step:g} s"
            y0 = fmu.getReal(out_vr)
            for v in inputs:
                for delta in PERTURBATIONS:
                    fmu.setReal([v.valueReference], [base[v.name] + delta])
                    y1 = fmu.getReal(out_vr)
                    fmu.setReal([v.valueReference], [base[v.name]])
                    y2 = fmu.getReal(out_vr)
                    for u, a, b, c in zip(outputs, y0, y1, y2):
                        name = u.variable.name
                        largest[name] = max(largest[name], abs(a), abs(b))
                        declared = any(d.name == v.name for d in u.dependencies)
                        if not same(a, b):
                            if declared:
                                changed_by_declared[name] = True
                            else:
                                problems.append(
                                    f"'{name}' changes when input '{v.name}' changes by {delta} {where}, "
                                    "but does not declare that dependency")
                        if not same(a, c):
                            problems.append(f"'{name}' does not return to {a!r} when input '{v.name}' is "
                                            f"restored {where} (got {c!r})")
        fmu.terminate()
    except FMICallException as exc:
        reasons = "; ".join(m for s, m in instance.messages if s >= 2)
        return problems + [f"the experiment could not run the FMU: {exc}; logged: {reasons}"]
    finally:
        instance.free()
    for u in outputs:
        rounding_only = largest[u.variable.name] <= ROUNDING_LEVEL
        if u.dependencies and not changed_by_declared[u.variable.name] and not rounding_only:
            names = ", ".join(d.name for d in u.dependencies)
            problems.append(f"'{u.variable.name}' declares dependencies on {names}, but no perturbation of "
                            "them changed it (declare only what the output depends on)")
    return sorted(set(problems), key=problems.index)


def in_child(path: Path) -> tuple[list[str], list[str]]:
    """(start problems, dependency problems) of the FMU at ``path``, from the experiment in a child process;
    ``children.ChildFailed`` says why there are none (a crash, a hang, an error)."""
    starts, dependencies = json.loads(children.run("orchestration.compliance.dependencies", path)[-1])
    return starts, dependencies


def main(argv: list[str] | None = None) -> int:
    """The child of ``in_child``: prints [start problems, dependency problems] as JSON."""
    starts: list[str] = []
    dependencies = experiment(Path((argv or sys.argv[1:])[0]), starts)
    print(json.dumps([starts, dependencies]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
