"""Intervals and paired verdicts for comparisons over many initial states (``scipy.stats.bootstrap``).

Tracking errors span decades between initial states, so a controller's figure over a set of points is
its geometric mean, and two controllers are compared by the geometric mean of their per-point ratio
(the mean of log10 ratios, paired on the same point). Intervals: ``scipy.stats.bootstrap``, BCa
(bias-corrected and accelerated), ``RESAMPLES`` seeded resamples of the points, paired for a ratio.
Verdict: "better" when the whole interval of the ratio A / B lies below 1, "worse" when it lies above,
else "not distinguishable"; beside it, on how many points A is worse than B. A "better" or "worse"
whose corrected bound nearest 1 lies within ``MARGINAL`` of 1 is said "marginal": one more draw of the
tuning or of the points could turn it (a hidden redraw of the tuning seeds turned such verdicts).

Multiple comparisons: a table that states several verdicts states them as one family, and each of its
intervals is taken at 1 - 0.05 / m for a family of m verdicts (Bonferroni: every verdict of the family
holds at once with at least 95 %). Bonferroni rather than Holm because the verdicts are read off
intervals: Bonferroni's corrected intervals say the same as its corrected tests, Holm's step-down has
no interval form. A run that failed has no figure; it is counted apart, and the pairs use the points
where both ran.
"""
from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np
from scipy.stats import bootstrap

LEVEL = 0.95  # of a whole family of verdicts
RESAMPLES = 20_000
BOOTSTRAP_SEED = 0
MARGINAL = 0.01  # a verdict whose bound nearest 1 is within 1 % of 1


def level(family: int = 1) -> float:
    """The confidence of each interval in a family of ``family`` verdicts (Bonferroni)."""
    return 1.0 - (1.0 - LEVEL) / family


def _bca(samples: tuple[np.ndarray, ...], confidence: float) -> tuple[float, float]:
    """BCa interval of the mean (of the paired difference, for two samples)."""
    diff = samples[0] - samples[1] if len(samples) == 2 else samples[0]
    if len(diff) < 2 or np.ptp(diff) == 0.0:  # one point, or all alike: nothing to resample
        return (float(diff.mean()), float(diff.mean())) if len(diff) else (math.nan, math.nan)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # BCa's own warning on a near-degenerate sample
        # a paired bootstrap of the mean difference resamples the per-point differences: the same resamples
        # and jackknife as bootstrap(samples, paired=True) (the same bits: tests/unit/test_statistics.py),
        # a third of its time
        res = bootstrap((diff,), lambda x, axis: np.mean(x, axis=axis), vectorized=True, method="BCa",
                        confidence_level=confidence, n_resamples=RESAMPLES, rng=np.random.default_rng(BOOTSTRAP_SEED))
    return float(res.confidence_interval.low), float(res.confidence_interval.high)


@dataclass(frozen=True)
class Interval:
    """A geometric mean and its interval over the points that ran; ``failed`` did not."""

    value: float
    low: float
    high: float
    n: int
    failed: int


def _usable(values) -> np.ndarray:
    a = np.array([math.nan if v is None else float(v) for v in values])
    return np.isfinite(a) & (a > 0)


def _interval(samples: tuple[np.ndarray, ...], failed: int, family: int) -> Interval:
    mean = float(np.mean(samples[0] - samples[1] if len(samples) == 2 else samples[0])) if len(samples[0]) else math.nan
    low, high = _bca(samples, level(family))
    return Interval(10 ** mean, 10 ** low, 10 ** high, len(samples[0]), failed)


def geometric_interval(values, family: int = 1) -> Interval:
    ok = _usable(values)
    logs = np.log10(np.array([v for v, u in zip(values, ok) if u], dtype=float))
    return _interval((logs,), int(len(ok) - len(logs)), family)


@dataclass(frozen=True)
class PairedVerdict:
    ratio: Interval  # geometric mean of A / B per point, with its interval
    verdict: str  # "better" (A lower), "worse" (A higher), "not distinguishable"
    failed_a: int
    failed_b: int
    worse_on: int  # points where A is higher than B (of ratio.n)

    @property
    def marginal(self) -> bool:
        """A "better" or "worse" whose corrected bound nearest 1 lies within ``MARGINAL`` of 1."""
        if self.verdict == "better":
            return self.ratio.high > 1.0 - MARGINAL
        return self.verdict == "worse" and self.ratio.low < 1.0 + MARGINAL

    @property
    def said(self) -> str:
        """The verdict as printed: "marginal" marked."""
        return self.verdict + (" (marginal)" if self.marginal else "")


def paired(a, b, family: int = 1) -> PairedVerdict:
    """A against B on the same points (lower is better), one verdict of a family of ``family``."""
    ok_a, ok_b = _usable(a), _usable(b)
    both = ok_a & ok_b
    la = np.log10(np.array([float(x) for x, u in zip(a, both) if u]))
    lb = np.log10(np.array([float(y) for y, u in zip(b, both) if u]))
    ratio = _interval((la, lb), 0, family)
    if ratio.n == 0:
        verdict = "not distinguishable"
    elif ratio.high < 1.0:
        verdict = "better"
    elif ratio.low > 1.0:
        verdict = "worse"
    else:
        verdict = "not distinguishable"
    return PairedVerdict(ratio, verdict, int(np.sum(~ok_a)), int(np.sum(~ok_b)), int(np.sum(la > lb)))
