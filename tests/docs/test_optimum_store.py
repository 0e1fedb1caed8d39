"""The stored optimum (docs/optimum/optimum.json, the source of docs/optimum.md and its verdict)
is what the code gives now: its optimal torques replay to its J*, its controllers' J are recomputed,
and no controller is below J* anywhere. No CasADi needed: only the solve needs it."""
from __future__ import annotations

import math

import numpy as np
import pytest

from fmu_controller.saturation import in_disc
from fmu_plant.dynamics import TORQUE_LIMIT
from orchestration.reports.optimum_tables import STORE_B, stored
from orchestration.study import optimum, optimum_scores
from support import REPO

DATA = stored(REPO)
DATA_B = stored(REPO, STORE_B)


def _problem(state, data=DATA):
    return optimum.Problem(tuple(state["phi0"]), tuple(state["dphi0"]), data["horizon"], data["objective"])


def test_the_stored_states_are_the_papers_and_the_value_studys():
    assert [s["index"] for s in DATA["states"]] == list(range(17))
    for s, (phi0, dphi0) in zip(DATA["states"], optimum_scores.all_states()):
        assert np.allclose(s["phi0"], phi0, rtol=0, atol=1e-15) and np.allclose(s["dphi0"], dphi0, rtol=0, atol=1e-15)


@pytest.mark.parametrize("data", [DATA, DATA_B], ids=["A", "B"])
def test_no_stored_controller_is_below_the_optimum_and_every_cold_start_agrees(data):
    assert [s["index"] for s in data["states"]] == list(range(17))
    for s in data["states"]:
        assert all(j is not None and j >= s["J_star"] for j in s["J"].values()), s["index"]
        assert s["solver"]["status"] == "Solve_Succeeded"
        assert "cold" not in s or s["cold"]["relative_difference"] <= 1e-6


@pytest.mark.parametrize("data, index", [(DATA, 0), (DATA, 9), (DATA_B, 0)], ids=["A-0", "A-9", "B-0"])
def test_the_stored_optimal_torques_replay_to_the_stored_j_star(data, index):
    state = data["states"][index]
    torques = np.array(state["torques"])
    assert all(in_disc(float(a), float(b), TORQUE_LIMIT) for a, b in torques)
    run = optimum.replay(_problem(state, data), torques)
    assert math.isclose(optimum.trajectory_cost(_problem(state, data), run), state["J_star"], rel_tol=1e-6)


@pytest.mark.parametrize("index, label", [(0, "SOTC nominal"), (9, "LQR tuned, seed 0")])
def test_a_stored_controller_cost_is_recomputed(index, label):
    state = DATA["states"][index]
    factory = optimum_scores.controller_cores(optimum_scores.learned_weights())[label]
    run = optimum_scores.run_controller(_problem(state), factory)
    assert math.isclose(optimum.trajectory_cost(_problem(state), run), state["J"][label], rel_tol=1e-6)
