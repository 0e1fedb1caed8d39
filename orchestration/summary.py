"""The run summary: what ``sotc-cosim run --summary`` writes and the metrics table it prints."""
from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from orchestration.master import RunResult
from orchestration.metrics import limit_active, tracking_metrics

def _column(result: RunResult, instance: str, name: str) -> np.ndarray | None:
    return result.outputs.get(instance, {}).get(name)


def error_and_torque(result: RunResult) -> tuple[np.ndarray, np.ndarray]:
    """e = phi - phi_d (n, 2) and the commanded torque (n, 2) of a closed-loop run."""
    e = np.column_stack([result.outputs["plant"][f"phi{i}"] - result.outputs["reference"][f"phi{i}_d"] for i in (1, 2)])
    tau = np.column_stack([result.outputs["controller"][f"tau{i}"] for i in (1, 2)])
    return e, tau


def _limit_handling(sc) -> str | None:
    """The name of the controller's torque-limit handling as the scenario sets it (else its default)."""
    from fmu_controller.saturation import LIMIT_HANDLINGS
    from orchestration.comparison import CORES

    inst = sc.instances.get("controller")
    if inst is None or inst.fmu not in CORES:
        return None
    specs = {s.name: s for s in CORES[inst.fmu].PARAMETER_SPECS}
    return LIMIT_HANDLINGS[int(inst.parameters.get("limit_handling", specs["limit_handling"].default))]


def summarize(result: RunResult) -> dict[str, Any]:
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
    }
    if result.samples == 0 or not {"plant", "reference", "controller"} <= set(result.outputs):
        return summary
    e, tau = error_and_torque(result)
    e_dot = np.column_stack([result.outputs["plant"][f"dphi{i}"] - result.outputs["reference"][f"dphi{i}_d"]
                             for i in (1, 2)])
    cost = _column(result, "controller", "cost_rate")
    flags = limit_active(result.outputs["controller"], len(result.time))
    metrics = tracking_metrics(result.time, e, tau, sc.torque_limit(), cost_rate=cost, stop_time=sc.stop_time,
                               e_dot=e_dot, limit_flags=flags)
    metrics["max_norm_tau"] = metrics.pop("max_tau_norm")
    summary.update(metrics)
    weights = [_column(result, "controller", f"W{i}") for i in range(1, 11)]
    if all(w is not None for w in weights):
        summary["final_weights"] = [float(w[-1]) for w in weights]
        eig = _column(result, "controller", "cl_stack_min_eig")
        summary["cl_stack_min_eig"] = None if eig is None else float(eig[-1])
    return summary


def write_summary(summary: dict[str, Any], path: Path) -> None:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(summary, indent=2, allow_nan=False) + "\n")


def fmt_cell(value: Any, spec: str, width: int) -> str:
    """A number in a fixed-width column; a missing or undefined one (None, NaN) as '-'."""
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return f"{'-':>{width}}"
    return f"{value:>{width}{spec}}"


def format_table(summaries: list[dict[str, Any]]) -> str:
    """A short fixed-width table: one row per run (failed runs too, with '-' where undefined)."""
    head = f"{'scenario':<16} {'controller':<16} {'status':<7} {'MSE 1':>10} {'MSE 2':>10} {'max|e| 2nd half':>18} {'max||tau||':>10} {'wall s':>7}"
    rows = [head, "-" * len(head)]
    for s in summaries:
        mse = s.get("mse") or [None, None]
        tail = [v for v in (s.get("max_abs_error_last_half") or []) if v is not None]
        rows.append(
            f"{s['scenario']:<16} {str(s['controller']):<16} {s['status']:<7} {fmt_cell(mse[0], '.5f', 10)} "
            f"{fmt_cell(mse[1], '.5f', 10)} {fmt_cell(max(tail) if tail else None, '.2e', 18)} "
            f"{fmt_cell(s.get('max_norm_tau'), '.4f', 10)} {fmt_cell(s.get('wall_time_s'), '.2f', 7)}"
        )
    return "\n".join(rows)
