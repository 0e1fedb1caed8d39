"""``sotc-cosim tune --until-converged CAP``: the phase the rule judges (the CMA-ES phase; the whole search
with ``--polish 0``) doubles alike for every search while any search still improves by ``CONVERGED`` or more
over the last half of that phase, and never beyond CAP (the searches themselves are stood in for by a
criterion curve per budget: the loop is what is tested here)."""
from __future__ import annotations

import pytest

from orchestration.cli import main
from orchestration.study.tuning import CONVERGED
from orchestration.sweep import tuning_jobs


def _store(curve: list[float], polish_from: int | None = None) -> dict:
    record = {"trials": len(curve), "criterion": curve, "best": curve.index(min(curve))}
    record.update({} if polish_from is None else {"polish_from": polish_from})
    budget = len(curve) if polish_from is None else polish_from
    return {"complete": True, "budget": budget, "polish": len(curve) - budget,
            "controllers": {"CtController": {"handlings": {"accel": {"seeds": {"0": record}}}}}}


def _falling(trials: int) -> list[float]:
    """A best that falls by 5 % each time the trials double, until 16 trials."""
    curve, value = [], 1.0
    for n in range(1, trials + 1):
        if n & (n - 1) == 0 and n <= 16:  # a new best at 1, 2, 4, 8, 16 trials
            value *= 1.0 - 5 * CONVERGED
        curve.append(value)
    return curve


@pytest.fixture
def budgets(monkeypatch):
    """Run tune with a search that falls as ``_falling`` in the phase the rule judges (its TPE phase flat
    at 1.0 when there is a CMA-ES phase)."""
    asked = []

    def tune(out, controllers, handlings, seeds, budget, polish, workers, scheduler, listener=None):
        asked.append((budget, polish) if polish else budget)
        if not polish:
            return tuning_jobs.TuneOutcome(1, 0, False, _store(_falling(budget)))
        return tuning_jobs.TuneOutcome(1, 0, False, _store([1.0] * budget + _falling(polish), budget))

    monkeypatch.setattr(tuning_jobs, "tune", tune)
    return asked


def test_the_budget_doubles_until_doubling_moves_the_best_by_less_than_the_rule(budgets, tmp_path, capsys):
    assert main(["tune", "CT", "--handlings", "accel", "--seeds", "0", "--budget", "4", "--polish", "0",
                 "--until-converged", "256", "--out", str(tmp_path / "t.json")]) == 0
    assert budgets == [4, 8, 16, 32]  # at 32 the last half (17..32) found nothing better
    out = capsys.readouterr().out
    assert "every search goes on to 8" in out and "goes on to 64" not in out and "not converged" not in out
    assert "32 trials, best" in out and "(converged: the rule is below 1 %)" in out


def test_the_cap_bounds_the_doubling_and_says_what_did_not_converge(budgets, tmp_path, capsys):
    assert main(["tune", "CT", "--handlings", "accel", "--seeds", "0", "--budget", "4", "--polish", "0",
                 "--until-converged", "8", "--out", str(tmp_path / "t.json")]) == 0
    assert budgets == [4, 8]
    out = capsys.readouterr().out
    assert "not converged at 8 trials, the cap of --until-converged: CtController accel seed 0" in out
    assert "8 trials, best" in out and "(still improving: the rule is below 1 %)" in out


def test_without_the_option_one_budget_is_run(budgets, tmp_path):
    main(["tune", "CT", "--handlings", "accel", "--seeds", "0", "--budget", "4", "--polish", "0",
          "--out", str(tmp_path / "t.json")])
    assert budgets == [4]


def test_with_a_cma_es_phase_that_phase_doubles_and_the_tpe_budget_stays(budgets, tmp_path, capsys):
    assert main(["tune", "CT", "--handlings", "accel", "--seeds", "0", "--budget", "8", "--polish", "4",
                 "--until-converged", "256", "--out", str(tmp_path / "t.json")]) == 0
    assert budgets == [(8, 4), (8, 8), (8, 16), (8, 32)]
    out = capsys.readouterr().out
    assert "every CMA-ES phase goes on to 8" in out and "40 trials, best" in out
    assert "TPE 0.00 %, CMA-ES 0.00 % (converged" in out
