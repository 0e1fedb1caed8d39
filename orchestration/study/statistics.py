"""Intervals and paired verdicts for comparisons over many initial states (plain numpy).

Tracking errors span decades between initial states, so a controller's figure over a set of points is
its geometric mean, and two controllers are compared by the geometric mean of their per-point ratio
(the mean of log10 ratios, paired on the same point). Intervals: seeded percentile bootstrap of that
mean, ``RESAMPLES`` resamples, 95 %. Verdict: "better" when the whole interval of the ratio A / B lies
below 1, "worse" when it lies above, else "not distinguishable". A run that failed has no figure; it
is counted apart, and the pairs use the points where both ran.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

LEVEL = 0.95
RESAMPLES = 10_000
BOOTSTRAP_SEED = 0


def _bootstrap(values: np.ndarray) -> tuple[float, float]:
    rng = np.random.default_rng(BOOTSTRAP_SEED)
    means = values[rng.integers(0, len(values), (RESAMPLES, len(values)))].mean(axis=1)
    tail = 100 * (1 - LEVEL) / 2
    return float(np.percentile(means, tail)), float(np.percentile(means, 100 - tail))


@dataclass(frozen=True)
class Interval:
    """A geometric mean and its 95 % interval over the points that ran; ``failed`` did not."""

    value: float
    low: float
    high: float
    n: int
    failed: int


def _usable(values) -> np.ndarray:
    a = np.array([math.nan if v is None else float(v) for v in values])
    return np.isfinite(a) & (a > 0)


def geometric_interval(values) -> Interval:
    ok = _usable(values)
    logs = np.log10(np.array([v for v, u in zip(values, ok) if u], dtype=float))
    if len(logs) == 0:
        return Interval(math.nan, math.nan, math.nan, 0, len(ok))
    low, high = _bootstrap(logs)
    return Interval(10 ** float(logs.mean()), 10 ** low, 10 ** high, len(logs), int(len(ok) - len(logs)))


@dataclass(frozen=True)
class PairedVerdict:
    ratio: Interval  # geometric mean of A / B per point, with its interval
    verdict: str  # "better" (A lower), "worse" (A higher), "not distinguishable"
    failed_a: int
    failed_b: int


def paired(a, b) -> PairedVerdict:
    """A against B on the same points (lower is better)."""
    ok_a, ok_b = _usable(a), _usable(b)
    both = ok_a & ok_b
    ratios = [float(x) / float(y) for x, y, u in zip(a, b, both) if u]
    ratio = geometric_interval(ratios)
    if ratio.n == 0:
        verdict = "not distinguishable"
    elif ratio.high < 1.0:
        verdict = "better"
    elif ratio.low > 1.0:
        verdict = "worse"
    else:
        verdict = "not distinguishable"
    return PairedVerdict(ratio, verdict, int(np.sum(~ok_a)), int(np.sum(~ok_b)))
