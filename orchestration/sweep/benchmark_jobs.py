"""The benchmark on Dask: the searches of a foreign controller (``tuning_jobs.searches``, one task per seed, one
journal), then each seed's tuned design on the held-out points (one task per seed, set and draw) and at the
optimum's states (one task per seed). Every task holds the FMU loaded in its worker (``Foreign.host``).

Resume: the journal keeps the searches' trials; ``heldout.json`` beside the store keeps each finished task with
the design and point count it ran, so a rerun runs only what is missing or whose design changed (a longer
search may find another best), and gives the same store."""
from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from orchestration.outputs import atomic_write
from orchestration.study import benchmark, optimize, polish
from orchestration.study.benchmark_problem import Foreign
from orchestration.sweep.cluster import follow, open_client, shutdown
from orchestration.sweep.tuning_jobs import POLL_S, TuneOutcome, searches

CACHE_NAME = "heldout.json"


@dataclass
class BenchmarkOutcome:
    tuning: TuneOutcome
    store: dict[str, Any] | None = None
    interrupted: bool = False


def _records(journal: Path, problem: Foreign, seeds, budget: int, polish_trials: int) -> dict[str, Any]:
    storage = optimize.storage(journal)
    return {str(s): polish.record(storage, problem, s, budget, polish_trials) for s in seeds}


def _read_cache(path: Path) -> dict[str, Any]:
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError):
        return {}
    return data if isinstance(data, dict) else {}


def _tasks(problem: Foreign, records: dict[str, Any], seeds, points: int) -> dict[str, tuple]:
    """Every task after the searches: its key -> (function, its arguments, the design it runs)."""
    out = {}
    for s in seeds:
        design = records[str(s)]["best_design"]
        for _, which, d in benchmark.heldout_jobs([s]):
            out[benchmark.key(s, which, d)] = (benchmark.heldout, (problem, design, which, d, points), design)
        out[f"seed {s} / optimum"] = (benchmark.optimum_costs, (problem, design), design)
    return out


def _evaluate(out: Path, tasks: dict[str, tuple], points: int, workers, scheduler, listener) -> tuple[dict, bool]:
    """Run the tasks not in the cache (``CACHE_NAME``, rewritten as each one finishes); True if Ctrl-C
    stopped them."""
    cache_path = out / CACHE_NAME
    cache = _read_cache(cache_path)
    done = {k: v["result"] for k, v in cache.items()
            if k in tasks and v.get("design") == tasks[k][2] and v.get("points") == points}
    todo = [k for k in tasks if k not in done]
    if listener is not None:
        listener.evaluating(len(tasks), len(done))
    if not todo:
        return done, False
    cluster, futures, stopped = None, [], True
    keys = {}

    def finished(future) -> None:
        k = keys[future.key]
        done[k] = future.result()  # an error of ours (not the FMU's: its runs fail apart) stops the command
        cache[k] = {"design": tasks[k][2], "points": points, "result": done[k]}
        atomic_write(cache_path, json.dumps(cache) + "\n")
        if listener is not None:
            listener.evaluated(k)

    try:
        cluster = open_client(scheduler, workers)
        for k in todo:
            function, args, _ = tasks[k]
            future = cluster.client.submit(function, *args, pure=False, key=f"benchmark-{k}-{cluster.scratch}")
            keys[future.key] = k
            futures.append(future)
        stopped = follow(futures, finished, None, POLL_S)
    finally:
        shutdown(cluster, futures, stopped)
    return done, stopped


def run(out: Path, problem: Foreign, settings: dict[str, Any], workers: int | None, scheduler: str | None,
        listener=None) -> BenchmarkOutcome:
    """The whole benchmark into the folder ``out``: the searches, then the held-out runs and J / J*; the store
    once everything is in (``benchmark.STORE_NAME``)."""
    seeds, budget, polish_trials = settings["seeds"], settings["budget"], settings["polish"]
    journal = out / benchmark.JOURNAL_NAME
    tuning = searches(journal, [(problem, s) for s in seeds], budget, polish_trials, workers, scheduler, listener)
    outcome = BenchmarkOutcome(tuning, interrupted=tuning.interrupted)
    if outcome.interrupted:
        return outcome
    records = _records(journal, problem, seeds, budget, polish_trials)
    tasks = _tasks(problem, records, seeds, settings["points"])
    results, outcome.interrupted = _evaluate(out, tasks, settings["points"], workers, scheduler, listener)
    if outcome.interrupted:
        return outcome
    heldout = {k: v for k, v in results.items() if not k.endswith("optimum")}
    optimum = {str(s): results[f"seed {s} / optimum"] for s in seeds}
    outcome.store = benchmark.assemble(problem, settings, records, heldout, optimum)
    atomic_write(out / benchmark.STORE_NAME, json.dumps(outcome.store, indent=1) + "\n")
    return outcome
