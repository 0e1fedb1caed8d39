"""The digit rule of the generated tables (orchestration.markdown.stable, stable_pair): a figure is printed
only to the digits it shares with every perturbed run; a figure of which fewer than two digits hold is printed
as chaotic with the median and range of all runs; a reading's chaos (comparison.chaos_of) from the same runs;
the ladder of perturbations (comparison.PERTURBATIONS) pinned. Constructed values only."""
from __future__ import annotations

import math

import pytest
from hypothesis import given, strategies as st

from orchestration.markdown import MIN_DIGITS, stable, stable_pair
from orchestration.study.comparison import (CHAOS_THRESHOLD, LADDER_DIRECTIONS, LADDER_SEED, LADDER_SIZES,
                                             PERTURBATIONS, chaos_of, ladder_directions)


def test_all_digits_when_every_run_agrees():
    assert stable(0.0123456, [0.0123456] * 8) == "0.01235"
    assert stable(0.0123456, [0.0123456] * 8, ".3g") == "0.0123"


def test_only_the_digits_every_run_shares():
    # one run of eight differs in the third digit: two digits are printed, not the three the others share
    others = [0.012345] * 7 + [0.01241]
    assert stable(0.012345, others) == "0.012"
    assert stable(0.012345, others[:7]) == format(0.012345, ".4g")


def test_a_figure_without_two_digits_that_hold_is_chaotic_with_the_median_and_range_of_all_runs():
    text = stable(0.02, [0.0075, 0.125, 0.03, 0.02, 0.02, 0.02, 0.02, 0.02])
    assert text == "chaotic: 0.02 (0.0075–0.13)"  # the range rounded outwards, the nominal inside it
    assert stable(0.0027, [0.0026]) == "chaotic: 0.0027 (0.0026–0.0027)"  # one digit holds, not two
    assert stable(0.5, [0.51, 0.49], ".2g") == "chaotic: 0.5 (0.49–0.51)"


def test_the_range_and_median_include_the_nominal_run():
    assert stable(0.9, [0.1] * 8) == "chaotic: 0.1 (0.1–0.9)"
    assert stable(0.05, [0.5, 0.2]) == "chaotic: 0.2 (0.05–0.5)"


def test_counts_and_missing_figures():
    assert stable(12, [12] * 8) == "12"
    assert stable(12, [12, 13, 11]) == "11–13"
    assert stable(None, [None] * 8) == "-"
    assert stable(None, [None, 3.5]) == "- (or 3.5)"
    assert stable(2.5, [2.5, None, float("nan")]) == "2.5 (or -)"


def test_a_figure_some_runs_lack_is_judged_over_the_runs_that_have_it():
    assert stable(1.8e-08, [2.2e-06, None, 7.1e-08]) == "chaotic: 7.1e-08 (1.8e-08–2.2e-06) (or -)"
    assert stable(None, [0.0123, 0.0124]) == "- (or 0.012)"
    assert stable(3, [None, 5]) == "3–5 (or -)"


def test_pairs_are_judged_joint_by_joint():
    others = [(0.00271, 0.0084)] * 7 + [(0.00274, 0.0084)]
    assert stable_pair((0.00271, 0.0084), others) == "0.0027 / 0.0084"
    assert stable_pair((0.0027, 0.0084), [None] + [(0.0027, 0.0084)] * 7) == "0.0027 (or -) / 0.0084 (or -)"
    assert stable_pair(None, others) == "-"


@given(st.floats(1e-6, 1e6), st.lists(st.floats(-0.4, 0.4), min_size=1, max_size=8))
def test_printed_digits_are_shared_by_every_run(value, changes):
    others = [value * (1.0 + c) for c in changes]
    text = stable(value, others)
    if text.startswith("chaotic: "):
        median, span = text.removeprefix("chaotic: ").removesuffix(")").split(" (")
        low, high = (float(t) for t in span.split("–"))
        assert low <= min(value, *others) and max(value, *others) <= high and low <= float(median) <= high
        assert any(format(o, f".{MIN_DIGITS}g") != format(value, f".{MIN_DIGITS}g") for o in others)
    else:
        digits = len(text.replace("-", "").replace(".", "").split("e")[0].lstrip("0")) or 1
        assert all(format(o, f".{digits}g") == format(value, f".{digits}g") for o in others)
        assert math.isclose(float(text), value, rel_tol=10.0 ** (1 - digits))


def test_the_ladder_of_perturbations_is_pinned():
    """Every size from 1e-13 to 1e-8 in the same 8 seeded directions, each moving the angles and the velocities;
    the largest component of each is the size itself; the seed and its first direction pinned (a change of
    either changes every stored perturbed run: docs/perturbed.json says which it holds)."""
    assert LADDER_SIZES == (1e-13, 1e-12, 1e-11, 1e-10, 1e-9, 1e-8) and LADDER_DIRECTIONS == 8
    assert LADDER_SEED == 20261129
    directions = ladder_directions()
    assert directions[0] == (1.0, -0.6030204962243797, 0.7896440129449838, -0.7335490830636462)
    assert len(set(directions)) == 8 and all(max(abs(c) for c in d) == 1.0 for d in directions)
    assert all(any(d[:2]) and any(d[2:]) for d in directions)  # angles and velocities
    assert len(PERTURBATIONS) == 48 and len(set(PERTURBATIONS)) == 48
    for k, size in enumerate(LADDER_SIZES):
        rung = PERTURBATIONS[8 * k:8 * k + 8]
        assert [max(abs(c) for c in p) for p in rung] == [size] * 8
        assert all(p == tuple(size * c for c in d) for p, d in zip(rung, directions))


def _mse(total: float) -> dict:
    return {"mse": [total / 4, 3 * total / 4]}


def test_a_reading_is_chaotic_when_table_1s_metric_moves_under_a_perturbation():
    steady = [_mse(0.011 * (1 + c)) for c in (1e-6, 2e-6, CHAOS_THRESHOLD / 2)]
    assert chaos_of(_mse(0.011), steady) is None
    moving = steady + [_mse(0.011 * 1.5)]
    assert chaos_of(_mse(0.011), moving) == ("chaotic (MSE_1 + MSE_2 chaotic: 0.011 (0.011–0.017); moves up to 50 % under 4 "
                                             "perturbations of the initial state)")
    far = [_mse(8.3 * c) for c in (1.2, 0.9)]
    assert chaos_of(_mse(8.3), far).startswith("does not track (MSE_1 + MSE_2 ")


def test_a_reading_without_a_finite_metric_does_not_track():
    text = chaos_of(_mse(8.3), [{"mse": [None, None]}])
    assert text.startswith("does not track") and "is not finite under 1 perturbations" in text
