"""The stored tuning search and fair evaluation are what the code produces: the protocol (training and
evaluation points, the store's shape) exactly, and a sample of the runs re-run here (the whole store is
`sotc-cosim tune --out orchestration/study/tuned.json` and `python -m orchestration.study.fair`, an hour)."""
import contextlib
import math
from pathlib import Path

import optuna
import pytest

from fmu_controller.catalog import LABELS
from fmu_controller.saturation import LIMIT_HANDLINGS
from orchestration.study import fair, optimize, polish, protocol, tuning

ROOT = Path(__file__).resolve().parents[2]
REL = 1e-6  # BLAS and libm differ between machines in the last bits; the runs amplify them a little


def test_the_stored_search_is_the_protocol_the_code_states():
    data = tuning.stored()
    assert data["budget"] >= 64 and data["polish"] >= 64 and len(data["seeds"]) >= 5 and data["complete"]
    # `sotc-cosim tune`'s defaults draw a new seed exactly as the stored searches were drawn
    assert (data["budget"], data["polish"], data["seeds"]) == (protocol.BUDGET, protocol.POLISH, list(protocol.SEEDS))
    assert data["training_points"] == len(tuning.training_points()) >= 8
    for fmu in tuning.CONTROLLERS:
        for h in tuning.HANDLINGS:
            seeds = data["controllers"][fmu]["handlings"][LIMIT_HANDLINGS[h]]["seeds"]
            assert sorted(seeds) == sorted(map(str, data["seeds"]))
            for seed, r in seeds.items():
                values = [math.inf if v is None else v for v in r["criterion"]]
                assert len(values) == len(r["state"]) == data["budget"] + data["polish"], (fmu, h, seed)
                assert r["polish_from"] == data["budget"]
                assert r["best"] == values.index(min(values)) and r["state"][r["best"]] == "complete"
                assert set(r["best_design"]) == set(tuning.SEARCH_SPACES[fmu])
                first = tuning.initial_design(fmu, int(seed))[0]
                assert r["best"] != 0 or r["best_design"] == first  # trial 0 is the nominal design


def test_every_search_converged_by_the_stated_rule():
    """Doubling every search's CMA-ES phase moved its best by less than tuning.CONVERGED (else the phase is
    too short: a larger --polish, or --until-converged, resumes every search)."""
    data = tuning.stored()
    still = tuning.unconverged(data)
    assert not still, f"still improving at {data['polish']} CMA-ES trials: {still}"


def test_a_stored_cma_es_phase_starts_where_the_code_starts_it(tmp_path):
    """CT under accel, seed 0: the phase starts at the TPE phase's best, and its first trial is what the
    code's CMA-ES asks for from there, with the criterion the loop gives."""
    r = tuning.study_record("CtController", 2, 0)
    tpe = [math.inf if v is None else v for v in r["criterion"][:r["polish_from"]]]
    start = r["polish_start"]
    assert r["criterion"][r["best"]] <= min(tpe)
    assert math.isclose(tuning.criterion("CtController", tuning.parameters("CtController", start, 2)), min(tpe), rel_tol=REL)
    journal = tmp_path / "t.journal"
    assert polish.run_polish(journal, tuning.Ours("CtController", 2), 0, r["polish_from"], 1, start) == 1
    again = optuna.load_study(study_name=polish.study_name(tuning.Ours("CtController", 2), 0, r["polish_from"]),
                              storage=optimize.storage(journal)).trials[0].value
    assert math.isclose(again, r["criterion"][r["polish_from"]], rel_tol=REL)


@pytest.mark.parametrize("fmu", ["CtController", "LqrController"])
def test_a_stored_best_trial_is_what_the_loop_gives(fmu):
    r = tuning.study_record(fmu, 2)
    again = tuning.criterion(fmu, tuning.parameters(fmu, r["best_design"], 2))
    assert math.isclose(again, r["criterion"][r["best"]], rel_tol=REL)


def _held_out() -> list[dict]:
    return [p for d in fair.DRAWS for which in fair.SETS for p in fair.evaluation_points(which, d)]


@pytest.mark.parametrize("training", ["shipped", "larger"])
def test_the_training_points_are_none_of_the_held_out_points(training):
    """Not one initial state or noise seed in common, for the shipped training set and for the larger one of
    the training-size study, across every held-out draw; and the draws' generator seeds are not the training's."""
    from orchestration.study.training_size import larger_training_set

    with larger_training_set() if training == "larger" else contextlib.nullcontext():
        points = tuning.training_points()
    held_out = _held_out()
    assert not any(p["phi0"] in [q["phi0"] for q in held_out] for p in points)
    noise = [p["perturbation"]["seed"] for p in held_out if "perturbation" in p]
    assert len(set(noise)) == len(noise)  # no two held-out points share a noise seed, across draws too
    assert not set(noise) & {p["perturbation"]["seed"] for p in points if "perturbation" in p}
    assert tuning.TRAINING_SEED not in fair.DRAWS and len(set(fair.DRAWS)) == len(fair.DRAWS) >= 3


def test_the_stored_evaluation_points_are_the_seeded_ones():
    data = fair.stored(ROOT)
    assert data["draws"] == list(fair.DRAWS)
    assert data["points"] == {str(d): {which: fair.evaluation_points(which, d) for which in fair.SETS} for d in fair.DRAWS}
    assert len(data["points"][str(fair.DRAWS[0])]["perturbed"]) == fair.N_POINTS >= 128
    assert data["seeds"] == tuning.stored()["seeds"]


@pytest.mark.parametrize("which, draw, index", [("initial states", 7, 3), ("perturbed", 9, 117)])
def test_a_stored_evaluation_run_is_what_the_loop_gives(which, draw, index):
    data = fair.stored(ROOT)
    seed = data["seeds"][-1]
    label = fair.tuned_label("SotcController", seed)
    fmu, params = fair.configurations(2)[label]
    assert params["limit_handling"] == 2 and label.startswith(LABELS[fmu])
    again = fair.run_point(fmu, params, fair.evaluation_points(which, draw)[index])
    for name in ("mse", "tail"):
        stored = fair.measure(data, "accel", label, which, name, draw)[index]
        assert math.isclose(again[name], stored, rel_tol=REL), name
    assert again["max_tau_norm"] <= 4.0


def test_the_larger_training_set_holds_the_shipped_one():
    from orchestration.study.training_size import LARGER, larger_training_set

    shipped = tuning.training_points()
    with larger_training_set():
        larger = tuning.training_points()
    assert len(larger) == sum(LARGER.values()) == 4 * len(shipped)
    assert all(p in larger for p in shipped)
    assert tuning.training_points() == shipped  # the shipped set is back outside


@pytest.mark.parametrize("fmu, which, draw, index", [("CtController", "perturbed", 8, 5),
                                                     ("SotcController", "initial states", 9, 100)])
def test_a_stored_run_of_the_training_size_study_is_what_the_loop_gives(fmu, which, draw, index):
    from orchestration.study import training_size

    data = training_size.stored(ROOT)
    record = data["records"][f"{fmu} 0"]
    params = training_size.design_parameters(fmu, record["best_design"])
    again = fair.run_point(fmu, params, fair.evaluation_points(which, draw)[index])
    stored = data["runs"][f"{fmu} 0"][str(draw)][which][index]
    for name in ("mse", "tail"):
        assert math.isclose(again[name], stored[name], rel_tol=REL), name
