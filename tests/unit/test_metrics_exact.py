"""``tracking_metrics`` against its docstring, each metric computed here by a plain loop over the samples of a
synthetic 60 s run (errors that decay and flare, torques below, on and over the limit, the cost rate, the
error rate and the limit flags), whole and fed in blocks; ``weight_total_variation`` and ``settle_time`` alike."""
from __future__ import annotations

import math

import numpy as np
import pytest

from orchestration.run import metrics

N, DT, LIMIT = 6001, 0.01, 4.0


def synthetic_run():
    rng = np.random.default_rng(50)
    t = np.arange(N) * DT
    e = np.column_stack([0.5 * np.exp(-t / 3.0) * np.cos(3 * t), -0.2 * np.exp(-t / 8.0)]) + 1e-3 * rng.normal(size=(N, 2))
    e[4000, 1] = 0.05  # a late flare of joint 2 (t = 40 s)
    tau = rng.uniform(-3.0, 3.0, (N, 2))
    tau[::7] *= LIMIT / np.hypot(tau[::7, 0], tau[::7, 1])[:, None]  # on the limit
    tau[5::97] *= 2.0  # some over it
    return t, e, tau, rng.uniform(0.0, 2.0, N), rng.normal(size=(N, 2)), rng.uniform(size=N) < 0.01


def expected(t, e, tau, cost, e_dot, flags, stop) -> dict:
    """Each metric of the docstring by a plain loop."""
    n = len(t)
    ae = [[abs(e[k][j]) for k in range(n)] for j in range(2)]
    norms = [math.hypot(*tau[k]) for k in range(n)]

    def trapezoid(y):
        return math.fsum((t[k + 1] - t[k]) * (y[k] + y[k + 1]) / 2 for k in range(n - 1))

    def late_max(t0):
        ks = [k for k in range(n) if t[k] >= t0 - 1e-12]
        return [max(ae[j][k] for k in ks) for j in range(2)] if ks else None

    def mse_over(ks):
        return [math.fsum(e[k][j] ** 2 for k in ks) / len(ks) for j in range(2)] if ks else None

    def settle(j):
        out = [k for k in range(n) if ae[j][k] >= metrics.SETTLE_BAND]
        return t[0] if not out else None if out[-1] == n - 1 else t[out[-1] + 1]

    hits = [k for k in range(n) if flags[k]]
    duration = t[-1] - t[0]
    z2 = [e[k][0] ** 2 + e[k][1] ** 2 + (e_dot[k][0] + e[k][0]) ** 2 + (e_dot[k][1] + e[k][1]) ** 2 for k in range(n)]
    mse = mse_over(range(n))
    at = sum(1 for v in norms if v >= LIMIT - 1e-9)
    return {
        "n_samples": n, "duration": duration, "mse": mse, "rmse": [math.sqrt(v) for v in mse],
        "iae": [trapezoid(ae[j]) for j in range(2)], "max_abs_error": [max(ae[j]) for j in range(2)],
        "max_abs_error_after_20s": late_max(20.0), "max_abs_error_after_50s": late_max(50.0),
        "max_abs_error_last_half": late_max(stop / 2), "settle_time_10mrad": [settle(0), settle(1)],
        "max_abs_tau": [max(abs(tau[k][j]) for k in range(n)) for j in range(2)], "max_tau_norm": max(norms),
        "samples_at_limit": at, "fraction_at_limit": at / n,
        "samples_over_limit": sum(1 for v in norms if v > LIMIT + 1e-9),
        "control_energy": math.fsum((t[k + 1] - t[k]) * norms[k] ** 2 for k in range(n - 1)),
        "tau_total_variation_rate": [math.fsum(abs(tau[k + 1][j] - tau[k][j]) for k in range(n - 1)) / duration
                                     for j in range(2)],
        "cost_integral": trapezoid(cost), "torque_limit": LIMIT,
        "mse_after_5s": mse_over([k for k in range(n) if t[k] >= 5.0 - 1e-12]),
        "last_limit_time": t[hits[-1]] if hits else None,
        "mse_after_limit": mse_over(range(hits[-1] + 1 if hits else 0, n)),
        "tracking_cost": trapezoid(z2),
    }


def close(got, want) -> bool:
    if isinstance(want, list):
        return isinstance(got, list) and len(got) == len(want) and all(close(g, w) for g, w in zip(got, want))
    if want is None or isinstance(want, int):
        return got == want
    return got == pytest.approx(want, rel=1e-11, abs=1e-14)


@pytest.mark.parametrize("blocks", [1, 7, 613])
@pytest.mark.parametrize("stop", [None, 80.0])
def test_every_metric_is_its_definition(blocks, stop):
    t, e, tau, cost, e_dot, flags = synthetic_run()
    want = expected(t.tolist(), e.tolist(), tau.tolist(), cost.tolist(), e_dot.tolist(), flags.tolist(),
                    t[-1] if stop is None else stop)
    if blocks == 1:
        got = metrics.tracking_metrics(t, e, tau, LIMIT, cost, stop, e_dot, flags)
    else:
        acc = metrics.TrackingMetrics(LIMIT, t[-1] if stop is None else stop, True, True, True)
        for part in np.array_split(np.arange(N), blocks):
            acc.add(t[part], e[part], tau[part], cost[part], e_dot[part], flags[part])
        got = acc.result()
    assert set(got) == set(want)
    wrong = {k: (got[k], want[k]) for k in want if not close(got[k], want[k])}
    assert not wrong, wrong


def test_without_the_optional_signals_their_metrics_are_none():
    t, e, tau, *_ = synthetic_run()
    got = metrics.tracking_metrics(t[:300], e[:300], tau[:300])
    assert (got["cost_integral"], got["tracking_cost"], got["mse_after_limit"], got["last_limit_time"]) == (None,) * 4
    assert got["torque_limit"] == metrics.TORQUE_LIMIT and got["mse_after_5s"] is None
    assert got["max_abs_error_after_20s"] is None and got["max_abs_error_last_half"] is not None


def test_a_block_without_a_column_the_accumulator_needs_is_refused():
    acc = metrics.TrackingMetrics(LIMIT, 1.0, with_cost=True)
    with pytest.raises(ValueError, match="^cost_rate is needed in every block"):
        acc.add([0.0, 0.01], np.zeros((2, 2)), np.zeros((2, 2)))
    with pytest.raises(ValueError, match="^cost_rate has 3 values, the block needs 2$"):
        acc.add([0.0, 0.01], np.zeros((2, 2)), np.zeros((2, 2)), [1.0, 2.0, 3.0])


def test_weight_total_variation_is_the_sum_of_step_norms_in_the_window():
    rng = np.random.default_rng(51)
    t, w = np.arange(500) * 0.01, rng.normal(size=(500, 10))
    for t0, t1 in ((0.0, 5.0), (1.0, 2.5), (4.995, 10.0), (3.0, 3.0)):
        ks = [k for k in range(500) if t0 - 1e-9 <= t[k] <= t1 + 1e-9]
        want = math.fsum(math.sqrt(math.fsum((w[a + 1][i] - w[a][i]) ** 2 for i in range(10))) for a in ks[:-1])
        assert metrics.weight_total_variation(t, w, t0, t1) == pytest.approx(want, rel=1e-13, abs=0.0)


@pytest.mark.parametrize("err, want", [([0.5, 0.02, 0.001, 0.0], 0.2), ([0.001, 0.002], 0.0),
                                       ([0.5, 0.001, 0.3], None), ([0.5, 0.0, 0.01, 0.009], 0.3)])
def test_settle_time_is_the_first_sample_after_the_last_one_outside_the_band(err, want):
    t = np.arange(len(err)) * 0.1
    got = metrics.settle_time(t, np.array(err))
    assert got == (None if want is None else pytest.approx(want))


def test_the_last_half_is_that_of_the_last_sample_by_default():
    t = np.array([0.0, 1.0, 1.6, 2.0, 3.4])  # last half: t >= 1.7
    e = np.zeros((5, 2))
    e[2], e[3] = 0.3, 0.1
    assert metrics.tracking_metrics(t, e, np.zeros((5, 2)))["max_abs_error_last_half"] == [0.1, 0.1]


def test_no_sample_is_refused():
    with pytest.raises(ValueError, match="^tracking_metrics needs at least one sample$"):
        metrics.tracking_metrics([], np.zeros((0, 2)), np.zeros((0, 2)))
    with pytest.raises(ValueError, match="^tracking_metrics needs at least one sample$"):
        metrics.TrackingMetrics(LIMIT, 1.0).result()


def test_a_time_axis_that_does_not_increase_is_refused_with_its_message():
    for t in ([0.0, 0.0], [0.0, 0.02, 0.01]):
        with pytest.raises(ValueError, match="^t must be strictly increasing$"):
            metrics.tracking_metrics(np.array(t), np.zeros((len(t), 2)), np.zeros((len(t), 2)))
    acc = metrics.TrackingMetrics(LIMIT, 1.0)
    acc.add([0.5], np.zeros((1, 2)), np.zeros((1, 2)))
    with pytest.raises(ValueError, match="^t must be strictly increasing$"):  # across blocks too
        acc.add([0.5], np.zeros((1, 2)), np.zeros((1, 2)))


@pytest.mark.parametrize("name", ["e_dot", "limit_flags"])
def test_each_optional_column_is_named_when_missing(name):
    acc = metrics.TrackingMetrics(LIMIT, 1.0, with_e_dot=name == "e_dot", with_flags=name == "limit_flags")
    with pytest.raises(ValueError, match=f"^{name} is needed in every block"):
        acc.add([0.0], np.zeros((1, 2)), np.zeros((1, 2)))


def test_one_sample_and_a_short_run():
    one = metrics.tracking_metrics([2.0], [[0.1, -0.2]], [[1.0, -1.0]])
    assert (one["duration"], one["tau_total_variation_rate"], one["iae"]) == (0.0, [0.0, 0.0], [0.0, 0.0])
    assert one["settle_time_10mrad"] == [None, None] and one["n_samples"] == 1
    short = metrics.tracking_metrics([0.0, 0.5], [[0.0, 0.0], [0.0, 0.0]], [[1.0, 0.0], [0.0, 2.0]])
    assert short["tau_total_variation_rate"] == [2.0, 4.0] and short["settle_time_10mrad"] == [0.0, 0.0]


def test_a_block_that_starts_inside_the_band_after_one_that_ended_outside_settles_there():
    acc = metrics.TrackingMetrics(LIMIT, 1.0)
    acc.add([0.0, 0.1], [[0.5, 0.5], [0.5, 0.0]], np.zeros((2, 2)))
    acc.add([0.2, 0.3], [[0.0, 0.0], [0.0, 0.0]], np.zeros((2, 2)))
    assert acc.result()["settle_time_10mrad"] == [0.2, 0.1]


def test_a_diverged_run_reports_none_not_inf():
    got = metrics.tracking_metrics([0.0, 0.01], [[0.1, 0.1], [0.1, 0.1]], [[math.inf, 0.0], [1.0, 0.0]])
    assert got["max_tau_norm"] is None and got["control_energy"] is None and got["max_abs_tau"] == [None, 0.0]


def test_the_boundaries_count_as_the_docstring_says():
    """A sample at exactly t0 of a late window, |e| exactly at the band, ||tau|| exactly at limit - 1e-9 and
    limit + 1e-9, the limit acting at the last sample."""
    t = np.array([0.0, 1.0, 1.6, 2.0, 3.4])
    e = np.zeros((5, 2))
    e[2], e[3] = 0.3, 0.1
    assert metrics.tracking_metrics(t, e, np.zeros((5, 2)), stop_time=3.2)["max_abs_error_last_half"] == [0.3, 0.3]
    acc = metrics.TrackingMetrics(LIMIT, 1.0)
    acc.add([0.0, 0.1, 0.2], [[0.01, 0.5], [0.0, 0.5], [0.0, 0.0]], np.zeros((3, 2)))
    assert acc.result()["settle_time_10mrad"] == [0.1, 0.2]
    tau = [[LIMIT - metrics.LIMIT_TOLERANCE, 0.0], [LIMIT + metrics.LIMIT_TOLERANCE, 0.0], [0.0, 0.0]]
    got = metrics.tracking_metrics([0.0, 0.1, 0.2], np.zeros((3, 2)), tau, LIMIT, limit_flags=[0.0, 0.0, 1.0])
    assert (got["samples_at_limit"], got["samples_over_limit"]) == (2, 0)
    assert got["last_limit_time"] == 0.2 and got["mse_after_limit"] is None


def test_the_windows_take_a_sample_within_1e_12_s_of_their_start():
    for start, key in ((metrics.TRANSIENT_END, "mse_after_5s"), (20.0, "max_abs_error_after_20s")):
        got = metrics.tracking_metrics([0.0, start - 1e-12], [[0.0, 0.0], [0.1, 0.1]], np.zeros((2, 2)))
        assert got[key] == pytest.approx([0.01, 0.01] if key.startswith("mse") else [0.1, 0.1]), key


def test_the_weights_window_takes_samples_within_1e_9_s_of_its_ends():
    t, w = np.array([0.0, 1.0 - 1e-9, 2.0 + 1e-9, 3.0]), np.array([[0.0], [1.0], [3.0], [6.0]])
    assert metrics.weight_total_variation(t, w, 1.0, 2.0) == 2.0
