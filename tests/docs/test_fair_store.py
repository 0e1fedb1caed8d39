"""The stored tuning search and fair evaluation are what the code produces: the protocol (training and
evaluation points, the store's shape) exactly, and a sample of the runs re-run here (the whole store is
`sotc-cosim tune --out orchestration/study/tuned.json` and `python -m orchestration.study.fair`, an hour)."""
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
    assert data["budget"] >= 64 and len(data["seeds"]) >= 3 and data["complete"]
    assert data["training_points"] == len(tuning.training_points()) >= 8
    for fmu in tuning.CONTROLLERS:
        for h in tuning.HANDLINGS:
            seeds = data["controllers"][fmu]["handlings"][LIMIT_HANDLINGS[h]]["seeds"]
            assert sorted(seeds) == sorted(map(str, data["seeds"]))
            for seed, r in seeds.items():
                values = [math.inf if v is None else v for v in r["criterion"]]
                assert len(values) == len(r["state"]) == data["budget"], (fmu, h, seed)
                assert r["best"] == values.index(min(values)) and r["state"][r["best"]] == "complete"
                assert set(r["best_design"]) == set(tuning.SEARCH_SPACES[fmu])
                first = tuning.initial_design(fmu, int(seed))[0]
                assert r["best"] != 0 or r["best_design"] == first  # trial 0 is the nominal design


@pytest.mark.xfail(strict=True, reason="the stored tuning's budget is not yet enough: at the stored budget some searches still "
                   "improve by tuning.CONVERGED or more over their last half (docs/baselines.md names them); the next "
                   "doubling resumes from the journal with `sotc-cosim tune --until-converged`, hours of compute")
def test_the_budget_is_enough_for_every_search_by_the_stated_rule():
    """The best-so-far of every search improves by less than tuning.CONVERGED over its last half (else the
    budget is too small: a larger --budget resumes every search)."""
    data = tuning.stored()
    still = tuning.unconverged(data)
    assert not still, f"still improving at {data['budget']} trials: {still}"


@pytest.mark.parametrize("fmu", ["CtController", "LqrController"])
def test_a_stored_best_trial_is_what_the_loop_gives(fmu):
    r = tuning.study_record(fmu, 2)
    again = tuning.criterion(fmu, tuning.parameters(fmu, r["best_design"], 2))
    assert math.isclose(again, r["criterion"][r["best"]], rel_tol=REL)


def test_the_training_points_are_none_of_the_held_out_points():
    held_out = [p["phi0"] for which in fair.SETS for p in fair.evaluation_points(which)]
    training = tuning.training_points()
    assert not any(p["phi0"] in held_out for p in training)
    noise = {p["perturbation"]["seed"] for which in fair.SETS for p in fair.evaluation_points(which) if "perturbation" in p}
    assert not noise & {p["perturbation"]["seed"] for p in training if "perturbation" in p}


def test_the_stored_evaluation_points_are_the_seeded_ones():
    data = fair.stored(ROOT)
    assert data["points"] == {which: fair.evaluation_points(which) for which in fair.SETS}
    assert len(data["points"]["perturbed"]) == fair.N_POINTS >= 16
    assert data["seeds"] == tuning.stored()["seeds"]


@pytest.mark.parametrize("which, index", [("initial states", 3), ("perturbed", 11)])
def test_a_stored_evaluation_run_is_what_the_loop_gives(which, index):
    data = fair.stored(ROOT)
    seed = data["seeds"][-1]
    label = fair.tuned_label("SotcController", seed)
    fmu, params = fair.configurations(2)[label]
    assert params["limit_handling"] == 2 and label.startswith(LABELS[fmu])
    again = fair.run_point(fmu, params, fair.evaluation_points(which)[index])
    stored = data["runs"]["accel"][label][which][index]
    for name in ("mse", "tail"):
        assert math.isclose(again[name], stored[name], rel_tol=REL), name
    assert stored["max_tau_norm"] <= 4.0
