"""Hand-computable cases for orchestration.run.metrics.tracking_metrics."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

from orchestration.run.metrics import TrackingMetrics, settle_time, tracking_metrics

T = 0.01


def _grid(stop: float) -> np.ndarray:
    return np.arange(int(round(stop / T)) + 1) * T  # 0, 0.01, ..., stop


def test_constant_error_gives_known_mse_rmse_iae():
    t = _grid(10.0)
    e = np.tile([0.1, -0.2], (len(t), 1))
    tau = np.zeros((len(t), 2))
    m = tracking_metrics(t, e, tau)
    assert m["n_samples"] == 1001 and m["duration"] == pytest.approx(10.0)
    assert m["mse"] == pytest.approx([0.01, 0.04])
    assert m["rmse"] == pytest.approx([0.1, 0.2])
    assert m["iae"] == pytest.approx([1.0, 2.0])
    assert m["max_abs_error"] == pytest.approx([0.1, 0.2])
    assert m["max_abs_error_after_20s"] is None and m["max_abs_error_after_50s"] is None
    assert m["max_abs_error_last_half"] == pytest.approx([0.1, 0.2])
    assert m["settle_time_10mrad"] == [None, None]  # never inside the band
    assert m["control_energy"] == 0.0 and m["tau_total_variation_rate"] == [0.0, 0.0]
    assert m["cost_integral"] is None


def test_mse_counts_every_sample_from_t0():
    """Eq. (50): mean over all n samples, the initial error included."""
    t = _grid(1.0)  # 101 samples
    e = np.zeros((len(t), 2))
    e[0] = [1.0, 2.0]
    m = tracking_metrics(t, e, np.zeros_like(e))
    assert m["mse"] == pytest.approx([1.0 / 101, 4.0 / 101])
    # trapezoid: the first interval carries half of |e(0)| * T
    assert m["iae"] == pytest.approx([0.5 * T, 1.0 * T])


def test_step_torque_gives_known_total_variation_and_energy():
    t = _grid(10.0)
    tau = np.zeros((len(t), 2))
    tau[t >= 5.0 - 1e-9, 0] = 1.0  # one step of 1 N.m at t = 5 s
    tau[:, 1] = 2.0  # constant
    m = tracking_metrics(t, np.zeros_like(tau), tau, torque_limit=4.0)
    assert m["tau_total_variation_rate"] == pytest.approx([0.1, 0.0])  # 1 N.m over 10 s
    assert m["max_abs_tau"] == pytest.approx([1.0, 2.0])
    assert m["max_tau_norm"] == pytest.approx(math.sqrt(5.0))
    # int tau'tau with each sample held over its step: 4 over 10 s, plus 1 over [5, 10) s
    assert m["control_energy"] == pytest.approx(40.0 + 5.0)
    assert m["samples_at_limit"] == 0 and m["samples_over_limit"] == 0


def test_settle_time_enters_and_stays():
    t = _grid(10.0)
    e = np.zeros((len(t), 2))
    e[:, 0] = 0.1 * np.exp(-t)  # |e| < 0.01 from t > ln 10 = 2.3026 s
    e[:, 1] = 0.005
    e[700, 1] = 0.02  # joint 2 leaves the band once, at t = 7 s
    m = tracking_metrics(t, e, np.zeros_like(e))
    assert m["settle_time_10mrad"][0] == pytest.approx(2.31)
    assert m["settle_time_10mrad"][1] == pytest.approx(7.01)
    assert settle_time(t, np.full(len(t), 0.001)) == 0.0  # always inside
    last_out = np.zeros(len(t))
    last_out[-1] = 1.0
    assert settle_time(t, last_out) is None  # outside at the end: never settled


def test_late_window_maxima():
    t = _grid(100.0)
    e = np.zeros((len(t), 2))
    e[t < 20.0 - 1e-9] = [1.0, -1.0]
    e[(t >= 20.0 - 1e-9) & (t < 50.0 - 1e-9)] = [0.1, -0.2]
    e[t >= 50.0 - 1e-9] = [0.003, 0.004]
    e[-1] = [0.003, -0.005]
    m = tracking_metrics(t, e, np.zeros_like(e), stop_time=100.0)
    assert m["max_abs_error"] == pytest.approx([1.0, 1.0])
    assert m["max_abs_error_after_20s"] == pytest.approx([0.1, 0.2])
    assert m["max_abs_error_after_50s"] == pytest.approx([0.003, 0.005])
    assert m["max_abs_error_last_half"] == pytest.approx([0.003, 0.005])


def test_samples_at_and_over_the_limit():
    t = _grid(0.04)  # 5 samples
    angle = 0.3
    tau = np.array([
        [3.0, 0.0],                                   # inside
        [4.0 * math.cos(angle), 4.0 * math.sin(angle)],  # on the limit up to rounding
        [4.0, 0.0],                                   # exactly on it
        [4.5, 0.0],                                   # over it
        [0.0, -3.999],                                # inside
    ])
    m = tracking_metrics(t, np.zeros_like(tau), tau, torque_limit=4.0)
    assert m["samples_at_limit"] == 3
    assert m["samples_over_limit"] == 1
    assert m["fraction_at_limit"] == pytest.approx(3 / 5)
    assert m["torque_limit"] == 4.0


def test_cost_integral_and_json():
    t = _grid(10.0)
    e = np.zeros((len(t), 2))
    m = tracking_metrics(t, e, e, cost_rate=np.full(len(t), 2.0))
    assert m["cost_integral"] == pytest.approx(20.0)
    text = json.dumps(m, allow_nan=False)
    assert json.loads(text)["cost_integral"] == pytest.approx(20.0)
    with pytest.raises(ValueError):
        tracking_metrics(t, e, e, cost_rate=np.ones(3))


def test_bad_time_axis_is_refused():
    with pytest.raises(ValueError):
        tracking_metrics(np.array([0.0, 0.0, 0.01]), np.zeros((3, 2)), np.zeros((3, 2)))
    with pytest.raises(ValueError):
        tracking_metrics(np.array([]), np.zeros((0, 2)), np.zeros((0, 2)))


def test_non_finite_values_become_none():
    t = _grid(0.02)
    e = np.array([[0.0, 0.0], [np.inf, 0.0], [0.0, 0.0]])
    m = tracking_metrics(t, e, np.zeros_like(e))
    assert m["mse"][0] is None and m["mse"][1] == 0.0
    json.dumps(m, allow_nan=False)


@pytest.mark.parametrize("blocks", [[1000], [1, 2, 997], [333, 333, 334], [1] * 50 + [950]])
def test_metrics_fed_in_blocks_equal_the_whole_run(blocks):
    """The streaming accumulator behind `sotc-cosim run`: any split gives the whole-run metrics
    (sums to rounding, everything else exactly), including a settle time decided across blocks."""
    rng = np.random.default_rng(3)
    t = np.arange(1000) * 0.1
    e = np.column_stack([0.5 * np.exp(-t / 9.0) * np.sin(t), 0.02 * rng.standard_normal(1000)])
    e[499, 0] = 0.3  # last excursion of joint 1 ends exactly at a block boundary in one split
    tau = np.column_stack([4.5 * np.sin(0.3 * t), 3.0 * np.cos(0.2 * t)])
    cost = np.abs(e[:, 0]) + 1.0
    e_dot = np.column_stack([np.cos(t), np.sin(2 * t)])
    flags = np.zeros(1000, dtype=bool)
    flags[[40, 332, 333, 610]] = True  # the limit acts last inside a block, and at block boundaries
    whole = tracking_metrics(t, e, tau, cost_rate=cost, stop_time=100.0, e_dot=e_dot, limit_flags=flags)
    acc = TrackingMetrics(4.0, 100.0, with_cost=True, with_e_dot=True, with_flags=True)
    lo = 0
    for m in blocks:
        part = slice(lo, lo + m)
        acc.add(t[part], e[part], tau[part], cost[part], e_dot[part], flags[part])
        lo += m
    got = acc.result()
    assert got.keys() == whole.keys()
    for key, want in whole.items():
        assert np.allclose(np.array(got[key], dtype=float), np.array(want, dtype=float), rtol=1e-12, atol=0.0, equal_nan=True), key


def test_post_transient_and_after_limit_metrics_leave_out_what_they_say():
    t = np.arange(0, 1001) * 0.01  # 0 .. 10 s
    e = np.zeros((len(t), 2))
    e[t < 5.0] = [1.0, -2.0]  # the transient
    e[t >= 5.0] = [0.1, 0.2]
    flags = np.zeros(len(t), dtype=bool)
    flags[[10, 300]] = True  # the limit acts last at t = 3 s
    e[301:500] = [0.5, 0.5]
    m = tracking_metrics(t, e, np.zeros((len(t), 2)), limit_flags=flags, e_dot=np.zeros((len(t), 2)))
    assert m["mse_after_5s"] == pytest.approx([0.01, 0.04])
    assert m["last_limit_time"] == pytest.approx(3.0)
    after = e[301:]
    assert m["mse_after_limit"] == pytest.approx(list(np.mean(after**2, axis=0)))
    # z = [e, e_dot + e] with e_dot = 0: z'z = 2 |e|^2, trapezoid over t
    zz = 2.0 * np.sum(e**2, axis=1)
    assert m["tracking_cost"] == pytest.approx(float(np.sum(0.5 * (zz[1:] + zz[:-1]) * 0.01)))
    never = tracking_metrics(t, e, np.zeros((len(t), 2)), limit_flags=np.zeros(len(t), dtype=bool))
    assert never["last_limit_time"] is None and never["mse_after_limit"] == pytest.approx(m["mse"])
    plain = tracking_metrics(t, e, np.zeros((len(t), 2)))
    assert plain["mse_after_limit"] is None and plain["tracking_cost"] is None


def test_limit_active_reads_every_flag_the_controller_has():
    from orchestration.run.metrics import limit_active

    out = {"tau_a_bounded": np.array([0.0, 1.0, 0.0, 0.0]), "tau_limited": np.array([0.0, 0.0, 0.0, 1.0]),
           "W1": np.ones(4)}
    assert limit_active(out, 4).tolist() == [False, True, False, True]
    assert limit_active({"saturated": np.array([1.0, 0.0])}, 2).tolist() == [True, False]
    assert not limit_active({}, 3).any()
