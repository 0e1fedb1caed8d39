"""The tuning searches on Dask, like a sweep's points: one task per search (controller, limit handling,
seed; ``orchestration.study.optimize.run_search``; the cores compiled where the installed wheel
compiled them, setup.py), all sharing one Optuna journal file, so they need a
file system the workers share with the client (a local cluster's always do). The client follows the
journal for progress, writes the store when the searches end or Ctrl-C stops them, and tells how to
resume."""
from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

from orchestration.outputs import atomic_write
from orchestration.study import optimize
from orchestration.sweep.cluster import follow, open_client, shutdown

POLL_S = 1.0  # how often the client reads the journal for progress and looks for Ctrl-C


@dataclass
class TuneOutcome:
    searches: int
    trials_before: int  # trials the journal held already
    interrupted: bool = False
    store: dict | None = None


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


def _counts(journal: Path, names: list[str]) -> dict[str, int]:
    if not journal.is_file():
        return dict.fromkeys(names, 0)
    storage = optimize.storage(journal)
    present = {s.study_name for s in storage.get_all_studies()}
    return {n: len(storage.get_all_trials(storage.get_study_id_from_name(n), deepcopy=False,
                                          states=optimize.FINISHED)) if n in present else 0 for n in names}


def tune(out: Path, controllers, handlings, seeds, budget: int, workers: int | None, scheduler: str | None,
         listener=None) -> TuneOutcome:
    """Run every search until ``budget`` trials count, the longest (the SOTC's) first; write the store to
    ``out`` (also after Ctrl-C, with the trials finished)."""
    journal = journal_of(out)
    repair(journal)
    jobs = [(fmu, h, s) for fmu in controllers for h in handlings for s in seeds]
    names = [optimize.study_name(*job) for job in jobs]
    before = _counts(journal, names)
    outcome = TuneOutcome(len(jobs), sum(min(c, budget) for c in before.values()))
    if listener is not None:
        listener.started(outcome, budget * len(jobs))
    todo = [job for job, n in zip(jobs, names) if before[n] < budget]
    if todo:
        outcome.interrupted = _run(journal, todo, budget, workers, scheduler, names, before, listener)
    outcome.store = optimize.store(journal, controllers, handlings, seeds, budget)
    atomic_write(out, json.dumps(outcome.store, indent=1) + "\n")
    return outcome


def _run(journal, todo, budget, workers, scheduler, names, before, listener) -> bool:
    """Submit the searches and follow them; True if Ctrl-C stopped them."""
    seen = dict(before)

    def done(future) -> None:
        if future.status == "error":
            future.result()  # its error, raised here (a journal this code cannot resume)

    def tick() -> None:
        counts = _counts(journal, names)
        if listener is not None:
            for n in names:
                for _ in range(min(counts[n], budget) - min(seen[n], budget)):
                    listener.trial(n)
        seen.update(counts)

    cluster, futures, stopped = None, [], True  # anything but the end of every search stops the workers
    try:
        cluster = open_client(scheduler, workers)
        futures = [cluster.client.submit(optimize.run_search, journal.resolve(), fmu, h, s, budget, pure=False,
                                         key=f"tune-{optimize.study_name(fmu, h, s)}-{cluster.scratch}")
                   for fmu, h, s in todo]
        stopped = follow(futures, done, tick, POLL_S)
    finally:
        shutdown(cluster, futures, stopped)
    return stopped
