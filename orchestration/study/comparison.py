"""Every controller under every torque-limit handling, and the baselines' tuning, in the pure loop.

The pure loop (``orchestration.study.pure_loop``) is the FMU run sample for sample (tests/test_sotc_fmu.py),
so these are the numbers ``sotc-cosim reproduce`` gets through the FMUs, in a fraction of the time.
Runs are cached per process: several generated tables share them (``orchestration.reports.docgen``).

Fair comparison: each controller is run under each handling of
``fmu_controller.saturation`` (SOTC: of its feedforward under (5), then the actuator limit; CT, LQR:
of the computed torque; OTC: unclipped as in the paper, and clipped by each handling), and the
baselines get the same small tuning search under each handling (``TUNING_GRIDS``).
"""
from __future__ import annotations

import functools
from typing import Any

import numpy as np

from fmu_controller.catalog import CORES
from fmu_controller.saturation import LIMIT_HANDLINGS
from fmu_plant.dynamics import TORQUE_LIMIT
from orchestration.run.metrics import limit_active, tracking_metrics
from orchestration.run.scenario import load_scenario
from orchestration.study.pure_loop import LoopResult, simulate

# (scenario, handlings to run): the scenario's own default first
COMPARED = (("paper", (2, 0, 1)), ("paper-ct", (0, 1, 2)), ("paper-lqr", (0, 1, 2)), ("paper-otc", (3, 0, 1, 2)))
# the tuning search, the same size for both baselines; the first point is the paper-like nominal
# (CT: kp = kd = 2, the error dynamics of Lambda = I; LQR: Theta = I4, r = 1, the SOTC's weights)
TUNING_GRIDS = {
    "paper-ct": ({"kp": 2.0, "kd": 2.0}, {"kp": 4.0, "kd": 4.0}, {"kp": 9.0, "kd": 6.0}, {"kp": 25.0, "kd": 10.0},
                 {"kp": 100.0, "kd": 20.0}, {"kp": 400.0, "kd": 40.0}),
    "paper-lqr": ({"q": 1.0, "r": 1.0}, {"q": 1.0, "r": 0.1}, {"q": 1.0, "r": 0.01}, {"q": 1.0, "r": 0.0016},
                  {"q": 10.0, "r": 1.0}, {"q": 100.0, "r": 0.01}),
}

# the OTC reconstruction's sensitivity (docs/baselines.md 3.4), each a change of the paper-otc defaults
OTC_VARIANTS: tuple[tuple[str, dict[str, float]], ...] = (
    ("defaults", {}),
    ("no learning (alpha_c = alpha_a = alpha_s = 0)", {"alpha_c": 0.0, "alpha_a": 0.0, "alpha_s": 0.0}),
    ("probing off", {"probe_amplitude": 0.0}),
    ("alpha_c = 1", {"alpha_c": 1.0}),
    ("alpha_c = 5", {"alpha_c": 5.0}),
    ("alpha_c = 50", {"alpha_c": 50.0}),
    ("init_phi2 = 0.9", {"init_phi2": 0.9}),
    ("init_phi2 = 1.5", {"init_phi2": 1.5}),
    ("zero initial weights, alpha_s = 0.01", {"init_weights": 0.0}),
    ("zero initial weights, alpha_s = 1", {"init_weights": 0.0, "alpha_s": 1.0}),
    ("zero initial weights, alpha_s = 10", {"init_weights": 0.0, "alpha_s": 10.0}),
    ("Lambda = diag[20, 5] (not the paper's)", {"lambda1": 20.0, "lambda2": 5.0}),
)


def loop_metrics(res: LoopResult, torque_limit: float = TORQUE_LIMIT) -> dict[str, Any]:
    """``tracking_metrics`` of a pure-loop run, with every optional input the loop has."""
    outputs = {name: res.outputs[:, i] for i, name in enumerate(res.names)}
    e_dot = res.y[:, 2:4] - res.ref[:, 2:4]
    return tracking_metrics(res.t, res.error, res.tau, torque_limit, cost_rate=outputs.get("cost_rate"),
                            e_dot=e_dot, limit_flags=limit_active(outputs, len(res.t)))


def controller_of(scenario: str, **overrides: float) -> tuple[str, dict[str, float]]:
    """(FMU name, parameters) of a scenario's controller, with overrides."""
    inst = load_scenario(scenario).instances["controller"]
    return inst.fmu, {**inst.parameters, **overrides}


@functools.lru_cache(maxsize=None)
def _cached(fmu: str, params: tuple[tuple[str, float], ...], stop_time: float) -> dict[str, Any]:
    p = dict(params)
    limit = float(p.get("rho", TORQUE_LIMIT))
    return loop_metrics(simulate(CORES[fmu](**p), stop_time=stop_time), limit)


def run_metrics(scenario: str, stop_time: float = 100.0, **overrides: float) -> dict[str, Any]:
    """Metrics of a scenario's controller (with overrides) in the pure loop; cached per process."""
    fmu, params = controller_of(scenario, **overrides)
    return _cached(fmu, tuple(sorted(params.items())), stop_time)


def handling_code(fmu: str, params: dict[str, float]) -> int:
    """The limit handling a controller FMU runs with these parameters (its default if they do not set it)."""
    spec = {s.name: s for s in CORES[fmu].PARAMETER_SPECS}["limit_handling"]
    return int(params.get("limit_handling", spec.default))


def handling_name(scenario: str, **overrides: float) -> str:
    return LIMIT_HANDLINGS[handling_code(*controller_of(scenario, **overrides))]


def tuning(scenario: str, handling: int, stop_time: float = 100.0) -> list[tuple[dict[str, float], dict[str, Any]]]:
    """(parameters, metrics) for every point of the scenario's tuning grid under one handling."""
    return [(point, run_metrics(scenario, stop_time, limit_handling=handling, **point))
            for point in TUNING_GRIDS[scenario]]


def mse_sum(m: dict[str, Any]) -> float:
    """The tuning criterion: mse1 + mse2 (Table 1's metric); inf for a run without it."""
    mse = m.get("mse")
    return float(np.sum(mse)) if mse and None not in mse else float("inf")


def best_tuning(scenario: str, handling: int, stop_time: float = 100.0) -> tuple[dict[str, float], dict[str, Any]]:
    return min(tuning(scenario, handling, stop_time), key=lambda pm: mse_sum(pm[1]))


@functools.lru_cache(maxsize=None)
def tuned_scenarios() -> dict[str, str]:
    """Controller FMU -> the scenario whose tuning grid tunes it (CT, LQR; the SOTC and OTC have none)."""
    return {controller_of(scenario)[0]: scenario for scenario in TUNING_GRIDS}


def tuned_parameter_names(fmu: str) -> set[str]:
    """The parameters the tuning search of a controller FMU sets (empty: the FMU has no search)."""
    scenario = tuned_scenarios().get(fmu)
    return {k for point in TUNING_GRIDS[scenario] for k in point} if scenario else set()


def best_parameters(fmu: str, handling: int) -> dict[str, float]:
    """The controller parameters of the best point of ``fmu``'s tuning search under a limit handling:
    the tuning the README's results table reports (``tuning = "best"`` of a sweep file). About a second
    of pure-loop runs per (fmu, handling) the first time; the runs are cached per process."""
    return dict(best_tuning(tuned_scenarios()[fmu], int(handling))[0])
