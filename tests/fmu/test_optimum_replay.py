"""The optimal torques through the shipped plant FMU reproduce J*: the optimum solved the problem the FMUs
run, not a model of it."""
from __future__ import annotations

import math

import numpy as np
import pytest
from support.fmu_driver import DrivenFmu

pytest.importorskip("casadi", reason="CasADi is missing: pip install '.[optimum]' (the test extra has it)")

from fmu_plant.dynamics import STEP_SIZE  # noqa: E402
from orchestration.study import optimum  # noqa: E402
from orchestration.study.pure_loop import LoopResult  # noqa: E402


def test_the_plant_fmu_replays_the_optimal_torques_to_j_star(fmu_paths, tmp_path):
    problem = optimum.Problem((0.5, -0.5), (0.0, 0.0), horizon=1.0)
    found = optimum.solve(problem)
    plant = DrivenFmu(fmu_paths["ArmPlant"], tmp_path / "plant")
    plant.initialize(phi1_0=0.5, phi2_0=-0.5, dphi1_0=0.0, dphi2_0=0.0)
    states = [plant.get("phi1", "phi2", "dphi1", "dphi2")]
    for k, (t1, t2) in enumerate(found.torques):
        plant.set(tau1=float(t1), tau2=float(t2))
        plant.fmu.doStep(k * STEP_SIZE, STEP_SIZE)
        states.append(plant.get("phi1", "phi2", "dphi1", "dphi2"))
    plant.free()
    torques = np.vstack([found.torques, found.torques[-1:]])
    run = LoopResult(problem.times(), np.array(states), problem.references, torques, ("tau1", "tau2"))
    assert math.isclose(optimum.trajectory_cost(problem, run), found.cost, rel_tol=1e-6, abs_tol=0.0)
