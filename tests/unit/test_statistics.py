"""Intervals and paired verdicts of the fair comparison (orchestration.study.statistics)."""
import math

import numpy as np

from orchestration.study.statistics import geometric_interval, paired


def test_the_geometric_interval_holds_the_geometric_mean_and_counts_failures():
    g = np.random.default_rng(1)
    values = list(10 ** g.normal(-2, 0.3, 16)) + [None, math.inf]
    i = geometric_interval(values)
    assert i.n == 16 and i.failed == 2
    assert i.low < i.value < i.high
    assert math.isclose(i.value, 10 ** np.mean(np.log10(values[:16])))


def test_paired_verdicts_follow_the_interval_of_the_ratio():
    g = np.random.default_rng(2)
    b = 10 ** g.uniform(-3, 0, 16)  # spread over decades: only pairing sees the effect
    assert paired(b * 0.8 * 10 ** g.normal(0, 0.02, 16), b).verdict == "better"
    assert paired(b * 1.25 * 10 ** g.normal(0, 0.02, 16), b).verdict == "worse"
    same = paired(b * 10 ** g.normal(0, 0.2, 16), b)
    assert same.verdict == "not distinguishable" and same.ratio.low < 1 < same.ratio.high


def test_a_failed_run_is_counted_apart_and_left_out_of_the_pairs():
    v = paired([1.0, None, 2.0, 4.0], [2.0, 1.0, 4.0, None])
    assert (v.failed_a, v.failed_b, v.ratio.n) == (1, 1, 2)
    assert math.isclose(v.ratio.value, 0.5) and v.verdict == "better"


def test_a_larger_family_widens_every_interval_and_can_undo_a_verdict():
    g = np.random.default_rng(3)
    b = 10 ** g.uniform(-3, 0, 16)
    a = b * 0.95 * 10 ** g.normal(0, 0.03, 16)
    alone, in_family = paired(a, b), paired(a, b, family=144)
    assert in_family.ratio.low < alone.ratio.low and in_family.ratio.high > alone.ratio.high
    assert alone.verdict == "better" and in_family.verdict == "not distinguishable"
    assert math.isclose(alone.ratio.value, in_family.ratio.value)


def test_the_sign_count_says_on_how_many_points_a_is_worse():
    v = paired([1.0, 3.0, 2.0, 5.0, 1.0], [2.0, 1.0, 4.0, 4.0, 1.0])
    assert v.worse_on == 2 and v.ratio.n == 5


def test_identical_configurations_are_not_distinguishable_and_their_interval_is_a_point():
    values = [0.1, 0.02, 0.3, 0.004]
    v = paired(values, values)
    assert v.verdict == "not distinguishable" and v.ratio.low == v.ratio.high == 1.0 and v.worse_on == 0


def test_a_verdict_whose_bound_is_within_one_percent_of_one_is_marginal():
    from orchestration.study.statistics import MARGINAL, Interval, PairedVerdict

    def verdict(low, high, said):
        return PairedVerdict(Interval(math.sqrt(low * high), low, high, 16, 0), said, 0, 0, 8)

    assert verdict(0.80, 0.995, "better").marginal and verdict(0.80, 0.995, "better").said == "better (marginal)"
    assert not verdict(0.80, 1.0 - 2 * MARGINAL, "better").marginal
    assert verdict(1.005, 1.3, "worse").marginal and not verdict(1.02, 1.3, "worse").marginal
    assert not verdict(0.9, 1.1, "not distinguishable").marginal


def test_a_verdict_across_seeds_holds_only_where_every_seed_gives_it_and_names_the_marginal_ones():
    from orchestration.reports.fair_tables import _across
    from orchestration.study.statistics import Interval, PairedVerdict

    def verdict(low, high, said):
        return PairedVerdict(Interval(math.sqrt(low * high), low, high, 16, 0), said, 0, 0, 8)

    every = _across({0: verdict(0.7, 0.9, "better"), 1: verdict(0.8, 0.995, "better")}, "mse")
    assert every.startswith("mse marginal: better for every tuning seed, but within 1 % of 1 for seed 1, so a new "
                            "tuning draw may not give it (")
    assert "seed 1: better (marginal)" in every and "seed 0: better," in every
    split = _across({0: verdict(0.7, 0.9, "better"), 1: verdict(0.9, 1.1, "not distinguishable")}, "mse")
    assert split.startswith("mse depends on the tuning seed (") and "seed 1: not distinguishable" in split
    firm = _across({0: verdict(0.7, 0.9, "better"), 1: verdict(0.8, 0.95, "better")}, "mse")
    assert firm.startswith("mse better for every tuning seed (")
