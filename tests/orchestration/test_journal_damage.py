"""A tuning journal with a damaged line (``orchestration.study.journal``): the journal as it was is kept
beside it, the rebuilt one holds every trial the damage cannot have touched, and the searches resumed
from it give the trials of one uninterrupted run. The criterion here is a cheap function of the design
(the searches' bookkeeping is under test, not the loop)."""
from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from orchestration.study import optimize, polish, tuning
from orchestration.study.journal import JOURNAL, salvage

FMU, HANDLING, SEED = "CtController", 2, 0
PROBLEM = tuning.Ours(FMU, HANDLING)
BUDGET = tuning.INITIAL_DESIGN + 3
POLISH = 8


@pytest.fixture(autouse=True)
def cheap_criterion(monkeypatch):
    def running(fmu, params):
        distance = math.log(params["kp"] / 50.0) ** 2 + math.log(params["kd"] / 10.0) ** 2
        for k in range(1, 4):
            yield distance + 0.1 * k

    monkeypatch.setattr(tuning, "running_criterion", running)


def _search(journal: Path, trials: int) -> int:
    return polish.search(journal, PROBLEM, SEED, BUDGET, trials)


def _record(journal: Path) -> dict:
    r = polish.record(optimize.storage(journal), PROBLEM, SEED, BUDGET, POLISH)
    return {k: r[k] for k in ("criterion", "state", "best", "best_design", "trials")}


@pytest.fixture
def runs(tmp_path):
    """One search run at once, and the same search stopped after 4 of its CMA-ES trials."""
    once, cut = tmp_path / "once.journal", tmp_path / "cut.journal"
    _search(once, POLISH)
    _search(cut, 4)
    return once, cut


def _damage(journal: Path, which) -> int:
    """Cut the first line whose record ``which`` picks in half (a torn write); its number from 1."""
    lines = journal.read_bytes().splitlines(keepends=True)
    k = next(i for i, line in enumerate(lines) if which(json.loads(line)))
    lines[k] = lines[k][: len(lines[k]) // 2] + b"\n"
    journal.write_bytes(b"".join(lines))
    return k + 1


def _trial_of_study(name: str, number: int):
    """Picks the creation record of trial ``number`` of the study ``name`` (records counted as Optuna does)."""
    studies, counts = {}, {}

    def which(record: dict) -> bool:
        if record["op_code"] == 0:
            studies.setdefault(record["study_name"], len(studies))
        if record["op_code"] != 4:
            return False
        count = counts[record["study_id"]] = counts.get(record["study_id"], -1) + 1
        return record["study_id"] == studies.get(name) and count == number
    return which


@pytest.mark.parametrize("damaged, kept, again", [
    # an intermediate value of the TPE phase's third trial: it and the phase's later trials run again, the
    # CMA-ES phase (from the same best, once they have) is kept
    (lambda: (lambda r: r["op_code"] == 7 and r["trial_id"] == 2), 2 + 4, BUDGET - 2),
    # the creation of the TPE phase's fourth trial: nothing after it can be placed (the 3 before are kept)
    (lambda: _trial_of_study(optimize.study_name(PROBLEM, SEED), 3), 3, 0),
    # the CMA-ES phase's second trial, written whole in one record: it is lost, the two after it run again
    (lambda: _trial_of_study(polish.study_name(PROBLEM, SEED, BUDGET), 1), BUDGET + 1, 2),
])
def test_a_damaged_line_is_kept_aside_and_the_search_resumes_to_the_trials_of_one_run(runs, damaged, kept, again):
    once, cut = runs
    line = _damage(cut, damaged())
    before = cut.read_bytes()
    done = salvage(cut)
    assert done.lines == [line] and done.aside.read_bytes() == before  # nothing lost
    assert f"line {line} is not an Optuna journal record" in str(done) and str(cut) in str(done)
    assert (done.kept, done.again, done.prefix) == (kept, again, kept == 3)
    assert salvage(cut) is None  # the rebuilt journal is whole
    assert _search(cut, POLISH) > 0
    assert _record(cut) == _record(once)


def test_a_journal_is_told_from_another_file(runs, tmp_path):
    once, _ = runs
    hosts = tmp_path / "hosts"
    hosts.write_text("127.0.0.1 localhost\n")
    assert JOURNAL.holds(once) and not JOURNAL.holds(hosts)


def test_searches_that_wrote_one_journal_at_once_keep_what_the_damage_cannot_touch(tmp_path):
    """Two searches appending to one journal at once (as the Dask workers of tune do), their records
    interleaved in whatever order the threads ran: a damaged line of one search's trial leaves the other
    search whole, and both resume to the trials of their own uninterrupted runs."""
    import threading

    alone = {seed: tmp_path / f"alone{seed}.journal" for seed in (0, 1)}
    for seed, journal in alone.items():
        polish.search(journal, PROBLEM, seed, BUDGET, POLISH)
    shared = tmp_path / "shared.journal"
    threads = [threading.Thread(target=polish.search, args=(shared, PROBLEM, seed, BUDGET, 4)) for seed in (0, 1)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    storage = optimize.storage(shared)
    study = storage.get_study_id_from_name(optimize.study_name(PROBLEM, 0))
    third = storage.get_all_trials(study)[2]._trial_id  # of seed 0's TPE phase: a parameter of it is damaged
    line = _damage(shared, lambda r: r["op_code"] == 5 and r["trial_id"] == third)
    done = salvage(shared)
    assert done.lines == [line] and not done.prefix
    # seed 0's TPE trials from the third on run again; whatever ran at that line in seed 1's search too
    assert BUDGET - 2 <= done.again and done.kept + done.again == 2 * (BUDGET + 4)
    for seed, journal in alone.items():
        polish.search(shared, PROBLEM, seed, BUDGET, POLISH)
        assert polish.record(optimize.storage(shared), PROBLEM, seed, BUDGET, POLISH)["criterion"] == \
            polish.record(optimize.storage(journal), PROBLEM, seed, BUDGET, POLISH)["criterion"]
