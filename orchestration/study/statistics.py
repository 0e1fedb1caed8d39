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


ROWS = 32  # samples bootstrapped in one call, BATCH resamples at a time: 32 x 250 x 128 doubles (8 MB) stay in
BATCH = 250  # the cache; four times faster than one sample and all resamples a call (measured, 128 points a sample)


def sequential_mean(x: np.ndarray, axis: int = -1) -> np.ndarray:
    """The mean along ``axis``, summed left to right: the same bits for a sample whatever the shape and memory
    layout of the array it is in (numpy's own mean sums a contiguous last axis pairwise and any other axis left
    to right, and scipy gathers the resamples of several samples with the samples innermost)."""
    terms = np.moveaxis(np.asarray(x), axis, 0)
    total = terms[0].copy(order="K")  # in the terms' own layout: every sum below runs through memory in order
    for term in terms[1:]:
        total += term
    mean = total / len(terms)
    # C order, as scipy's later sums over the last axis take each row alone (pairwise) only there
    return np.ascontiguousarray(mean) if mean.ndim else mean


def _degenerate(diff: np.ndarray) -> tuple[float, float] | None:
    """The interval of a sample with nothing to resample (one point, or all alike), else None."""
    if len(diff) and (len(diff) < 2 or np.ptp(diff) == 0.0):
        return float(diff.mean()), float(diff.mean())
    return (math.nan, math.nan) if not len(diff) else None


def bca_intervals(diffs: list[np.ndarray], confidence: float) -> list[tuple[float, float]]:
    """BCa intervals of the mean of each sample (a paired comparison's: of its per-point differences), those of
    one length ``ROWS`` at a time in one ``scipy.stats.bootstrap`` call: every sample gets the same seeded
    resamples of its points, and the same bits as bootstrapped alone (``sequential_mean``)."""
    out: list[tuple[float, float] | None] = [_degenerate(d) for d in diffs]
    groups: dict[int, list[int]] = {}
    for i, d in enumerate(diffs):
        if out[i] is None:
            groups.setdefault(len(d), []).append(i)
    for rows in (g[k:k + ROWS] for g in groups.values() for k in range(0, len(g), ROWS)):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # BCa's own warning on a near-degenerate sample
            # a paired bootstrap of the mean difference resamples the per-point differences: the same resamples
            # and jackknife as bootstrap(samples, paired=True) (tests/unit/test_statistics.py)
            res = bootstrap((np.stack([diffs[i] for i in rows]),), sequential_mean, axis=-1, vectorized=True,
                            method="BCa", confidence_level=confidence, n_resamples=RESAMPLES, batch=BATCH,
                            rng=np.random.default_rng(BOOTSTRAP_SEED))
        for i, low, high in zip(rows, res.confidence_interval.low, res.confidence_interval.high):
            out[i] = (float(low), float(high))
    return out  # type: ignore[return-value]


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


def _intervals(samples: list[tuple[np.ndarray, ...]], failed: list[int], family: int) -> list[Interval]:
    diffs = [x[0] - x[1] if len(x) == 2 else x[0] for x in samples]
    bounds = bca_intervals(diffs, level(family))
    return [Interval(10 ** (float(np.mean(d)) if len(d) else math.nan), 10 ** low, 10 ** high, len(d), f)
            for d, (low, high), f in zip(diffs, bounds, failed)]


def geometric_intervals(values: list, family: int = 1) -> list[Interval]:
    """``geometric_interval`` of each of ``values``, bootstrapped together."""
    logs, failed = [], []
    for v in values:
        ok = _usable(v)
        logs.append(np.log10(np.array([x for x, u in zip(v, ok) if u], dtype=float)))
        failed.append(int(len(ok) - len(logs[-1])))
    return _intervals([(x,) for x in logs], failed, family)


def geometric_interval(values, family: int = 1) -> Interval:
    """The geometric mean of the usable (finite, positive) values with its BCa interval; the others counted failed."""
    return geometric_intervals([values], family)[0]


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


def paired_verdicts(pairs: list[tuple[list, list]], family: int = 1) -> list[PairedVerdict]:
    """``paired`` of each (A, B) of ``pairs``, bootstrapped together."""
    logs, counts = [], []
    for a, b in pairs:
        ok_a, ok_b = _usable(a), _usable(b)
        both = ok_a & ok_b
        la = np.log10(np.array([float(x) for x, u in zip(a, both) if u]))
        lb = np.log10(np.array([float(y) for y, u in zip(b, both) if u]))
        logs.append((la, lb))
        counts.append((int(np.sum(~ok_a)), int(np.sum(~ok_b)), int(np.sum(la > lb))))
    ratios = _intervals(logs, [0] * len(pairs), family)
    return [PairedVerdict(r, _verdict(r), *c) for r, c in zip(ratios, counts)]


def _verdict(ratio: Interval) -> str:
    if ratio.n and ratio.high < 1.0:
        return "better"
    if ratio.n and ratio.low > 1.0:
        return "worse"
    return "not distinguishable"


def paired(a, b, family: int = 1) -> PairedVerdict:
    """A against B on the same points (lower is better), one verdict of a family of ``family``."""
    return paired_verdicts([(a, b)], family)[0]
