"""Intervals and paired verdicts of the fair comparison (orchestration.study.statistics)."""
import math
import warnings

import numpy as np
import pytest
from scipy.stats import bootstrap

from orchestration.study import statistics
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


def test_a_verdict_holds_only_where_every_draw_and_seed_gives_it_clear_of_the_marginal_band():
    from orchestration.reports.fair_tables import _agreed, _every, _seeds_cell
    from orchestration.study.statistics import Interval, PairedVerdict

    def verdict(low, high, said):
        return PairedVerdict(Interval(math.sqrt(low * high), low, high, 128, 0), said, 0, 0, 64)

    firm = {(7, 0): verdict(0.7, 0.9, "better"), (8, 0): verdict(0.8, 0.95, "better")}
    assert _agreed(firm) == "better" and _every(firm) == "**better**"
    marginal = {(7, 0): verdict(0.7, 0.9, "better"), (8, 0): verdict(0.8, 0.995, "better")}
    assert _agreed(marginal) is None and _every(marginal) == "marginal"
    split = {(7, 0): verdict(0.7, 0.9, "better"), (8, 0): verdict(0.9, 1.1, "not distinguishable")}
    assert _agreed(split) is None and _every(split) == "depends on the draw or seed"
    cell = _seeds_cell({(7, 0): verdict(0.7, 0.9, "better"), (7, 1): verdict(0.8, 0.995, "better"),
                        (7, 2): verdict(0.75, 0.85, "better")})
    assert cell == f"better 2, better (marginal) 1 of 3 seeds; A / B {math.sqrt(0.7 * 0.9):.3g}-{math.sqrt(0.8 * 0.995):.3g}"


# --- against scipy.stats.bootstrap called here, on the values the definition keeps --------------------------------

HOSTILE = [0.0, -0.0, -1e-3, -5.0, math.nan, math.inf, -math.inf, None]


def _kept(values) -> list[float]:
    """The runs with a figure: a finite positive number (a failed run has None, nan, inf; zero or less is none)."""
    return [float(v) for v in values if v is not None and math.isfinite(float(v)) and float(v) > 0.0]


def _scipy_bca(sample, confidence: float) -> tuple[float, float]:
    """BCa interval of the mean of one sample (the paired ratio's: the mean of the log differences), the mean summed
    left to right as ours is (numpy's pairwise sum moves BCa's count of resampled means below the sample's, and so
    the interval, where a resample's mean ties the sample's but for rounding)."""
    res = bootstrap((sample,), statistics.sequential_mean, method="BCa", confidence_level=confidence,
                    n_resamples=statistics.RESAMPLES, rng=np.random.default_rng(statistics.BOOTSTRAP_SEED))
    return res.confidence_interval.low, res.confidence_interval.high


@pytest.mark.parametrize("family", [1, 12])
@pytest.mark.parametrize("seed", [4, 5])
def test_the_geometric_interval_is_scipys_bca_on_the_runs_with_a_figure(seed, family):
    g = np.random.default_rng(seed)
    good = list(10 ** g.normal(-2, 0.5, 14))
    values = good[:5] + HOSTILE + good[5:]
    i = geometric_interval(values, family)
    logs = np.log10(_kept(values))
    assert (i.n, i.failed) == (len(good), len(HOSTILE))
    low, high = _scipy_bca(logs, 1.0 - 0.05 / family)
    assert (i.value, i.low, i.high) == pytest.approx((10 ** np.mean(logs), 10 ** low, 10 ** high), rel=1e-12)


@pytest.mark.parametrize("seed", [6, 7])
def test_the_paired_ratio_is_scipys_paired_bca_on_the_points_where_both_ran(seed):
    g = np.random.default_rng(seed)
    b = list(10 ** g.uniform(-3, 0, 14))
    a = [v * 0.9 * 10 ** g.normal(0, 0.1) for v in b]
    a_all, b_all = a[:3] + HOSTILE + a[3:] + [1.0] * 4, b[:3] + [1.0] * 8 + b[3:] + HOSTILE[:4]
    v = paired(a_all, b_all)
    both = [k for k in range(len(a_all)) if _kept([a_all[k]]) and _kept([b_all[k]])]
    la, lb = (np.log10([float(x[k]) for k in both]) for x in (a_all, b_all))
    assert (v.ratio.n, v.failed_a, v.failed_b) == (len(b), len(HOSTILE), 4)
    assert v.worse_on == int(np.sum(la > lb))
    low, high = _scipy_bca(la - lb, 0.95)
    assert (v.ratio.value, v.ratio.low, v.ratio.high) == pytest.approx(
        (10 ** np.mean(la - lb), 10 ** low, 10 ** high), rel=1e-12)
    assert v.verdict == ("better" if 10 ** high < 1 else "worse" if 10 ** low > 1 else "not distinguishable")


@pytest.mark.parametrize("n", [16, 128])
def test_resampling_the_differences_is_scipys_paired_bootstrap_to_the_bit(n):
    """statistics.bca_intervals resamples the per-point differences: the same interval, bit for bit, as scipy's
    paired bootstrap of the two samples with the same statistic."""
    g = np.random.default_rng(n)
    a, b = g.normal(size=n), g.normal(0.1, 1.2, size=n)
    res = bootstrap((a, b), lambda x, y, axis: statistics.sequential_mean(x - y, axis), paired=True, vectorized=True,
                    method="BCa", confidence_level=0.999, n_resamples=statistics.RESAMPLES,
                    rng=np.random.default_rng(statistics.BOOTSTRAP_SEED))
    assert statistics.bca_intervals([a - b], 0.999) == [(res.confidence_interval.low, res.confidence_interval.high)]


def test_samples_bootstrapped_together_get_the_bits_each_gets_alone():
    """More samples than one call takes, of two lengths, with nothing to resample in some: each interval is the one
    its sample gets on its own, bit for bit (so a table's figures do not depend on what else it bootstraps)."""
    g = np.random.default_rng(11)
    diffs = [g.normal(size=40) for _ in range(statistics.ROWS + 3)] + [g.normal(size=17), np.full(9, 0.25),
                                                                       np.array([2.0]), np.array([])]
    together = statistics.bca_intervals(diffs, 0.99)
    alone = [statistics.bca_intervals([d], 0.99)[0] for d in diffs]
    assert together == alone
    assert together[-3:-1] == [(0.25, 0.25), (2.0, 2.0)] and all(math.isnan(x) for x in together[-1])
    pairs = [(list(10 ** g.normal(size=12)), list(10 ** g.normal(size=12))) for _ in range(3)] + [([1.0, None], [2.0, 3.0])]
    assert statistics.paired_verdicts(pairs, 4) == [paired(a, b, 4) for a, b in pairs]
    values = [a for a, _ in pairs]
    assert statistics.geometric_intervals(values, 4) == [geometric_interval(v, 4) for v in values]


def test_the_sequential_mean_is_the_mean_in_every_layout():
    """Summed left to right: within rounding of the exact mean (math.fsum), and the same bits for a row in a C- or
    Fortran-ordered array, a transposed view, or alone."""
    g = np.random.default_rng(12)
    x = g.normal(size=(5, 33)) * 10 ** g.uniform(-3, 3, size=(5, 33))
    rows = [statistics.sequential_mean(r) for r in x]
    for r, got in zip(x, rows):
        assert got == pytest.approx(math.fsum(r) / len(r), rel=1e-12, abs=1e-15)
    for layout in (x, np.asfortranarray(x), x.T.copy().T, np.moveaxis(x.T, 0, 1)):
        assert list(statistics.sequential_mean(layout)) == rows
    assert list(statistics.sequential_mean(x.T, axis=0)) == rows


@pytest.mark.parametrize("values, n", [([2.0] * 5 + HOSTILE, 5), ([3.0] + HOSTILE, 1), (HOSTILE, 0)])
def test_alike_single_or_no_usable_values(values, n):
    """Nothing to resample: all alike or one value gives the value itself as its interval, none gives nan."""
    i = geometric_interval(values)
    assert (i.n, i.failed) == (n, len(HOSTILE))
    if n:
        assert i.value == i.low == i.high == pytest.approx(values[0], rel=1e-15)
    else:
        assert math.isnan(i.value) and math.isnan(i.low) and math.isnan(i.high)


def test_two_values_are_resampled_and_the_default_family_is_one():
    i, logs = geometric_interval([1.0, 10.0]), np.log10([1.0, 10.0])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # BCa on two points warns of a degenerate resample
        low, high = _scipy_bca(logs, 0.95)
    assert (i.low, i.high) == pytest.approx((10 ** low, 10 ** high), rel=1e-12, nan_ok=True)
    assert (statistics.level(), statistics.level(10)) == (0.95, 0.995)


def test_without_a_family_each_interval_is_a_single_verdicts():
    g = np.random.default_rng(13)
    a, b = list(10 ** g.normal(size=20)), list(10 ** g.normal(0.3, 1.0, size=20))
    assert geometric_interval(a) == geometric_interval(a, 1) != geometric_interval(a, 2)
    assert statistics.geometric_intervals([a]) == [geometric_interval(a, 1)]
    assert paired(a, b) == paired(a, b, 1) != paired(a, b, 2)
    assert statistics.paired_verdicts([(a, b)]) == [paired(a, b, 1)]


def test_no_usable_value_gives_nan_without_a_warning():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        i, v = geometric_interval(HOSTILE), paired(HOSTILE, [1.0] * len(HOSTILE))
    assert math.isnan(i.value) and math.isnan(i.low) and (i.n, i.failed) == (0, len(HOSTILE))
    assert v.verdict == "not distinguishable" and (v.ratio.n, v.ratio.failed) == (0, 0) and v.said == v.verdict


@pytest.mark.parametrize("a, verdict", [(0.5, "better"), (2.0, "worse"), (1.0, "not distinguishable")])
def test_a_single_pair_is_its_own_interval(a, verdict):
    v = paired([a, None], [1.0, 1.0])
    assert (v.ratio.n, v.ratio.failed, v.failed_a, v.verdict) == (1, 0, 1, verdict)
    assert v.ratio.value == v.ratio.low == v.ratio.high == pytest.approx(a, rel=1e-15)


def test_single_precision_figures_are_taken_in_double():
    """The logarithms are taken of float64 copies: MSEs handed over as float32 (a store read with numpy, say)
    give the interval of their exact values, not logarithms rounded to single precision."""
    values = [0.0123, 0.0456, 0.0789, 0.0321, 0.0654, 0.0987]
    single = [np.float32(v) for v in values]
    assert geometric_interval(single) == geometric_interval([float(v) for v in single])
