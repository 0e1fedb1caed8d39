"""The tuning searches on Dask, like a sweep's points: one task per search (a problem and a seed: our controller
under a limit handling, or a foreign controller's; ``orchestration.study.polish.search``: its TPE phase, then its CMA-ES phase; the cores compiled where the installed wheel
compiled them, setup.py), all sharing one Optuna journal file, so they need a
file system the workers share with the client (a local cluster's always do). The client follows the
journal for progress, writes the store when the searches end or Ctrl-C stops them, and tells how to
resume."""
from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

from orchestration.outputs import atomic_write
from orchestration.study import optimize, polish as local, tuning
from orchestration.study.journal import Salvage, salvage
from orchestration.sweep.cluster import follow, open_client, shutdown

POLL_S = 1.0  # how often the client reads the journal for progress and looks for Ctrl-C


@dataclass
class TuneOutcome:
    searches: int
    trials_before: int  # trials the journal held already
    interrupted: bool = False
    store: dict | None = None
    salvaged: Salvage | None = None  # the journal's damaged lines, set aside before the searches started


def journal_of(out: Path) -> Path:
    """The Optuna journal beside a store, named from the store's whole name (``tuned.json`` ->
    ``tuned.json.journal``): two stores of one stem (``t.json``, ``t.toml``; ``tuned``, ``tuned.json``)
    never share a journal (they did, and the first command died with Optuna's "did not possess lock")."""
    return out.with_name(out.name + ".journal")


def repair(journal: Path) -> None:
    """Before a run: the journal's lock left by a worker stopped while holding it goes (only one
    sotc-cosim tunes into a journal at a time: the caller holds the journal's own ``PathLock``), and so does a last
    line cut off by a stopped worker, which would corrupt the line appended after it."""
    journal.with_name(journal.name + ".lock").unlink(missing_ok=True)  # JournalFileOpenLock's file
    if not journal.is_file():
        return
    data = journal.read_bytes()
    if data and not data.endswith(b"\n"):
        with open(journal, "r+b") as f:
            f.truncate(data.rfind(b"\n") + 1)


class _Reader:
    """The journal as the client follows it: one storage for the whole run, which reads only what was
    appended since its last read (a storage opened per poll parsed the whole journal, 100 MB at the
    stored study's size, every second, and took a core from the searches)."""

    def __init__(self, journal: Path):
        self.journal, self.storage = journal, None

    def counts(self, jobs: list[tuple], budget: int, polish: int) -> dict[tuple, int]:
        if self.storage is None and self.journal.is_file():
            self.storage = optimize.storage(self.journal)
        if self.storage is None:
            return dict.fromkeys(jobs, 0)
        return _counts(self.storage, jobs, budget, polish)


def _counts(storage, jobs: list[tuple], budget: int, polish: int) -> dict[tuple, int]:
    """The trials of each search that count: of its TPE phase up to ``budget``, then of its CMA-ES phase."""
    present = {s.study_name for s in storage.get_all_studies()}

    def finished(name: str, states) -> int:
        return len(storage.get_all_trials(storage.get_study_id_from_name(name), deepcopy=False,
                                          states=states)) if name in present else 0

    return {job: min(finished(optimize.study_name(*job), optimize.FINISHED), budget)
            + min(finished(local.study_name(*job, budget), local.COUNTED), polish) for job in jobs}


def tune(out: Path, controllers, handlings, seeds, budget: int, polish: int, workers: int | None,
         scheduler: str | None, listener=None) -> TuneOutcome:
    """Run every search until ``budget`` TPE and ``polish`` CMA-ES trials count, the longest (the SOTC's)
    first; write the store to ``out`` (also after Ctrl-C, with the trials finished)."""
    journal = journal_of(out)
    jobs = [(tuning.Ours(fmu, h), s) for fmu in controllers for h in handlings for s in seeds]
    outcome = searches(journal, jobs, budget, polish, workers, scheduler, listener)
    outcome.store = local.store(journal, controllers, handlings, seeds, budget, polish)
    atomic_write(out, json.dumps(outcome.store, indent=1) + "\n")
    return outcome


def searches(journal: Path, jobs: list[tuple], budget: int, polish: int, workers: int | None, scheduler: str | None,
             listener=None, after=None) -> TuneOutcome:
    """Run (or resume) the searches ``jobs`` (problem, seed; ``tuning.Ours`` or a foreign controller's problem)
    in the journal at ``journal`` until ``budget`` TPE and ``polish`` CMA-ES trials count, in this order; the
    outcome has no store (each command writes its own). ``after``: the work that follows each search on the same
    cluster, started as soon as that search is done (its ``start(client, jobs)`` for the searches done before,
    its ``finished(future, job, client)`` for every future that ends: ``job`` for a search, else None), so a
    worker left without a search takes it up while the others still search."""
    repair(journal)
    salvaged = salvage(journal) if journal.is_file() else None
    reader = _Reader(journal)
    before = reader.counts(jobs, budget, polish)
    outcome = TuneOutcome(len(jobs), sum(before.values()), salvaged=salvaged)
    if listener is not None:
        listener.started(outcome, (budget + polish) * len(jobs))
    todo = [job for job in jobs if before[job] < budget + polish]
    if todo or after is not None:
        outcome.interrupted = _run(journal, todo, budget, polish, workers, scheduler, reader, jobs, before, listener,
                                   after)
    return outcome


def _run(journal, todo, budget, polish, workers, scheduler, reader, jobs, before, listener, after=None) -> bool:
    """Submit the searches (and ``after``'s work) and follow them; True if Ctrl-C stopped them."""
    seen = dict(before)
    cluster, futures, stopped, search_of = None, [], True, {}  # anything but the end of every search stops the workers

    def done(future) -> list:
        if future.status == "error":
            future.result()  # its error, raised here (a journal this code cannot resume)
        more = [] if after is None else after.finished(future, search_of.get(future.key), cluster.client)
        futures.extend(more)
        return more

    def tick() -> None:
        counts = reader.counts(jobs, budget, polish)
        if listener is not None:
            for job in jobs:
                for _ in range(counts[job] - seen[job]):
                    listener.trial(optimize.study_name(*job))
        seen.update(counts)

    try:
        cluster = open_client(scheduler, workers)
        for problem, seed in todo:
            future = cluster.client.submit(local.search, journal.resolve(), problem, seed, budget, polish, pure=False,
                                           key=f"tune-{optimize.study_name(problem, seed)}-{cluster.scratch}")
            search_of[future.key] = (problem, seed)
            futures.append(future)
        if after is not None:
            futures += after.start(cluster.client, [job for job in jobs if job not in todo])
        stopped = follow(list(futures), done, tick, POLL_S) if futures else False
    finally:
        shutdown(cluster, futures, stopped)
    return stopped
