"""The run summary: what ``sotc-cosim run --summary`` writes and the metrics table it prints."""
from __future__ import annotations

import json
from pathlib import Path
from typing import Any, Callable

import numpy as np

from fmu_controller.catalog import CORES
from fmu_controller.saturation import LIMIT_HANDLINGS
from orchestration.outputs import atomic_write
from orchestration.paths import json_kind
from orchestration.markdown import number
from orchestration.run.master import RunResult
from orchestration.run.metrics import LIMIT_FLAG_OUTPUTS, TORQUE_CUT, TrackingMetrics, limit_active
from orchestration.run.scenario import Scenario

CLOSED_LOOP = {"e": (("plant.phi1", "reference.phi1_d"), ("plant.phi2", "reference.phi2_d")),
               "tau": ("controller.tau1", "controller.tau2")}
E_DOT = (("plant.dphi1", "reference.dphi1_d"), ("plant.dphi2", "reference.dphi2_d"))
LIMIT_FLAGS = tuple(f"controller.{name}" for name in LIMIT_FLAG_OUTPUTS)
WEIGHTS = tuple(f"controller.W{i}" for i in range(1, 11))
CUT = f"controller.{TORQUE_CUT}"  # the actuator's flag beside a foreign controller (orchestration.run.ported)


class SummaryObserver:
    """The run summary, computed while the run streams (a ``RunObserver``): blocks of samples go
    into ``TrackingMetrics`` and the last sample's weights are kept, so a run of any length is
    summarised in bounded memory. ``summary`` is ready after ``finish``."""

    def __init__(self) -> None:
        self.metrics: TrackingMetrics | None = None
        self.summary: dict[str, Any] | None = None
        self.where: dict[str, tuple[str, int]] = {}
        self.final: dict[str, float] = {}
        self.cuts = 0  # samples whose torques the actuator cut (none for our controllers: they bound themselves)

    def start(self, scenario: Scenario, columns: dict[str, list[str]], parameters=None) -> None:
        self.where = {f"{inst}.{v}": (inst, i) for inst, names in columns.items() for i, v in enumerate(names)}
        needed = [k for pair in CLOSED_LOOP["e"] for k in pair] + list(CLOSED_LOOP["tau"])
        if {"plant", "reference", "controller"} <= set(columns) and all(k in self.where for k in needed):
            self.metrics = TrackingMetrics(scenario.torque_limit(), scenario.stop_time,
                                           with_cost="controller.cost_rate" in self.where,
                                           with_e_dot=all(k in self.where for pair in E_DOT for k in pair),
                                           with_flags=True)  # no flag outputs: the limit never acts

    def block(self, time: np.ndarray, rows: dict[str, np.ndarray]) -> None:
        self.add(time, lambda key: rows[self.where[key][0]][:, self.where[key][1]])

    def add(self, time: np.ndarray, column: Callable[[str], np.ndarray]) -> None:
        """One block: its times and ``column(key)``, the samples of output "instance.variable"."""
        if CUT in self.where:
            self.cuts += int(np.count_nonzero(column(CUT)))
        if self.metrics is None or len(time) == 0:
            return
        e = np.column_stack([column(p) - column(r) for p, r in CLOSED_LOOP["e"]])
        tau = np.column_stack([column(k) for k in CLOSED_LOOP["tau"]])
        cost = column("controller.cost_rate") if self.metrics.with_cost else None
        e_dot = np.column_stack([column(p) - column(r) for p, r in E_DOT]) if self.metrics.with_e_dot else None
        flags = limit_active({k.split(".", 1)[1]: column(k) for k in LIMIT_FLAGS if k in self.where}, len(time))
        self.metrics.add(time, e, tau, cost, e_dot, flags)
        self.final = {k: float(column(k)[-1]) for k in (*WEIGHTS, "controller.cl_stack_min_eig") if k in self.where}

    def finish(self, result: RunResult) -> None:
        self.summary = self.summarize(result)

    def summarize(self, result: RunResult) -> dict[str, Any]:
        sc = result.scenario
        summary: dict[str, Any] = {
            "scenario": sc.name,
            "controller": sc.controller_fmu(),
            "limit_handling": _limit_handling(sc),
            "step_size": sc.step_size,
            "stop_time": sc.stop_time,
            "steps": max(result.samples - 1, 0),
            "samples": result.samples,
            "status": "interrupted" if result.interrupted else "failed" if result.failed else "ok",
            "error": result.error,
            "wall_time_s": result.wall_time_s,
            "torque_cuts": self.cuts,
        }
        # a failed run reports no metrics: its last samples may already be diverged (or cut short), and a
        # number computed from them would read like a result
        if result.failed or result.samples == 0 or self.metrics is None:
            return summary
        metrics = self.metrics.result()
        metrics["max_norm_tau"] = metrics.pop("max_tau_norm")
        summary.update(metrics)
        if all(k in self.final for k in WEIGHTS):
            summary["final_weights"] = [self.final[k] for k in WEIGHTS]
            summary["cl_stack_min_eig"] = self.final.get("controller.cl_stack_min_eig")
        return summary


def _limit_handling(sc) -> str | None:
    """The name of the controller's torque-limit handling as the scenario sets it (else its default)."""
    inst = sc.instances.get("controller")
    if inst is None or inst.fmu not in CORES:
        return None
    specs = {s.name: s for s in CORES[inst.fmu].PARAMETER_SPECS}
    return LIMIT_HANDLINGS[int(inst.parameters.get("limit_handling", specs["limit_handling"].default))]


def summarize(result: RunResult) -> dict[str, Any]:
    """The summary of a run that kept its samples (``run(..., keep_samples=True)``)."""
    obs = SummaryObserver()
    obs.start(result.scenario, {inst: list(outs) for inst, outs in result.outputs.items()})
    obs.add(result.time, lambda key: result.outputs[obs.where[key][0]][key.split(".", 1)[1]])
    return obs.summarize(result)


SUMMARY = json_kind("a run summary (JSON with scenario and status)", ("scenario", "status"))  # what --summary replaces


def write_summary(summary: dict[str, Any], path: Path) -> None:
    atomic_write(path, json.dumps(summary, indent=2, allow_nan=False) + "\n")


def fmt_cell(value: Any, spec: str, width: int) -> str:
    """A number in a fixed-width column; a missing or undefined one (None, NaN) as '-'."""
    return f"{number(value, spec):>{width}}"


def format_table(summaries: list[dict[str, Any]]) -> str:
    """A short fixed-width table: one row per run (failed runs too, with '-' where undefined)."""
    head = f"{'scenario':<16} {'controller':<16} {'status':<7} {'MSE 1':>10} {'MSE 2':>10} {'max|e| 2nd half':>18} {'max||tau||':>10} {'cuts':>6} {'wall s':>7}"
    rows = [head, "-" * len(head)]
    for s in summaries:
        mse = s.get("mse") or [None, None]
        tail = [v for v in (s.get("max_abs_error_last_half") or []) if v is not None]
        rows.append(
            f"{s['scenario']:<16} {str(s['controller']):<16} {s['status']:<7} {fmt_cell(mse[0], '.5f', 10)} "
            f"{fmt_cell(mse[1], '.5f', 10)} {fmt_cell(max(tail) if tail else None, '.2e', 18)} "
            f"{fmt_cell(s.get('max_norm_tau'), '.4f', 10)} {fmt_cell(s.get('torque_cuts'), 'd', 6)} {fmt_cell(s.get('wall_time_s'), '.2f', 7)}"
        )
    return "\n".join(rows)
