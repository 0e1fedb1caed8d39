"""Parameter sweeps: many runs of one scenario, spread over processes (or a cluster) with Dask.

``sotc-cosim sweep paper-ct --set controller.kp=25,100,400 --set plant.f1=8.45,10`` runs the
cartesian product of the values. Each variant is one task: it loads the FMUs, runs, and returns its
summary. A variant that fails (a refused parameter, a diverging loop, any exception in the task) is
recorded with status ``failed`` and its error; the other variants go on.

Schedulers (``--scheduler``):

- ``processes`` (default): Dask's embedded local process pool, nothing to start; one worker per
  core. Processes, not threads: the FMUs run Python inside the host's interpreter, so threads would
  share one GIL (and module state) and gain nothing.
- ``synchronous``: every task in this process, one after another (debugging).
- ``tcp://HOST:PORT``: an existing ``dask.distributed`` scheduler (``pip install
  "sotc-cosim[distributed]"``). Its workers need sotc-cosim installed and must see ``--fmu-dir``
  (a shared file system); the FMUs are built once, here, before the tasks are sent.
"""
from __future__ import annotations

import itertools
import traceback
from pathlib import Path
from typing import Any

from orchestration.scenario import Scenario, ScenarioError

LOCAL_SCHEDULERS = ("processes", "synchronous")


def parse_assignments(items: list[str]) -> dict[str, list[float]]:
    """``["controller.kp=25,100", ...]`` -> ``{"controller.kp": [25.0, 100.0]}``."""
    grid: dict[str, list[float]] = {}
    for item in items:
        key, sep, values = item.partition("=")
        if not sep or "." not in key or not values:
            raise ScenarioError(f"--set {item!r}: write instance.parameter=v1,v2,...")
        try:
            grid[key.strip()] = [float(v) for v in values.split(",")]
        except ValueError:
            raise ScenarioError(f"--set {item!r}: every value must be a number") from None
    return grid


def variants(base: Scenario, grid: dict[str, list[float]]) -> list[tuple[dict[str, float], Scenario]]:
    """The cartesian product of ``grid`` applied to ``base``: (overrides, scenario) per variant."""
    keys = list(grid)
    out = []
    for i, values in enumerate(itertools.product(*(grid[k] for k in keys))):
        overrides = dict(zip(keys, values))
        out.append((overrides, base.with_parameters(overrides, name=f"{base.name}#{i}")))
    return out


def run_variant(overrides: dict[str, float], scenario: Scenario, fmu_paths: dict[str, Path]) -> dict[str, Any]:
    """One task: run and summarise; never raises (a failure is a result)."""
    from orchestration.master import run
    from orchestration.summary import summarize

    try:
        summary = summarize(run(scenario, fmu_paths))
    except Exception as exc:  # a task must report, not kill the sweep
        summary = {"scenario": scenario.name, "controller": scenario.controller_fmu(), "status": "failed",
                   "error": f"{type(exc).__name__}: {exc}", "traceback": traceback.format_exc(limit=3)}
    return {"parameters": overrides, **summary}


def run_sweep(
    base: Scenario, grid: dict[str, list[float]], fmu_paths: dict[str, Path],
    scheduler: str = "processes", workers: int | None = None,
) -> list[dict[str, Any]]:
    """Run every variant with Dask and return their summaries in grid order."""
    import dask

    tasks = [dask.delayed(run_variant)(o, s, fmu_paths) for o, s in variants(base, grid)]
    if scheduler in LOCAL_SCHEDULERS:
        options = {"num_workers": workers} if scheduler == "processes" and workers else {}
        return list(dask.compute(*tasks, scheduler=scheduler, **options))
    try:
        from distributed import Client
    except ImportError:
        raise ScenarioError(
            f"--scheduler {scheduler}: a cluster needs dask.distributed: pip install 'sotc-cosim[distributed]'"
        ) from None
    with Client(scheduler) as client:
        return list(client.gather(client.compute(tasks)))


def write_results(results: list[dict[str, Any]], csv_path: Path) -> tuple[Path, Path]:
    """One CSV row per variant (its parameters, status and key metrics) and the full summaries as
    JSON beside it (same name, ``.json``)."""
    import csv
    import json

    keys = list(results[0]["parameters"]) if results else []
    header = keys + ["status", "mse_1", "mse_2", "max_abs_error_last_half_1", "max_abs_error_last_half_2",
                     "max_norm_tau", "samples_over_limit", "wall_time_s", "error"]
    csv_path = Path(csv_path)
    csv_path.parent.mkdir(parents=True, exist_ok=True)
    with open(csv_path, "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(header)
        for r in results:
            values = [r["parameters"][k] for k in keys] + [
                r["status"], *(r.get("mse") or [None, None]), *(r.get("max_abs_error_last_half") or [None, None]),
                r.get("max_norm_tau"), r.get("samples_over_limit"), r.get("wall_time_s"), r.get("error"),
            ]
            writer.writerow(["" if v is None else v for v in values])
    json_path = csv_path.with_suffix(".json")
    json_path.write_text(json.dumps(results, indent=1, allow_nan=False) + "\n")
    return csv_path, json_path
