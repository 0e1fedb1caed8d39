"""``check-controller``'s short run (docs/benchmark.md): a controller FMU that meets the contract, as the controller
of the ``paper`` scenario for 1 s against our arm and reference, through its port map and with its parameters, the
actuator between it and the arm as in any run. What it found: whether the run finished (else its reason), whether
every torque the FMU wrote is finite, the largest ||tau|| it wrote and the samples the actuator cut, and the
tracking error at the end."""
from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from orchestration.compliance.contract import Check
from orchestration.run.scenario import CONTROLLER, Instance, Scenario, load_scenario

SCENARIO = "paper"  # the arm, the reference and their connections to a controller
STOP_TIME = 1.0  # s
JOINTS = ("phi1", "phi2")  # the plant's angles; the reference's are these with "_d"


@dataclass
class Smoke:
    """What the run found: a line each, and whether it passes (``interrupted``: stopped by a signal)."""

    lines: list[str] = field(default_factory=list)
    ok: bool = False
    interrupted: bool = False


def scenario_for(checked: Check) -> Scenario:
    """The ``paper`` scenario for ``STOP_TIME``, its controller the checked FMU with its map and parameters."""
    paper = load_scenario(SCENARIO).with_stop_time(STOP_TIME)
    controller = Instance(CONTROLLER, str(checked.fmu.resolve()), dict(checked.parameters), ports=dict(checked.ports))
    return replace(paper, name="check-controller", source=str(checked.fmu),
                   instances={**paper.instances, CONTROLLER: controller})


def models(scenario: Scenario) -> list[str]:
    """Our FMUs the run needs (the arm and the reference), to be built where missing."""
    return sorted(i.fmu for i in scenario.instances.values() if i.file is None)


def run_controller(scenario: Scenario, fmu_paths: dict):
    """The one place this check runs the FMU: in a child process, so that a crash or a hang of the FMU fails the
    run with its reason (``isolated``), not the command."""
    from orchestration.run.isolated import run_any

    return run_any(scenario, fmu_paths)


def smoke(checked: Check, fmu_paths: dict) -> Smoke:
    """Run the checked FMU against our arm (``run_controller``) and say what the run found."""
    from orchestration.compliance.contract import model_description
    from orchestration.run.metrics import norms
    from orchestration.run.ported import written
    from orchestration.run.summary import summarize

    scenario = scenario_for(checked)
    result = run_controller(scenario, fmu_paths)
    head = f"  {STOP_TIME:g} s run against our arm (scenario {SCENARIO}, rho = {scenario.torque_limit():g} N.m)"
    if result.failed:
        return Smoke([f"{head}: FAILED: {result.error}"], interrupted=result.interrupted)
    variables = {v.name: v for v in model_description(checked.fmu).modelVariables}
    names = written(variables, checked.ports)
    out, t = result.outputs[CONTROLLER], result.time
    wrote = np.column_stack([out[n] for n in names])
    lines = [f"{head}: finished, {result.samples} samples"]  # a torque that is not finite failed the run (isolated)
    cuts = summarize(result)["torque_cuts"]
    plant, reference = result.outputs["plant"], result.outputs["reference"]
    errors = ", ".join(f"e{j + 1} = {plant[p][-1] - reference[p + '_d'][-1]:+.3g} rad" for j, p in enumerate(JOINTS))
    lines += [f"    every torque it wrote ({', '.join(names)}) is finite",
              f"    max ||tau|| it wrote: {float(norms(wrote).max()):.6g} N.m; samples the actuator cut: {cuts} of "
              f"{result.samples}",
              f"    tracking error at t = {t[-1]:g} s: {errors}"]
    return Smoke(lines, ok=True)
