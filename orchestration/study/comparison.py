"""Every controller under every torque-limit handling, and the baselines' tuning, in the pure loop.

The pure loop (``orchestration.study.pure_loop``) is the FMU run sample for sample (tests/fmu/test_sotc_fmu.py),
so these are the numbers ``sotc-cosim reproduce`` gets through the FMUs, in a fraction of the time.
Runs are cached per process: several generated tables share them (``orchestration.reports.docgen``).

Fair comparison: each controller is run under each handling of
``fmu_controller.saturation`` (SOTC: of its feedforward under (5), then the actuator limit; CT, LQR:
of the computed torque; OTC: unclipped as in the paper, and clipped by each handling), and every
controller, the SOTC included, gets the same tuning protocol under each handling
(``orchestration.study.tuning``); ``orchestration.study.fair`` judges them on points the tuning never saw.
"""
from __future__ import annotations

import functools
import math
from typing import Any

import numpy as np

from fmu_controller.catalog import CORES
from fmu_controller.saturation import LIMIT_HANDLINGS
from fmu_plant.dynamics import TORQUE_LIMIT
from fmu_plant.paper_setting import INITIAL_ANGLES, SUBSTEPS
from orchestration.markdown import stable
from orchestration.run.metrics import limit_active, tracking_metrics
from orchestration.run.scenario import load_scenario
from orchestration.study.pure_loop import LoopResult, simulate
from orchestration.study.tuning import NOMINAL_SCENARIO, best_design, tuned_parameters

# (scenario, handlings to run): the scenario's own default first
COMPARED = (("paper", (2, 0, 1)), ("paper-ct", (0, 1, 2)), ("paper-lqr", (0, 1, 2)), ("paper-otc", (3, 0, 1, 2)))
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


# the changes of the initial state every printed figure is judged over, (relative change of phi1_0, of phi2_0,
# initial dphi1 and dphi2 in rad/s): a ladder of sizes, each in LADDER_DIRECTIONS seeded directions that move
# angles and velocities at once (the largest component of a direction is the size); a table prints only the
# digits the nominal run shares with every one of them (``orchestration.markdown.stable``)
NOMINAL = (0.0, 0.0, 0.0, 0.0)
LADDER_SIZES = (1e-13, 1e-12, 1e-11, 1e-10, 1e-9, 1e-8)
LADDER_DIRECTIONS = 8
LADDER_SEED = 20261129


def ladder_directions(n: int = LADDER_DIRECTIONS, seed: int = LADDER_SEED) -> list[tuple[float, ...]]:
    """``n`` directions in the four components: seeded integers in [-1000, 1000] over the largest of their
    magnitudes (integers and one correctly rounded division: the same bits on every machine)."""
    out = []
    for row in np.random.default_rng(seed).integers(-1000, 1001, size=(n, 4)).tolist():
        top = max(abs(k) for k in row)
        if top == 0:  # all four zero: no direction (one chance in 1e13)
            raise ValueError(f"seed {seed} draws a zero direction")
        out.append(tuple(k / top for k in row))
    return out


PERTURBATIONS: tuple[tuple[float, float, float, float], ...] = tuple(
    tuple(size * c for c in d) for size in LADDER_SIZES for d in ladder_directions())  # type: ignore[misc]


def initial_state(perturbation: tuple[float, float, float, float],
                  phi0: tuple[float, float] = INITIAL_ANGLES) -> dict[str, tuple[float, float]]:
    """``simulate``'s phi0 and dphi0 for the state at rest at ``phi0`` (section 4's by default) changed by
    ``perturbation``."""
    return {"phi0": (phi0[0] * (1.0 + perturbation[0]), phi0[1] * (1.0 + perturbation[1])),
            "dphi0": (perturbation[2], perturbation[3])}


@functools.lru_cache(maxsize=4)
def loop_result(fmu: str, params: tuple[tuple[str, float], ...], stop_time: float, substeps: int = SUBSTEPS,
                perturbation: tuple[float, float, float, float] = NOMINAL) -> tuple[Any, LoopResult]:
    """A controller FMU's core with these parameters after its pure-loop run, and the run; the last few
    are cached per process, so the tables that read one run's metrics, core state and value function
    simulate it once (a run holds its whole recording: the cache stays small)."""
    core = CORES[fmu](**dict(params))
    return core, simulate(core, stop_time=stop_time, substeps=substeps, **initial_state(perturbation))


@functools.lru_cache(maxsize=None)
def loop_run(fmu: str, params: tuple[tuple[str, float], ...], stop_time: float, substeps: int = SUBSTEPS,
             perturbation: tuple[float, float, float, float] = NOMINAL) -> dict[str, Any]:
    """Metrics of a controller FMU's core with these parameters in the pure loop; cached per process."""
    limit = float(dict(params).get("rho", TORQUE_LIMIT))
    return loop_metrics(loop_result(fmu, params, stop_time, substeps, perturbation)[1], limit)


def run_metrics(scenario: str, stop_time: float = 100.0, substeps: int = SUBSTEPS,
                perturbation: tuple[float, float, float, float] = NOMINAL, **overrides: float) -> dict[str, Any]:
    """Metrics of a scenario's controller (with overrides) in the pure loop, its initial state changed by
    ``perturbation`` (one of ``PERTURBATIONS``); cached per process."""
    fmu, params = controller_of(scenario, **overrides)
    return loop_run(fmu, tuple(sorted(params.items())), stop_time, substeps, perturbation)


def run_perturbed(scenario: str, stop_time: float = 100.0,
                  **overrides: float) -> tuple[dict[str, Any], list[dict[str, Any]]]:
    """``run_metrics`` as it is, and under every one of ``PERTURBATIONS``: a table prints each figure only
    to the digits all of them share (``orchestration.markdown.stable``). The generated docs read the
    perturbed runs from their store instead (``orchestration.reports.perturbed``)."""
    return run_metrics(scenario, stop_time, **overrides), [
        run_metrics(scenario, stop_time, perturbation=p, **overrides) for p in PERTURBATIONS]


# Table 1 of the paper (MSE, eq. (50)); no other metric is reported there.
PAPER_TABLE1 = {
    "SOTC": (0.0025, 0.0084),
    "OTC": (0.0059, 0.0159),
}
TABLE1_MARGIN = 1.3  # a reading reaches Table 1 when each joint's MSE is within 30 % of the paper's


def within_table1(mse: tuple[float, float], controller: str = "SOTC") -> bool:
    """Whether the MSE (50) of both joints is at most ``TABLE1_MARGIN`` times Table 1's."""
    return all(m <= TABLE1_MARGIN * p for m, p in zip(mse, PAPER_TABLE1[controller]))

# a reading is chaotic when Table 1's metric moves by more than this under a perturbation of its initial state
CHAOS_THRESHOLD = 0.10


def chaos_of(nominal: dict[str, Any], others: list[dict[str, Any]]) -> str | None:
    """None for a run whose Table 1 metric MSE_1 + MSE_2 moves by at most ``CHAOS_THRESHOLD`` (relative)
    under every one of ``others`` (the run under each of ``PERTURBATIONS``); else what is reproducible
    about it: "does not track" (or "chaotic", within 10x of Table 1's), the metric to the digits all the
    runs share (or their range) and how far it moves."""
    sums = [mse_sum(m) for m in (nominal, *others)]
    finite = all(math.isfinite(s) for s in sums) and sums[0] > 0
    move = max(abs(s - sums[0]) / sums[0] for s in sums[1:]) if finite else math.inf
    if move <= CHAOS_THRESHOLD:
        return None
    what = "does not track" if min(sums) > 10 * sum(PAPER_TABLE1["SOTC"]) else "chaotic"
    moves = f"moves up to {100 * move:.2g} %" if finite else "is not finite"
    return (f"{what} (MSE_1 + MSE_2 {stable(sums[0], sums[1:])}; {moves} under {len(others)} "
            "perturbations of the initial state)")


def chaos_text(scenario: str, stop_time: float = 100.0, **overrides: float) -> str | None:
    """``chaos_of`` a scenario's controller (with overrides) in the pure loop."""
    return chaos_of(*run_perturbed(scenario, stop_time, **overrides))


def handling_code(fmu: str, params: dict[str, float]) -> int:
    """The limit handling a controller FMU runs with these parameters (its default if they do not set it)."""
    spec = {s.name: s for s in CORES[fmu].PARAMETER_SPECS}["limit_handling"]
    return int(params.get("limit_handling", spec.default))


def handling_name(scenario: str, **overrides: float) -> str:
    return LIMIT_HANDLINGS[handling_code(*controller_of(scenario, **overrides))]


def mse_sum(m: dict[str, Any]) -> float:
    """Table 1's metric mse1 + mse2 (the tuning criterion); inf for a run without it."""
    mse = m.get("mse")
    return float(np.sum(mse)) if mse and None not in mse else float("inf")


def tuned_metrics(fmu: str, handling: int, stop_time: float = 100.0) -> tuple[dict[str, float], dict[str, Any]]:
    """(design point, metrics of the nominal `paper` loop) of ``fmu`` tuned under a handling by the
    protocol of ``orchestration.study.tuning`` (its stored result)."""
    scenario, overrides = tuned_run(fmu, handling)
    return best_design(fmu, handling), run_metrics(scenario, stop_time, **overrides)


def tuned_run(fmu: str, handling: int) -> tuple[str, dict[str, float]]:
    """(scenario, overrides) of ``fmu`` tuned under a handling: its nominal scenario at the stored design."""
    return NOMINAL_SCENARIO[fmu], {"limit_handling": handling, **tuned_parameters(fmu, handling)}
