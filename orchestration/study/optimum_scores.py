"""Every controller scored on exactly the optimal control problem of ``orchestration.study.optimum``:
J of its closed loop from the same initial state over the same horizon, by the same cost, against J*.

Controllers (every one under the ``accel`` limit handling, the one handling whose tuned designs exist for
all four and under which each respects ||tau|| <= rho; the OTC's own default applies no limit at all and
would leave the problem's constraint):

* the fair comparison's configurations (``fair.configurations``): SOTC, CT, LQR and OTC at their nominal
  and tuned designs, the SOTC also with its learning off; "SOTC nominal" is the paper's SOTC learning
  as it runs (PE for 0.4 s, CL, W from 0);
* the value study's policies with W frozen (``value_function.candidates``): the W the `paper` run
  learned in 100 s, W = 0 (the feedforward alone), the paper's W and the LQR weights of the
  linearised (6).

Initial states: the paper's (``paper_setting.INITIAL_STATE``) first, then the value study's 16
(``value_function.initial_states``). One state is one task (``solve_state``): it runs every controller,
warm-starts the solver from the best controller's trajectory and, where asked, solves again from zero
torque as a check that the optimum does not depend on the start.
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np

from fmu_controller.catalog import CORES
from fmu_controller.saturation import ACCEL, in_disc
from fmu_plant.dynamics import TORQUE_LIMIT
from fmu_plant.paper_setting import INITIAL_ANGLES, INITIAL_VELOCITIES
from orchestration.study.fair import configurations
from orchestration.study.optimum import Optimum, Problem, Nlp, solve, trajectory_cost
from orchestration.study.pure_loop import LoopResult, simulate
from orchestration.study.statistics import geometric_interval
from orchestration.study.value_function import _core, candidates, initial_states

PAPER_STATE = (INITIAL_ANGLES, INITIAL_VELOCITIES)  # section 4's (the plant FMU's defaults)
HANDLING = ACCEL
FROZEN_LABELS = {"learned W": "SOTC, learned W frozen", "W = 0": "SOTC, W = 0 (feedforward only)",
                 "the paper's W": "SOTC, the paper's W frozen", "LQR": "SOTC, LQR weights of (6) frozen"}


def all_states() -> list[tuple[tuple[float, float], tuple[float, float]]]:
    """The paper's initial state, then the value study's 16."""
    return [PAPER_STATE, *initial_states()]


def learned_weights() -> list[float]:
    """W(100 s) of the `paper` run (the value study's learned W)."""
    from orchestration.study.sotc_study import run

    return [float(w) for w in run("paper")[0].W]


def fair_core(label: str):
    """A zero-argument factory of one of the fair comparison's configurations under ``HANDLING``."""
    fmu, params = configurations(HANDLING)[label]
    return lambda: CORES[fmu](**params)


def controller_cores(learned: list[float]) -> dict[str, Any]:
    """label -> a zero-argument factory of a fresh controller core."""
    out: dict[str, Any] = {label: fair_core(label) for label in configurations(HANDLING)}
    for name, W in candidates(np.asarray(learned, dtype=float)):
        out[FROZEN_LABELS[name]] = lambda W=W: _core(W)
    return out


def run_controller(problem: Problem, factory) -> LoopResult:
    """A controller's closed loop from the problem's initial state over its horizon; ValueError if it
    leaves the disc (then it did not solve the same problem)."""
    run = simulate(factory(), stop_time=problem.horizon, phi0=problem.phi0, dphi0=problem.dphi0, arm=problem.arm,
                   trajectory=problem.trajectory)
    if not all(in_disc(float(a), float(b), TORQUE_LIMIT) for a, b in run.tau):
        raise ValueError("its torque leaves ||tau|| <= rho")
    return run


def _solver_record(o: Optimum) -> dict[str, Any]:
    return {"J": o.cost, "solver_objective": o.solver_objective, "status": o.status, "iterations": o.iterations,
            "seconds": o.seconds}


def controller_costs(problem: Problem, learned: list[float]) -> tuple[dict, dict, tuple | None]:
    """(J per controller, failure reason per controller, (J, run, label) of the best) on ``problem``.
    Never raises for a controller that fails (its J is None and its reason is kept)."""
    costs: dict[str, float | None] = {}
    failures: dict[str, str] = {}
    best: tuple[float, LoopResult, str] | None = None
    for label, factory in controller_cores(learned).items():
        try:
            run = run_controller(problem, factory)
            costs[label] = trajectory_cost(problem, run)
        except (ArithmeticError, ValueError) as exc:  # IntegrationError, a refused state, the disc left
            costs[label], failures[label] = None, f"{type(exc).__name__}: {exc}"
            continue
        if math.isfinite(costs[label]) and (best is None or costs[label] < best[0]):
            best = (costs[label], run, label)
    return costs, failures, best


def solve_state(index: int, horizon: float, objective: str, learned: list[float], cold: bool) -> dict[str, Any]:
    """One task: the problem from ``all_states()[index]``, every controller's J, J* (warm start from the
    best controller) and, if ``cold``, J* again from zero torque. Raises if the solver fails."""
    phi0, dphi0 = all_states()[index]
    problem = Problem(phi0, dphi0, horizon, objective)
    costs, failures, best = controller_costs(problem, learned)
    nlp = Nlp(problem)
    warm = solve(problem, best[1] if best else None, nlp)
    record: dict[str, Any] = {"index": index, "phi0": list(phi0), "dphi0": list(dphi0), "J_star": warm.cost,
                              "warm_start": best[2] if best else "zero torque", "solver": _solver_record(warm),
                              "J": costs, "failures": failures,
                              "torques": warm.torques.tolist()}
    if cold:
        c = solve(problem, None, nlp)
        record["cold"] = {**_solver_record(c), "relative_difference": abs(c.cost - warm.cost) / warm.cost}
    return record


def rescore_state(record: dict[str, Any], horizon: float, objective: str, learned: list[float]) -> dict[str, Any]:
    """A stored state with every controller's J computed again (the designs changed, e.g. a new tuning),
    its optimum kept: J* and the optimal torques do not depend on the controllers."""
    problem = Problem(tuple(record["phi0"]), tuple(record["dphi0"]), horizon, objective)
    costs, failures, _ = controller_costs(problem, learned)
    return {**record, "J": costs, "failures": failures}


def ratios(states: list[dict[str, Any]], label: str) -> list[float | None]:
    """J / J* of one controller at each state (None where it failed)."""
    return [None if s["J"].get(label) is None else s["J"][label] / s["J_star"] for s in states]


def summary(states: list[dict[str, Any]]) -> dict[str, dict[str, Any]]:
    """Per controller: J / J* at the paper's state, and the geometric mean over all states with its 95 %
    bootstrap interval (``statistics.geometric_interval``)."""
    labels = list(states[0]["J"]) if states else []
    at_paper = [s["index"] == 0 for s in states]
    out = {}
    for label in labels:
        r = ratios(states, label)
        iv = geometric_interval(r)
        usable = [v for v in r if v is not None]
        out[label] = {"paper": next((v for v, p in zip(r, at_paper) if p), None),
                      "gmean": iv.value, "low": iv.low, "high": iv.high, "n": iv.n, "failed": iv.failed,
                      "min": min(usable) if usable else None, "max": max(usable) if usable else None}
    return out


def result(states: list[dict[str, Any]], horizon: float, objective: str) -> dict[str, Any]:
    """The JSON ``sotc-cosim optimum --json`` writes."""
    states = sorted(states, key=lambda s: s["index"])
    return {"horizon": horizon, "objective": objective, "handling": "accel", "torque_limit": TORQUE_LIMIT,
            "states": states, "summary": summary(states)}
