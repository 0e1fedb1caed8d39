"""The README's verdict line states only what every draw of the held-out points and every tuning seed gives on
the tuned-for measure, clear of the marginal band; everything else is left to docs/robustness.md."""
from __future__ import annotations

import pytest

from orchestration.reports import fair_tables
from orchestration.study.statistics import Interval, PairedVerdict


def _v(verdict: str, value: float, low: float, high: float) -> PairedVerdict:
    return PairedVerdict(Interval(value, low, high, 16, 0), verdict, 0, 0, 8)


BETTER = _v("better", 0.8, 0.7, 0.9)
WORSE = _v("worse", 1.3, 1.1, 1.5)
MARGINAL_WORSE = _v("worse", 1.2, 1.005, 1.4)
NEITHER = _v("not distinguishable", 1.0, 0.9, 1.1)


@pytest.fixture
def said(monkeypatch):
    def headline(per_pair: dict) -> str:
        against = {("initial states", f, name): per_pair.get((f, name), {(7, 0): NEITHER, (8, 1): NEITHER})
                   for f in fair_tables.BASELINES for name in ("mse", "tail")}
        data = {"seeds": [0, 1], "draws": [7, 8], "n_points": 128}
        monkeypatch.setattr(fair_tables, "_stored_verdicts", lambda root: (data, against, 44, {}))
        monkeypatch.setattr(fair_tables, "stored_tuning", lambda: {"budget": 256})
        return fair_tables.headline(None)
    monkeypatch.setattr(fair_tables, "unconverged", lambda data: [])
    return headline


def test_a_verdict_every_seed_gives_is_stated(said):
    text = said({("CtController", "mse"): {(7, 0): WORSE, (8, 1): _v("worse", 1.1, 1.05, 1.2)}})
    assert ("the tuned SOTC is worse than CT on the initial states set (mse, A / B 1.1 to 1.3 over 2 draws x 2 seeds)"
            in text)
    assert "on 2 independent draws of 128 points per set" in text
    assert "every search converged" in text


@pytest.mark.parametrize("per_seed", [{(7, 0): BETTER, (8, 0): NEITHER}, {(7, 0): WORSE, (7, 1): MARGINAL_WORSE},
                                      {(7, 0): NEITHER, (8, 1): NEITHER}],
                         ids=["depends on the draw", "marginal for one seed", "not distinguishable"])
def test_what_not_every_seed_gives_clearly_is_not_stated(said, per_seed):
    text = said({("CtController", "mse"): per_seed})
    assert "the tuned SOTC is" not in text and "no MSE verdict" in text


def test_the_tail_is_never_a_headline(said):
    text = said({("LqrController", "tail"): {(7, 0): WORSE, (8, 1): WORSE}})
    assert "tail" not in text.split("Every other")[0] and "no MSE verdict" in text


def test_searches_still_improving_are_named_when_they_are_the_verdicts_own(said, monkeypatch):
    monkeypatch.setattr(fair_tables, "unconverged", lambda data: ["SotcController radial seed 2"])
    assert "every accel search converged by the stated rule, 1 under other handlings not yet" in said({})
    monkeypatch.setattr(fair_tables, "unconverged", lambda data: ["CtController accel seed 1"])
    assert "NOT converged by the stated rule: CtController accel seed 1" in said({})
