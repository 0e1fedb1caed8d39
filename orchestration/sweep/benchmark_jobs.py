"""The benchmark on Dask: the searches of a foreign controller (``tuning_jobs.searches``, one task per seed, one
journal), each followed, as soon as it is done, by its seed's tuned design on the held-out points (one task per
set and draw) and at the optimum's states (one task): with 5 seeds on 2 workers, the last search runs beside the
others' evaluation instead of alone. Every task holds the FMU loaded in its worker (``Foreign.host``).

Resume: the journal keeps the searches' trials; ``heldout.json`` beside the store keeps each finished task with
the design and point count it ran, so a rerun runs only what is missing or whose design changed (a longer
search may find another best), and gives the same store."""
from __future__ import annotations

import json
import uuid
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from orchestration.outputs import atomic_write
from orchestration.study import benchmark, optimize, polish
from orchestration.study.benchmark_problem import Foreign
from orchestration.sweep.tuning_jobs import TuneOutcome, searches

CACHE_NAME = "heldout.json"


@dataclass
class BenchmarkOutcome:
    tuning: TuneOutcome
    store: dict[str, Any] | None = None
    interrupted: bool = False


def check_journal(journal: Path, problem: Foreign, seeds) -> None:
    """A journal that holds a search of another controller under this one's name (another FMU, map, fixed
    parameters or search, or another protocol) is refused before anything runs: a complete search is never
    reopened, so its numbers would pass for this controller's."""
    if not journal.is_file():
        return
    try:
        studies = {s.study_name: s for s in optimize.storage(journal).get_all_studies()}
    except (ValueError, KeyError):  # damaged lines: the searches set them aside first (journal.salvage), then check
        return
    for seed in seeds:
        study = studies.get(optimize.study_name(problem, seed))
        if study is not None and study.user_attrs.get("protocol") != problem.digest(seed):
            raise optimize.JournalError(
                f"{journal.parent}: holds the benchmark of another controller file, FMU, map, fixed parameters or "
                f"search (seed {seed}), or of another protocol; give another --out (or remove that folder)")


def _read_cache(path: Path) -> dict[str, Any]:
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError):
        return {}
    return data if isinstance(data, dict) else {}


def _tasks(problem: Foreign, seed: int, design: dict[str, float], points: int) -> dict[str, tuple]:
    """The tasks after one seed's search: key -> (function, its arguments)."""
    out = {benchmark.key(seed, which, d): (benchmark.heldout, (problem, design, which, d, points))
           for _, which, d in benchmark.heldout_jobs([seed])}
    out[f"seed {seed} / optimum"] = (benchmark.optimum_costs, (problem, design))
    return out


class _Evaluation:
    """What follows each seed's search on the same cluster (``tuning_jobs.searches``' ``after``): its held-out runs
    and J / J*, as soon as its search is done; each finished task kept in ``CACHE_NAME`` with the design and
    point count it ran, so a rerun runs only what is missing or whose design changed."""

    def __init__(self, out: Path, problem: Foreign, settings: dict[str, Any], listener=None):
        self.path, self.problem, self.listener = out / CACHE_NAME, problem, listener
        self.journal = out / benchmark.JOURNAL_NAME
        self.budget, self.polish, self.points = settings["budget"], settings["polish"], settings["points"]
        self.cache = _read_cache(self.path)
        self.records: dict[str, Any] = {}
        self.results: dict[str, Any] = {}
        self.keys: dict[str, str] = {}  # a future's key -> its task's
        self.designs: dict[str, dict] = {}  # a task's key -> the design it runs
        self.token = uuid.uuid4().hex[:12]

    def start(self, client, jobs: list[tuple]) -> list:
        return [f for _, seed in jobs for f in self._submit(client, seed)]

    def finished(self, future, job, client) -> list:
        if job is not None:  # a search: its design is known now
            return self._submit(client, job[1])
        k = self.keys[future.key]
        self.results[k] = future.result()  # an error of ours (an FMU's runs fail apart) stops the command
        self.cache[k] = {"design": self.designs[k], "points": self.points, "controller": self.problem.identity,
                         "result": self.results[k]}
        atomic_write(self.path, json.dumps(self.cache) + "\n")
        if self.listener is not None:
            self.listener.evaluated(k)
        return []

    def _submit(self, client, seed: int) -> list:
        record = polish.record(optimize.storage(self.journal), self.problem, seed, self.budget, self.polish)
        self.records[str(seed)] = record
        futures, kept_now = [], 0
        for k, (function, args) in _tasks(self.problem, seed, record["best_design"], self.points).items():
            self.designs[k] = record["best_design"]
            kept = self.cache.get(k, {})
            if (kept.get("design"), kept.get("points"), kept.get("controller")) == (record["best_design"], self.points,
                                                                                   self.problem.identity):
                self.results[k] = kept["result"]
                kept_now += 1
                continue
            future = client.submit(function, *args, pure=False, key=f"benchmark-{k}-{self.token}")
            self.keys[future.key] = k
            futures.append(future)
        if self.listener is not None:
            self.listener.evaluating(seed, len(futures), kept_now)
        return futures


def run(out: Path, problem: Foreign, settings: dict[str, Any], workers: int | None, scheduler: str | None,
        listener=None) -> BenchmarkOutcome:
    """The whole benchmark into the folder ``out``: the searches, each followed by its seed's held-out runs and
    J / J* on the same cluster; the store once everything is in (``benchmark.STORE_NAME``)."""
    seeds = settings["seeds"]
    check_journal(out / benchmark.JOURNAL_NAME, problem, seeds)
    evaluation = _Evaluation(out, problem, settings, listener)
    tuning = searches(out / benchmark.JOURNAL_NAME, [(problem, s) for s in seeds], settings["budget"],
                      settings["polish"], workers, scheduler, listener, after=evaluation)
    outcome = BenchmarkOutcome(tuning, interrupted=tuning.interrupted)
    if outcome.interrupted:
        return outcome
    heldout = {k: v for k, v in evaluation.results.items() if not k.endswith("optimum")}
    optimum = {str(s): evaluation.results[f"seed {s} / optimum"] for s in seeds}
    outcome.store = benchmark.assemble(problem, settings, evaluation.records, heldout, optimum)
    atomic_write(out / benchmark.STORE_NAME, json.dumps(outcome.store, indent=1) + "\n")
    return outcome
