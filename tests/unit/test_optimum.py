"""The optimum (orchestration.study.optimum) on a short horizon: its model is the plant core's step, its
torques stay in the disc exactly, it is a true optimum (no controller does better, a cold start finds the
same), and both objectives are the ones the scores use."""
from __future__ import annotations

import math

import numpy as np
import pytest

pytest.importorskip("casadi", reason="CasADi is missing: pip install '.[optimum]' (the test extra has it)")

from fmu_controller.saturation import in_disc  # noqa: E402
from fmu_controller.sotc_math import omega_of_mu  # noqa: E402
from fmu_plant import dynamics  # noqa: E402
from fmu_plant.dynamics import STEP_SIZE, TORQUE_LIMIT  # noqa: E402
from orchestration.exit_codes import UsageError  # noqa: E402
from orchestration.study import optimum, optimum_scores  # noqa: E402

HORIZON = 1.0  # s: 100 samples, the whole saturated start of the paper's run


@pytest.fixture(scope="module")
def learned():
    return optimum_scores.learned_weights()


@pytest.fixture(scope="module")
def paper_state(learned):
    return optimum_scores.solve_state(0, HORIZON, "A", learned, cold=True)


def test_the_model_step_is_the_plant_cores_step():
    arm = dynamics.ArmParameters()
    step = optimum.step_function(arm)
    rng = np.random.default_rng(1)
    for _ in range(200):
        x, u = rng.uniform(-3, 3, 4), rng.uniform(-4, 4, 2)
        symbolic = np.asarray(step(x, u)).ravel()
        core = np.array(dynamics.integrate(tuple(x), u[0], u[1], STEP_SIZE, 4, arm))
        assert np.max(np.abs(symbolic - core)) <= 1e-12


def test_the_optimal_torques_are_in_the_disc_exactly(paper_state):
    torques = np.array(paper_state["torques"])
    assert len(torques) == round(HORIZON / STEP_SIZE)
    assert all(in_disc(float(a), float(b), TORQUE_LIMIT) for a, b in torques)
    assert np.max(np.hypot(*torques.T)) > TORQUE_LIMIT - 1e-6  # the bound is active: the check is not idle


def test_no_controller_beats_the_optimum(paper_state):
    costs = paper_state["J"]
    assert len(costs) == len(optimum_scores.controller_cores([0.0] * 10)) and not paper_state["failures"]
    assert all(j >= paper_state["J_star"] for j in costs.values()), costs
    assert paper_state["solver"]["status"] == "Solve_Succeeded"


def test_a_cold_start_finds_the_same_optimum(paper_state):
    assert paper_state["cold"]["relative_difference"] <= 1e-6
    assert paper_state["warm_start"] in paper_state["J"]  # warm-started from a controller, not from zero


def test_objective_b_charges_omega_and_stays_below_every_controller(learned):
    record = optimum_scores.solve_state(1, HORIZON, "B", learned, cold=False)
    assert all(j >= record["J_star"] for j in record["J"].values())
    a = optimum.Problem(*optimum_scores.all_states()[1], HORIZON, "A")
    b = optimum.Problem(*optimum_scores.all_states()[1], HORIZON, "B")
    run = optimum.replay(b, np.array(record["torques"]))
    assert optimum.trajectory_cost(b, run) > optimum.trajectory_cost(a, run)  # the input is charged


def test_the_symbolic_omega_is_the_cores_omega():
    import casadi as ca

    rng = np.random.default_rng(2)
    mu = rng.uniform(-0.999, 0.999, (2, 50)) * optimum.INPUT_LEVEL
    symbolic = float(ca.evalf(optimum.omega_symbolic(ca.DM(mu), optimum.INPUT_LEVEL)))
    assert math.isclose(symbolic, sum(omega_of_mu(m, optimum.INPUT_LEVEL, optimum.INPUT_WEIGHTS) for m in mu.T),
                        rel_tol=1e-12)


def test_the_solver_objective_is_the_replayed_cost():
    problem = optimum.Problem((0.5, -0.5), (0.0, 0.0), HORIZON)
    found = optimum.solve(problem)
    assert math.isclose(found.solver_objective, found.cost, rel_tol=1e-6)


@pytest.mark.parametrize("horizon, objective", [(0.015, "A"), (-1.0, "A"), (1.0, "C")])
def test_a_problem_it_cannot_pose_is_refused(horizon, objective):
    with pytest.raises(UsageError):
        optimum.Problem((0.5, -0.5), (0.0, 0.0), horizon, objective)
