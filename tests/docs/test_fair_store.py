"""The stored tuning search and fair evaluation are what the code produces: the protocol (design
points, evaluation points) exactly, and a sample of the runs re-run here (the whole store is
`python -m orchestration.study.tuning` and `python -m orchestration.study.fair`, minutes)."""
import math
from pathlib import Path

import pytest

from fmu_controller.catalog import LABELS
from fmu_controller.saturation import LIMIT_HANDLINGS
from orchestration.study import fair, tuning

ROOT = Path(__file__).resolve().parents[2]
REL = 1e-6  # BLAS and libm differ between machines in the last bits; the runs amplify them a little


def test_the_stored_search_is_the_protocol_the_code_states():
    data = tuning.stored()
    assert data["budget"] == tuning.BUDGET and data["seed"] == tuning.SEED
    for fmu in tuning.CONTROLLERS:
        stored = data["controllers"][fmu]
        assert stored["designs"] == tuning.design_points(fmu) and len(stored["designs"]) == tuning.BUDGET
        for h in tuning.HANDLINGS:
            r = stored["handlings"][LIMIT_HANDLINGS[h]]
            values = [math.inf if v is None else v for v in r["criterion"]]
            assert r["best"] == values.index(min(values)) and r["best_design"] == stored["designs"][r["best"]]


@pytest.mark.parametrize("fmu", tuning.CONTROLLERS)
def test_a_stored_tuning_point_is_what_the_loop_gives(fmu):
    best = tuning.stored()["controllers"][fmu]["handlings"]["accel"]
    again = tuning.criterion(fmu, tuning.parameters(fmu, best["best_design"], 2))
    assert math.isclose(again, best["criterion"][best["best"]], rel_tol=REL)


def test_the_stored_evaluation_points_are_the_seeded_ones():
    data = fair.stored(ROOT)
    assert data["points"] == {which: fair.evaluation_points(which) for which in fair.SETS}
    assert len(data["points"]["perturbed"]) == fair.N_POINTS >= 16


@pytest.mark.parametrize("which, index", [("initial states", 3), ("perturbed", 11)])
def test_a_stored_evaluation_run_is_what_the_loop_gives(which, index):
    data = fair.stored(ROOT)
    label = f"{LABELS['SotcController']} tuned"
    fmu, params = fair.configurations(2)[label]
    again = fair.run_point(fmu, params, fair.evaluation_points(which)[index])
    stored = data["runs"]["accel"][label][which][index]
    for name in ("mse", "tail"):
        assert math.isclose(again[name], stored[name], rel_tol=REL), name
    assert stored["max_tau_norm"] <= 4.0
