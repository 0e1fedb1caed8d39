"""The pure loop with a perturbed plant, a disturbance and measurement noise is the `paper-perturbed`
scenario through the FMUs, sample for sample: the fair comparison (orchestration.study.fair) runs
there, so its numbers are the FMUs' numbers."""
import dataclasses

import numpy as np
import pytest

from fmu_controller.catalog import CORES
from fmu_plant.dynamics import ArmParameters
from orchestration.run.master import run
from orchestration.run.scenario import Instance, load_scenario
from orchestration.study.pure_loop import Perturbation, simulate

PLANT = {"p1": 3.473 * 1.15, "p2": 0.196 * 0.85, "p3": 0.242 * 1.1, "f1": 8.45 * 0.9, "f2": 2.35 * 1.2}
NOISE = {"std_phi": 3e-4, "std_dphi": 3e-3, "seed": 11}
DISTURBANCE = {"step1": 0.3, "step2": -0.2, "step_time": 1.0, "sin1": 0.1, "sin2": 0.25, "omega": 2.0}


@pytest.mark.parametrize("controller", ["SotcController", "LqrController"])
def test_the_perturbed_pure_loop_equals_the_fmu_run(fmu_paths, controller):
    scenario = load_scenario("paper-perturbed")
    overrides = {**{f"plant.{k}": v for k, v in PLANT.items()}, **{f"noise.{k}": v for k, v in NOISE.items()},
                 **{f"disturbance.{k}": v for k, v in DISTURBANCE.items()},
                 "plant.phi1_0": -1.0, "plant.phi2_0": 1.5}
    scenario = scenario.with_parameters(overrides).with_stop_time(5.0)
    if controller != "SotcController":
        scenario = dataclasses.replace(
            scenario, instances={**scenario.instances, "controller": Instance("controller", controller, {})})
    fmu_run = run(scenario, fmu_paths)
    core = CORES[controller](**scenario.instances["controller"].parameters)
    arm = ArmParameters(**PLANT)
    pure = simulate(core, stop_time=5.0, arm=arm, phi0=(-1.0, 1.5),
                    perturbation=Perturbation(**DISTURBANCE, **NOISE))
    p, c = fmu_run.outputs["plant"], fmu_run.outputs["controller"]
    assert np.array_equal(pure.y[:, 0], p["phi1"]) and np.array_equal(pure.y[:, 1], p["phi2"])
    assert np.array_equal(pure.tau, np.column_stack([c["tau1"], c["tau2"]]))
    assert np.std(pure.y[:, 0] - simulate(CORES[controller](**scenario.instances["controller"].parameters),
                                          stop_time=5.0, phi0=(-1.0, 1.5)).y[:, 0]) > 1e-4  # it did perturb
