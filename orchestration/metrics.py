"""Closed-loop performance metrics, pure numpy (no FMI, no rerun).

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

# tolerance of "at the limit": ||tau|| >= limit - LIMIT_TOLERANCE counts (a norm scaled to the
# limit lands on it up to rounding)
LIMIT_TOLERANCE = 1e-9
SETTLE_BAND = 0.01  # rad
TRANSIENT_END = 5.0  # s: "post-transient" metrics use t >= 5 s
# controller outputs that flag a sample where the torque limit acts (SOTC: bound (5) on tau^a or
# chi_vd^a, the actuator limit; CT/LQR: the limit handling; OTC: the torque before the limit is over it)
LIMIT_FLAG_OUTPUTS = ("tau_a_bounded", "chi_a_bounded", "tau_limited", "saturated", "over_limit")


def limit_active(outputs: dict[str, np.ndarray], n: int) -> np.ndarray:
    """Per sample: does the torque limit act? (any of ``LIMIT_FLAG_OUTPUTS`` the controller has is nonzero)"""
    flags = np.zeros(n, dtype=bool)
    for name in LIMIT_FLAG_OUTPUTS:
        if name in outputs:
            flags |= np.asarray(outputs[name]) != 0.0
    return flags


def _mse_from(e: np.ndarray, mask: np.ndarray) -> list[float] | None:
    return _per_joint(np.mean(e[mask] ** 2, axis=0)) if mask.any() else None


def _trapezoid(y: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Trapezoid integral along axis 0 (numpy's name changed between versions; do it by hand)."""
    if len(t) < 2:
        return np.zeros(y.shape[1:]) if y.ndim > 1 else np.float64(0.0)
    dt = np.diff(t)
    mid = 0.5 * (y[1:] + y[:-1])
    return np.tensordot(dt, mid, axes=(0, 0))


def _per_joint(x: np.ndarray) -> list[float]:
    return [float(v) for v in x]


def _max_abs_after(t: np.ndarray, e: np.ndarray, t0: float) -> list[float] | None:
    mask = t >= t0 - 1e-12
    if not mask.any():
        return None
    return _per_joint(np.max(np.abs(e[mask]), axis=0))


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
    torque_limit: float = 4.0,
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
    e = np.asarray(e, dtype=float).reshape(len(t), 2)
    tau = np.asarray(tau, dtype=float).reshape(len(t), 2)
    n = len(t)
    if n == 0:
        raise ValueError("tracking_metrics needs at least one sample")
    if n > 1 and np.any(np.diff(t) <= 0.0):
        raise ValueError("t must be strictly increasing")
    duration = float(t[-1] - t[0])
    stop = float(t[-1]) if stop_time is None else float(stop_time)

    mse = np.mean(e**2, axis=0)
    tau_norm = np.hypot(tau[:, 0], tau[:, 1])
    tv = np.sum(np.abs(np.diff(tau, axis=0)), axis=0)

    out: dict[str, Any] = {
        "n_samples": int(n),
        "duration": duration,
        "mse": _per_joint(mse),
        "rmse": _per_joint(np.sqrt(mse)),
        "iae": _per_joint(_trapezoid(np.abs(e), t)),
        "max_abs_error": _per_joint(np.max(np.abs(e), axis=0)),
        "max_abs_error_after_20s": _max_abs_after(t, e, 20.0),
        "max_abs_error_after_50s": _max_abs_after(t, e, 50.0),
        "max_abs_error_last_half": _max_abs_after(t, e, stop / 2.0),
        "settle_time_10mrad": [settle_time(t, e[:, 0]), settle_time(t, e[:, 1])],
        "max_abs_tau": _per_joint(np.max(np.abs(tau), axis=0)),
        "max_tau_norm": float(np.max(tau_norm)),
        "samples_at_limit": int(np.sum(tau_norm >= torque_limit - LIMIT_TOLERANCE)),
        "fraction_at_limit": float(np.sum(tau_norm >= torque_limit - LIMIT_TOLERANCE) / n),
        "samples_over_limit": int(np.sum(tau_norm > torque_limit + LIMIT_TOLERANCE)),
        "control_energy": float(np.dot(np.diff(t), tau_norm[:-1] ** 2)),
        "tau_total_variation_rate": _per_joint(tv / duration) if duration > 0.0 else [0.0, 0.0],
        "cost_integral": None,
        "torque_limit": float(torque_limit),
    }
    late = t >= TRANSIENT_END - 1e-12
    out["mse_after_5s"] = _mse_from(e, late)
    out["last_limit_time"] = out["mse_after_limit"] = None
    if limit_flags is not None:
        flags = np.asarray(limit_flags, dtype=bool).reshape(-1)
        hit = np.flatnonzero(flags)
        after = np.ones(n, dtype=bool)
        if len(hit):
            out["last_limit_time"] = float(t[hit[-1]])
            after[: hit[-1] + 1] = False
        out["mse_after_limit"] = _mse_from(e, after)
    out["tracking_cost"] = None
    if e_dot is not None:
        ed = np.asarray(e_dot, dtype=float).reshape(n, 2)
        zz = np.sum(e**2, axis=1) + np.sum((ed + e) ** 2, axis=1)
        out["tracking_cost"] = float(_trapezoid(zz, t))
    if cost_rate is not None:
        c = np.asarray(cost_rate, dtype=float).reshape(-1)
        if len(c) != n:
            raise ValueError(f"cost_rate has {len(c)} samples, t has {n}")
        out["cost_integral"] = float(_trapezoid(c, t))
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
    return float(np.sum(np.linalg.norm(np.diff(w, axis=0), axis=1)))

