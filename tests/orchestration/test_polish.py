"""The CMA-ES phase of a tuning search (orchestration.study.polish), in process: it starts from the TPE
phase's best, a resumed phase gives the trials of one run, a journal it cannot replay is refused, and the
convergence rule judges it."""
import math

import numpy as np
import optuna
import pytest

from orchestration.cli.tune_commands import MAX_SEED
from orchestration.study import optimize, polish, tuning

FMU, HANDLING, SEED = "CtController", 2, 0
PROBLEM = tuning.Ours(FMU, HANDLING)
BUDGET = tuning.INITIAL_DESIGN + 1  # one TPE trial after the initial design


def _record(journal, trials):
    return polish.record(optimize.storage(journal), PROBLEM, SEED, BUDGET, trials)


@pytest.fixture(scope="module")
def once(tmp_path_factory):
    """One search run at once: the TPE phase, then 8 CMA-ES trials (a generation of 6 and part of the next)."""
    journal = tmp_path_factory.mktemp("polish") / "once.journal"
    assert polish.search(journal, PROBLEM, SEED, BUDGET, 8) == BUDGET + 8
    return journal


def test_the_phase_starts_from_the_tpe_best_and_stays_near_it(once):
    tpe = optimize.record(optimize.storage(once), PROBLEM, SEED, BUDGET)
    r = _record(once, 8)
    assert r["polish_from"] == BUDGET and r["trials"] == len(r["criterion"]) == len(r["state"]) == BUDGET + 8
    assert r["criterion"][:BUDGET] == tpe["criterion"]
    start = polish.to_unit(PROBLEM, tpe["best_design"])
    name = polish.study_name(PROBLEM, SEED, BUDGET)
    trials = optuna.load_study(study_name=name, storage=optimize.storage(once)).trials
    steps = [np.abs(polish.to_unit(PROBLEM, t.params) - start).max() for t in trials]
    assert 0 < max(steps) < 6 * polish.SIGMA0  # CMA-ES's first generation: about SIGMA0 around the start
    values = [v for v in r["criterion"] if v is not None]
    assert r["criterion"][r["best"]] == min(values)
    assert r["best_design"] == (trials[r["best"] - BUDGET].params if r["best"] >= BUDGET else tpe["best_design"])


def test_a_resumed_phase_gives_the_trials_of_one_run(once, tmp_path):
    cut = tmp_path / "cut.journal"
    assert polish.search(cut, PROBLEM, SEED, BUDGET, 4) == BUDGET + 4  # stopped inside a generation
    assert polish.search(cut, PROBLEM, SEED, BUDGET, 8) == 4  # resumed: replayed, then 4 more
    assert polish.search(cut, PROBLEM, SEED, BUDGET, 8) == 0
    assert _record(cut, 8)["criterion"] == _record(once, 8)["criterion"]
    assert _record(cut, 8)["best_design"] == _record(once, 8)["best_design"]


def test_a_journal_whose_phase_no_longer_replays_is_refused(once, tmp_path):
    """A trial of the journal that is not what CMA-ES asks for at its number (here: moved by 1 %)."""
    journal = tmp_path / "moved.journal"
    optimize.run_search(journal, PROBLEM, SEED, BUDGET)
    start = optimize.record(optimize.storage(journal), PROBLEM, SEED, BUDGET)["best_design"]
    study = polish._open(journal, PROBLEM, SEED, BUDGET, start)
    name = polish.study_name(PROBLEM, SEED, BUDGET)
    first = optuna.load_study(study_name=name, storage=optimize.storage(once)).trials[0]
    moved = {k: v * 1.01 for k, v in first.params.items()}
    study.add_trial(optuna.trial.create_trial(params=moved, distributions=first.distributions, value=first.value))
    with pytest.raises(optimize.JournalError, match="no longer replays its trial 0"):
        polish.run_polish(journal, PROBLEM, SEED, BUDGET, 2, start)


def test_a_phase_from_another_start_is_refused(once):
    other = {name: low for name, (low, _, _) in tuning.SEARCH_SPACES[FMU].items()}
    with pytest.raises(optimize.JournalError, match="another tuning protocol"):
        polish.run_polish(once, PROBLEM, SEED, BUDGET, 8, other)


@pytest.mark.parametrize("fmu", tuning.CONTROLLERS)
def test_the_unit_cube_is_the_log_scaled_space_and_never_leaves_it(fmu):
    space = tuning.SEARCH_SPACES[fmu]
    nominal = tuning.nominal_design(fmu)
    again = polish.from_unit(tuning.Ours(fmu, 0), polish.to_unit(tuning.Ours(fmu, 0), nominal))
    assert all(math.isclose(again[k], nominal[k], rel_tol=1e-12) for k in space)
    for unit, end in ((np.zeros(len(space)), 0), (np.full(len(space), 1.5), 1), (np.full(len(space), -0.5), 0)):
        for k, v in polish.from_unit(tuning.Ours(fmu, 0), unit).items():
            assert space[k][0] <= v <= space[k][1] and math.isclose(v, space[k][end], rel_tol=1e-12)


def test_the_largest_tuning_seed_seeds_both_phases():
    """numpy's legacy generators take 32 bits: seed 5000 and up crashed Optuna's sampler."""
    for seed in (0, 4295, MAX_SEED):
        optimize._sampler(seed, 1023).sample_independent  # the TPE phase's sampler is made
        assert 0 <= optimize.generator_seed(seed, polish.STREAM) < 2**32
        np.random.RandomState(optimize.generator_seed(seed, 1023))
    assert optimize.generator_seed(4, 1023) == 1_000_003 * 4 + 1023  # the stored searches' seeds, unchanged


def test_the_rule_judges_the_cma_es_phase_when_there_is_one():
    tpe = [3.0, 2.0, 2.0, 1.0]  # its last half fell by half
    record = {"criterion": tpe + [1.0, 0.99, 0.98, 0.98], "polish_from": 4}
    assert tuning.tpe_improvement(record) == 0.5
    assert math.isclose(tuning.improvement(record), (0.99 - 0.98) / 0.99)  # best after 2 CMA-ES trials, then after 4
    assert tuning.still_improving(record) and not tuning.still_improving({**record, "criterion": tpe + [1.0] * 4})
    assert tuning.improvement({"criterion": tpe}) == tuning.tpe_improvement({"criterion": tpe}) == 0.5
    above = {"criterion": tpe + [1.2, 1.15, 1.1, 1.05], "polish_from": 4}  # never back down to its start
    assert tuning.last_half_improvement(above["criterion"], 4) == 0.0
    assert math.isclose(tuning.improvement(above), (1.15 - 1.05) / 1.15) and tuning.still_improving(above)


def test_a_failed_candidate_ranks_last_and_the_phase_goes_on(monkeypatch, tmp_path):
    """A design whose run fails (an infinite criterion) is kept as failed, and CMA-ES moves away from it:
    here every design with kp above the start fails, and the phase still fills its trials."""
    start = tuning.nominal_design(FMU)

    def criterion(fmu, params):
        return math.inf if params["kp"] > start["kp"] else abs(math.log(params["kd"] / start["kd"])) + 1.0

    monkeypatch.setattr(tuning, "criterion", criterion)
    journal = tmp_path / "failing.journal"
    assert polish.run_polish(journal, PROBLEM, SEED, BUDGET, 18, start) == 18
    trials = polish._polish_record(optimize.storage(journal), PROBLEM, SEED, BUDGET, 18)["trials"]
    failed = [t for t in trials if math.isinf(t.value)]
    assert 0 < len(failed) < 18
    last = trials[-6:]  # the third generation: drawn after two generations told the failures ranked last
    assert sum(math.isinf(t.value) for t in last) < sum(math.isinf(t.value) for t in trials[:6])
