"""The tuning protocol and its Optuna journal (orchestration.study.tuning, .optimize), in process; the
command itself, resumed after Ctrl-C, is tests/shipped/test_shipped_tune.py."""
import functools
import math

import optuna
import pytest

from orchestration.study import optimize, protocol, tuning


@pytest.mark.parametrize("fmu", tuning.CONTROLLERS)
def test_the_initial_design_is_the_nominal_then_a_seeded_latin_hypercube_inside_the_space(fmu):
    design = tuning.initial_design(fmu, 0)
    assert len(design) == tuning.INITIAL_DESIGN and design[0] == tuning.nominal_design(fmu)
    assert design == tuning.initial_design(fmu, 0) and design[1:] != tuning.initial_design(fmu, 1)[1:]
    for name, (low, high, _) in tuning.SEARCH_SPACES[fmu].items():
        logs = sorted(math.log(d[name]) for d in design[1:])
        assert low <= min(d[name] for d in design[1:]) and max(d[name] for d in design[1:]) <= high
        width = (math.log(high) - math.log(low)) / (len(logs))
        # a Latin hypercube: one point in each of the n equal strata of every coordinate
        assert [int((v - math.log(low)) // width) for v in logs] == list(range(len(logs)))


def test_the_last_half_improvement_is_measured_on_the_best_so_far():
    assert tuning.best_so_far([3.0, None, 2.0, 2.5]) == [3.0, 3.0, 2.0, 2.0]
    assert math.isclose(tuning.last_half_improvement([3.0, 2.0, 1.9, 2.5]), 0.05)
    assert tuning.last_half_improvement([1.0, 2.0, 3.0, 4.0]) == 0.0
    assert tuning.last_half_improvement([None, None, 1.0, 1.0]) == 1.0


def test_a_journal_of_another_protocol_is_refused(tmp_path):
    journal = tmp_path / "t.journal"
    study = optuna.create_study(study_name=optimize.study_name(tuning.Ours("CtController", 2), 0), storage=optimize.storage(journal))
    study.set_user_attr("protocol", "another")
    with pytest.raises(optimize.JournalError, match="another tuning protocol"):
        optimize.run_search(journal, tuning.Ours("CtController", 2), 0, 1)


def test_a_journal_whose_first_trial_no_longer_reproduces_is_refused(tmp_path):
    journal = tmp_path / "t.journal"
    fmu = "CtController"
    study = optuna.create_study(study_name=optimize.study_name(tuning.Ours(fmu, 2), 0), storage=optimize.storage(journal))
    study.set_user_attr("protocol", tuning.Ours(fmu, 2).digest(0))
    dist = {n: optuna.distributions.FloatDistribution(lo, hi, log=True) for n, (lo, hi, _) in tuning.SEARCH_SPACES[fmu].items()}
    study.add_trial(optuna.trial.create_trial(params=tuning.nominal_design(fmu), distributions=dist, value=0.5,
                                              intermediate_values={0: 0.123}))  # numbers of older code
    with pytest.raises(optimize.JournalError, match="no longer reproduces"):
        optimize.run_search(journal, tuning.Ours(fmu, 2), 0, 2)


def _trials(journal, fmu, handling, seed):
    study = optuna.load_study(study_name=optimize.study_name(tuning.Ours(fmu, handling), seed), storage=optimize.storage(journal))
    return [(t.params, t.intermediate_values, t.value, t.state) for t in optimize.finished_trials(study)]


def test_a_search_resumed_from_its_journal_gives_the_trials_of_one_run(tmp_path):
    """CtController under radial handling: its first training MSE is not exp(log(MSE)) in the last bit,
    and resume was refused as "no longer reproduces" (12 of the 36 searches)."""
    fmu, handling, seed = "CtController", 0, 0
    once, cut = tmp_path / "once.journal", tmp_path / "cut.journal"
    assert optimize.run_search(once, tuning.Ours(fmu, handling), seed, 3) == 3
    assert optimize.run_search(cut, tuning.Ours(fmu, handling), seed, 2) == 2
    assert optimize.run_search(cut, tuning.Ours(fmu, handling), seed, 3) == 1  # resumed: one more trial
    assert _trials(cut, fmu, handling, seed) == _trials(once, fmu, handling, seed)


@functools.lru_cache(maxsize=None)
def _first_number(fmu: str, handling: int) -> float:
    """What the first trial (the nominal design, the same in every seed's search) reports after its first point."""
    return next(tuning.running_criterion(fmu, tuning.parameters(fmu, tuning.initial_design(fmu, 0)[0], handling)))


@pytest.mark.parametrize("seed", protocol.SEEDS)
@pytest.mark.parametrize("handling", tuning.HANDLINGS)
@pytest.mark.parametrize("fmu", tuning.CONTROLLERS)
def test_every_search_of_the_protocol_resumes_from_its_journal(fmu, handling, seed, tmp_path):
    """Each of the searches `sotc-cosim tune` runs by default (every controller, handling and seed): its
    journal, holding the first trial as a run reports it, is taken up again, not refused; the first number
    goes through Optuna's journal (JSON) and must come back as the same double."""
    journal = tmp_path / "t.journal"
    study = optimize._open(journal, tuning.Ours(fmu, handling), seed)
    design = tuning.initial_design(fmu, seed)[0]
    dist = {n: optuna.distributions.FloatDistribution(lo, hi, log=True) for n, (lo, hi, _) in tuning.SEARCH_SPACES[fmu].items()}
    study.add_trial(optuna.trial.create_trial(params=design, distributions=dist, value=1.0,
                                              intermediate_values={0: _first_number(fmu, handling)}))
    assert optimize.run_search(journal, tuning.Ours(fmu, handling), seed, 1) == 0  # resumed: nothing to run, nothing refused
    assert _trials(journal, fmu, handling, seed)[0][1] == {0: _first_number(fmu, handling)}
