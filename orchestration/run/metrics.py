"""Closed-loop performance metrics: a pure core (numpy, the project's numerics and the arm model; no FMI, no rerun).

``tracking_metrics`` turns one run -- time, tracking error, commanded torque, optionally the SOTC
cost integrand -- into a flat dict of JSON-friendly values (floats, ints, None, lists of two
floats). Names are stable; each is documented in ``tracking_metrics``.

Conventions: ``e = phi - phi_d`` in rad, ``tau`` the torque the controller commands (held over the
sample in a sampled loop) in N.m; integrals of torques are exact for that hold (each sample over
its step), integrals of continuous signals (|e|, the cost rate) use the trapezoid rule; "per
joint" values are lists [joint 1, joint 2]. NaN never appears: an undefined value is None.
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np

from fmu_numerics import elementary
from fmu_plant.dynamics import TORQUE_LIMIT

# tolerance of "at the limit": ||tau|| >= limit - LIMIT_TOLERANCE counts (a norm scaled to the
# limit lands on it up to rounding)
LIMIT_TOLERANCE = 1e-9
SETTLE_BAND = 0.01  # rad
TRANSIENT_END = 5.0  # s: "post-transient" metrics use t >= 5 s


def norms(tau: np.ndarray) -> np.ndarray:
    """||tau|| per row (m, 2) by the cores' hypot, the same bits anywhere: its C function where
    ``elementary`` is compiled, else ``elementary_interpreted``'s (the same bits on the whole column at once;
    one interpreted call per row cost over 1 us a sample). The C function is mapped over the two columns as
    Python floats: a list of rows unpacked in a comprehension cost twice as much (a trial's runs each pay it)."""
    if elementary.__file__.endswith(".py"):
        from fmu_numerics import elementary_interpreted

        return elementary_interpreted.hypot(tau[:, 0], tau[:, 1])
    return np.fromiter(map(elementary.hypot, tau[:, 0].tolist(), tau[:, 1].tolist()), float, len(tau))
# the flag the master's actuator writes beside a foreign controller's torques where it cut them
# (orchestration.run.ported); the run summary counts these samples
TORQUE_CUT = "torque_cut"
# controller outputs that flag a sample where the torque limit acts (SOTC: bound (5) on tau^a or
# chi_vd^a, the actuator limit; CT/LQR: the limit handling; OTC: the torque before the limit is over it;
# a foreign controller: the actuator)
LIMIT_FLAG_OUTPUTS = ("tau_a_bounded", "chi_a_bounded", "tau_limited", "saturated", "over_limit", TORQUE_CUT)


def limit_active(outputs: dict[str, np.ndarray], n: int) -> np.ndarray:
    """Per sample: does the torque limit act? (any of ``LIMIT_FLAG_OUTPUTS`` the controller has is nonzero)"""
    flags = np.zeros(n, dtype=bool)
    for name in LIMIT_FLAG_OUTPUTS:
        if name in outputs:
            flags |= np.asarray(outputs[name]) != 0.0
    return flags


def _trapezoid(y: np.ndarray, t: np.ndarray, start=None) -> np.ndarray:
    """Trapezoid integral along axis 0 (numpy's name changed between versions; do it by hand), added
    interval by interval to ``start`` (``ordered_sum``)."""
    y = np.asarray(y, dtype=float)
    dt = np.diff(t)
    mid = 0.5 * (y[1:] + y[:-1])
    return ordered_sum(dt[:, None] * mid if y.ndim > 1 else dt * mid, start)


def ordered_sum(x: np.ndarray, start=None) -> np.ndarray:
    """The sum along axis 0, term after term in sample order (``cumsum``), from ``start`` (default 0):
    numpy's ``sum`` adds pairwise in blocks whose shape depends on the CPU's SIMD width, ``dot`` goes
    to BLAS; this is one order everywhere, so a metric has the same bits on every machine, and a run
    summed block by block (streaming) gets the bits of the whole run summed at once."""
    x = np.asarray(x, dtype=float)
    if start is not None:
        x = np.concatenate([np.asarray(start, dtype=float).reshape((1,) + x.shape[1:]), x])
    return np.cumsum(x, axis=0)[-1] if len(x) else np.zeros(x.shape[1:])


def _per_joint(x: np.ndarray) -> list[float]:
    return [float(v) for v in x]


def settle_time(t: np.ndarray, err: np.ndarray, band: float = SETTLE_BAND) -> float | None:
    """First sample time after which |err| < band holds at every later sample; None if the last
    sample is outside the band (the signal never enters and stays)."""
    outside = np.flatnonzero(np.abs(err) >= band)
    if len(outside) == 0:
        return float(t[0])
    last = outside[-1]
    if last == len(t) - 1:
        return None
    return float(t[last + 1])


def tracking_metrics(
    t: np.ndarray,
    e: np.ndarray,
    tau: np.ndarray,
    torque_limit: float = TORQUE_LIMIT,
    cost_rate: np.ndarray | None = None,
    stop_time: float | None = None,
    e_dot: np.ndarray | None = None,
    limit_flags: np.ndarray | None = None,
) -> dict[str, Any]:
    """Metrics of one closed-loop run.

    Arguments: ``t`` (n,) sample times in s, increasing; ``e`` (n, 2) tracking error phi - phi_d
    in rad; ``tau`` (n, 2) commanded torque in N.m; ``torque_limit`` the bound on ||tau|| in N.m
    (the paper's rho = 4); ``cost_rate`` (n,) optional SOTC cost integrand z'Theta z + Omega(mu)
    per sample (eq. (12)); ``stop_time`` the run's stop time (default t[-1]), used for
    ``max_abs_error_last_half``; ``e_dot`` (n, 2) optional dphi - dphi_d in rad/s (for
    ``tracking_cost``); ``limit_flags`` (n,) optional: True where the torque limit acts
    (``limit_active``).

    Returned keys (per-joint values are [joint 1, joint 2]):

    - ``n_samples``: n.  ``duration``: t[-1] - t[0] in s.
    - ``mse``: mean of e_i^2 over all n samples, eq. (50) of the paper (rad^2).
    - ``rmse``: sqrt(mse) (rad).
    - ``iae``: integral of |e_i| dt, trapezoid (rad.s).
    - ``max_abs_error``: max |e_i| over all samples (rad).
    - ``max_abs_error_after_20s``, ``max_abs_error_after_50s``: max |e_i| over samples with
      t >= 20 s / t >= 50 s (rad); None if no sample is that late.
    - ``max_abs_error_last_half``: max |e_i| over t >= stop_time / 2 (rad).
    - ``settle_time_10mrad``: first time after which |e_i| < 0.01 rad at every later sample (s);
      None if joint i is outside the band at the last sample.
    - ``max_abs_tau``: max |tau_i| (N.m).  ``max_tau_norm``: max ||tau|| (N.m).
    - ``samples_at_limit``: number of samples with ||tau|| >= torque_limit - 1e-9.
    - ``fraction_at_limit``: samples_at_limit / n.
    - ``samples_over_limit``: number of samples with ||tau|| > torque_limit + 1e-9 (a violation
      of the bound, as opposed to riding on it).
    - ``control_energy``: integral of tau' tau dt (N^2.m^2.s), exact for the sampled loop's
      zero-order hold: sum_k (t_{k+1} - t_k) ||tau_k||^2 (tau_k is held over [t_k, t_{k+1})).
    - ``tau_total_variation_rate``: sum_k |tau_i[k+1] - tau_i[k]| / duration, per joint (N.m/s).
    - ``cost_integral``: integral of cost_rate dt, trapezoid, or None without cost_rate (the
      controller's own cost (12); only the SOTC has one).
    - ``mse_after_5s``: MSE (50) over the samples with t >= 5 s, per joint (None if none).
    - ``last_limit_time``: time of the last sample where the limit acts (None: never, or no flags).
    - ``mse_after_limit``: MSE over the samples after that one (all samples if the limit never
      acts; None without flags or if no sample follows).
    - ``tracking_cost``: the realised cost (12) in coordinates every controller shares, integral of
      z'z dt (trapezoid) with z = [e, e_dot + e]: Theta = I and Lambda_1 = I of section 4 with the
      learned chi_vd* left out, and no input term (the controllers' inputs differ; see
      ``control_energy``). None without e_dot.
    - ``torque_limit``: the limit used.
    """
    t = np.asarray(t, dtype=float).reshape(-1)
    if len(t) == 0:
        raise ValueError("tracking_metrics needs at least one sample")
    acc = TrackingMetrics(torque_limit, float(t[-1]) if stop_time is None else float(stop_time),
                          with_cost=cost_rate is not None, with_e_dot=e_dot is not None,
                          with_flags=limit_flags is not None)
    acc.add(t, e, tau, cost_rate, e_dot, limit_flags)
    return acc.result()


class TrackingMetrics:
    """``tracking_metrics`` over a run handed over in blocks of samples (``add``), holding O(1)
    state: what the master streams is summarised without keeping the run. Fed the whole run as
    one block it is ``tracking_metrics``; fed in blocks the sums differ only by rounding."""

    def __init__(self, torque_limit: float, stop_time: float, with_cost: bool = False, with_e_dot: bool = False,
                 with_flags: bool = False):
        self.limit, self.stop, self.with_cost = float(torque_limit), float(stop_time), with_cost
        self.with_e_dot, self.with_flags = with_e_dot, with_flags
        self.late = [np.zeros(2), 0]  # sum of e^2 and count over t >= TRANSIENT_END
        self.after_limit = [np.zeros(2), 0]  # the same since the last sample where the limit acts
        self.last_limit_time: float | None = None
        self.tracking_cost = 0.0
        self.n = 0
        self.t0 = self.t_last = math.nan
        self.e2 = np.zeros(2)  # sum of e^2
        self.iae = np.zeros(2)
        self.max_e = np.zeros(2)
        self.max_after = {20.0: None, 50.0: None, self.stop / 2.0: None}  # t0 -> max |e| per joint
        self.max_tau = np.zeros(2)
        self.max_norm = -math.inf
        self.at_limit = self.over_limit = 0
        self.energy = 0.0
        self.tv = np.zeros(2)
        self.cost = 0.0
        # settle time: per joint the time of the sample after the last one outside the band, or
        # None while the latest sample is outside; "never outside" is t0 (resolved in result())
        self.settle: list[float | None] = [math.nan, math.nan]
        self.last: tuple[float, np.ndarray, np.ndarray, float, float] | None = None  # t, |e|, tau, norm, cost

    def add(self, t: np.ndarray, e: np.ndarray, tau: np.ndarray, cost_rate: np.ndarray | None = None,
            e_dot: np.ndarray | None = None, limit_flags: np.ndarray | None = None) -> None:
        t = np.asarray(t, dtype=float).reshape(-1)
        m = len(t)
        if m == 0:
            return
        e = np.asarray(e, dtype=float).reshape(m, 2)
        tau = np.asarray(tau, dtype=float).reshape(m, 2)
        c = self._column("cost_rate", cost_rate, self.with_cost, m)
        if self.with_e_dot:
            ed = np.asarray(self._column("e_dot", e_dot, True, 2 * m), dtype=float).reshape(m, 2)
            f = ed + e
            zz = (e[:, 0] ** 2 + e[:, 1] ** 2) + (f[:, 0] ** 2 + f[:, 1] ** 2)  # z'z of ``tracking_cost``
        ae = np.abs(e)
        norm = norms(tau)
        e2 = e * e
        late = t >= TRANSIENT_END - 1e-12
        self.late[0] = ordered_sum(e2[late], self.late[0])
        self.late[1] += int(np.sum(late))
        if self.with_flags:
            hits = np.flatnonzero(np.asarray(self._column("limit_flags", limit_flags, True, m), dtype=bool))
            if len(hits):  # MSE after the limit restarts after the latest sample where it acts
                self.last_limit_time = float(t[hits[-1]])
                self.after_limit = [np.zeros(2), 0]
            first = hits[-1] + 1 if len(hits) else 0
            self.after_limit[0] = ordered_sum(e2[first:], self.after_limit[0])
            self.after_limit[1] += m - first
        if self.last is not None:  # the interval from the previous block's last sample
            tp, aep, taup, normp, cp, zzp = self.last
            t, ae, tau, norm = np.r_[tp, t], np.vstack([aep, ae]), np.vstack([taup, tau]), np.r_[normp, norm]
            if self.with_cost:
                c = np.r_[cp, c]
            if self.with_e_dot:
                zz = np.r_[zzp, zz]
        else:
            self.t0 = float(t[0])
        if len(t) > 1 and np.any(np.diff(t) <= 0.0):
            raise ValueError("t must be strictly increasing")
        new = slice(0 if self.last is None else 1, None)  # the samples of this block
        self.n += m
        self.e2 = ordered_sum(e2, self.e2)
        self.iae = _trapezoid(ae, t, self.iae)
        self.max_e = np.maximum(self.max_e, np.max(ae[new], axis=0))
        tn = t[new]
        for t_from in self.max_after:
            mask = tn >= t_from - 1e-12
            if mask.any():
                peak = np.max(ae[new][mask], axis=0)
                old = self.max_after[t_from]
                self.max_after[t_from] = peak if old is None else np.maximum(old, peak)
        for j in (0, 1):
            outside = np.flatnonzero(ae[new][:, j] >= SETTLE_BAND)
            if len(outside):
                last = outside[-1]
                self.settle[j] = float(tn[last + 1]) if last + 1 < len(tn) else None
            elif self.settle[j] is None:
                self.settle[j] = float(tn[0])  # the previous block ended outside; this one starts inside
        self.max_tau = np.maximum(self.max_tau, np.max(np.abs(tau[new]), axis=0))
        self.max_norm = max(self.max_norm, float(np.max(norm[new])))
        self.at_limit += int(np.sum(norm[new] >= self.limit - LIMIT_TOLERANCE))
        self.over_limit += int(np.sum(norm[new] > self.limit + LIMIT_TOLERANCE))
        self.energy = float(ordered_sum(np.diff(t) * norm[:-1] ** 2, self.energy))
        self.tv = ordered_sum(np.abs(np.diff(tau, axis=0)), self.tv)
        if self.with_cost:
            self.cost = float(_trapezoid(c, t, self.cost))
        if self.with_e_dot:
            self.tracking_cost = float(_trapezoid(zz, t, self.tracking_cost))
        self.t_last = float(t[-1])
        self.last = (self.t_last, ae[-1].copy(), tau[-1].copy(), float(norm[-1]),
                     float(c[-1]) if self.with_cost else 0.0, float(zz[-1]) if self.with_e_dot else 0.0)

    @staticmethod
    def _column(name: str, values, needed: bool, size: int):
        if not needed:
            return None
        if values is None:
            raise ValueError(f"{name} is needed in every block (the accumulator was made with it)")
        a = np.asarray(values).reshape(-1)
        if len(a) != size:
            raise ValueError(f"{name} has {len(a)} values, the block needs {size}")
        return a

    def result(self) -> dict[str, Any]:
        n = self.n
        if n == 0:
            raise ValueError("tracking_metrics needs at least one sample")
        duration = self.t_last - self.t0
        mse = self.e2 / n
        settle = [self.t0 if s is not None and math.isnan(s) else s for s in self.settle]  # NaN: never outside
        after = {k: None if v is None else _per_joint(v) for k, v in self.max_after.items()}
        out: dict[str, Any] = {
            "n_samples": int(n),
            "duration": float(duration),
            "mse": _per_joint(mse),
            "rmse": _per_joint(np.sqrt(mse)),
            "iae": _per_joint(self.iae),
            "max_abs_error": _per_joint(self.max_e),
            "max_abs_error_after_20s": after[20.0],
            "max_abs_error_after_50s": after[50.0],
            "max_abs_error_last_half": after[self.stop / 2.0],
            "settle_time_10mrad": settle,
            "max_abs_tau": _per_joint(self.max_tau),
            "max_tau_norm": float(self.max_norm),
            "samples_at_limit": self.at_limit,
            "fraction_at_limit": float(self.at_limit / n),
            "samples_over_limit": self.over_limit,
            "control_energy": self.energy,
            "tau_total_variation_rate": _per_joint(self.tv / duration) if duration > 0.0 else [0.0, 0.0],
            "cost_integral": self.cost if self.with_cost else None,
            "torque_limit": self.limit,
            "mse_after_5s": _per_joint(self.late[0] / self.late[1]) if self.late[1] else None,
            "last_limit_time": self.last_limit_time,
            "mse_after_limit": (_per_joint(self.after_limit[0] / self.after_limit[1])
                                if self.with_flags and self.after_limit[1] else None),
            "tracking_cost": self.tracking_cost if self.with_e_dot else None,
        }
        # floats must be finite for JSON; a diverged run reports None rather than NaN/inf
        for key, value in out.items():
            if isinstance(value, float) and not math.isfinite(value):
                out[key] = None
            elif isinstance(value, list):
                out[key] = [None if isinstance(v, float) and not math.isfinite(v) else v for v in value]
        return out


def weight_total_variation(t: np.ndarray, weights: np.ndarray, t0: float, t1: float) -> float:
    """Total variation sum_k ||W_{k+1} - W_k||_2 of critic weights (n, m) over samples in [t0, t1].

    The measurable form of the paper's Figures 1-2: weights that keep jumping (PE only) against
    weights that settle (concurrent learning)."""
    t = np.asarray(t, dtype=float)
    w = np.asarray(weights, dtype=float)[(t >= t0 - 1e-9) & (t <= t1 + 1e-9)]
    d = np.diff(w, axis=0)
    return float(ordered_sum(np.sqrt(np.cumsum(d * d, axis=1)[:, -1]))) if len(d) else 0.0

