"""Seeded points of the fair comparison and one run at a point: shared by the tuning's training set
(``orchestration.study.tuning``) and the held-out sets (``orchestration.study.fair``), which differ only
in their seeds, so the two can never overlap by construction.

A point is a dict: ``phi0`` (initial angles; at rest unless it has ``dphi0``, the initial velocities) and,
for a perturbed point, ``plant`` (the five model parameters, each off by a uniform factor in [0.8, 1.2];
the controllers keep the nominal model) and ``perturbation`` (step disturbances in [-0.5, 0.5] N.m and
sinusoidal ones up to 0.5 N.m on both joints, measurement noise std_phi log-uniform in [1e-4, 1e-3] rad,
std_dphi ten times that, and the noise's own seed).
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np

from fmu_controller.catalog import CORES
from fmu_plant.dynamics import ArmParameters, IntegrationError
from fmu_plant.paper_setting import INITIAL_VELOCITIES
from orchestration.run.metrics import tracking_metrics
from orchestration.study.pure_loop import Perturbation, simulate

KINDS = ("initial states", "perturbed")
NOMINAL_ARM = ArmParameters()


def draw_points(seed: int, which: str, n: int, first_noise_seed: int) -> list[dict[str, Any]]:
    """``n`` points of one kind (``KINDS``) drawn from the generator seeded with ``[seed, kind index]``;
    the i-th perturbed point's noise seed is ``first_noise_seed + i``."""
    rng = np.random.default_rng([seed, KINDS.index(which)])
    points = []
    for i in range(n):
        point: dict[str, Any] = {"phi0": [float(rng.uniform(-math.pi, math.pi)), float(rng.uniform(-2.5, 2.5))]}
        if which == "perturbed":
            scale = rng.uniform(0.8, 1.2, 5)
            point["plant"] = {k: float(getattr(NOMINAL_ARM, k) * s) for k, s in zip(("p1", "p2", "p3", "f1", "f2"), scale)}
            std = float(10 ** rng.uniform(-4, -3))
            point["perturbation"] = {"step1": float(rng.uniform(-0.5, 0.5)), "step2": float(rng.uniform(-0.5, 0.5)),
                                     "sin1": float(rng.uniform(0, 0.5)), "sin2": float(rng.uniform(0, 0.5)),
                                     "std_phi": std, "std_dphi": 10 * std, "seed": first_noise_seed + i}
        points.append(point)
    return points


def loop_arguments(point: dict[str, Any]) -> dict[str, Any]:
    """A point as the arguments of a run from it (``pure_loop.simulate``'s, which ``ForeignLoop.run`` shares):
    its initial state, arm and perturbation."""
    return {"phi0": tuple(point["phi0"]), "dphi0": tuple(point.get("dphi0", INITIAL_VELOCITIES)),
            "arm": ArmParameters(**point["plant"]) if "plant" in point else None,
            "perturbation": Perturbation(**point.get("perturbation", {}))}


def run_point(fmu: str, params: dict[str, float], point: dict[str, Any], stop_time: float) -> dict[str, float | None]:
    """The measures of one pure-loop run at a point: ``mse`` = MSE_1 + MSE_2 (eq. (50)), ``tail`` =
    max_i max |e_i| over the last half, ``max_tau_norm`` (None for a run that failed)."""
    try:
        res = simulate(CORES[fmu](**params), stop_time=stop_time, **loop_arguments(point))
    except (IntegrationError, ArithmeticError, ValueError):
        return {"mse": None, "tail": None, "max_tau_norm": None}
    m = tracking_metrics(res.t, res.error, res.tau)
    finite = lambda v: v if v is not None and math.isfinite(v) else None  # noqa: E731
    return {"mse": finite(sum(m["mse"])) if None not in m["mse"] else None,
            "tail": finite(max(m["max_abs_error_last_half"])), "max_tau_norm": finite(m["max_tau_norm"])}
