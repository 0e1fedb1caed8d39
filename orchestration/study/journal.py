"""A tuning journal with damaged lines (``sotc-cosim tune`` printed Optuna's JSONDecodeError traceback):
the damaged lines are found before the searches start, the journal as it was is kept beside it, and the
searches resume from a journal rebuilt of every trial the damage cannot have touched.

Optuna's journal (``optuna.storages.JournalStorage``) is a log of operations, one JSON record a line;
trials and studies are numbered by the order of their creation records, and every later record names
its trial or study by that number and carries the id of the worker (process and thread) that wrote it.
A damaged line's record is unknown, so it is replayed as if absent, and checked:

- every record must name the study its worker opened last and a trial that exists, is not finished and
  (but for the state that ends it) belongs to its worker; a damaged creation record would shift the
  numbers of everything after it and break that. Then only the records before the first damaged line
  are kept (a prefix of the log is the journal as it was at that moment);
- a trial still running at a damaged line may have lost a parameter, an intermediate value or its end,
  and a trial written whole in one record (the CMA-ES phase's) may be the damaged line itself: such a
  trial, and every later trial of its search, is kept as failed. A failed trial does not count, and a
  search draws each trial from the ones that count before it, so the search runs them again to the same
  trials as one uninterrupted run (keeping a later trial would change what the search draws). Every
  other trial is kept as it was.

The rebuilt journal is written with Optuna's own storage and backend (``create_new_study``,
``create_new_trial``, ``JournalFileBackend.append_logs``) and renamed into place.
"""
from __future__ import annotations

import json
import os
import shutil
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from optuna.storages import JournalStorage
from optuna.storages.journal import BaseJournalBackend, JournalFileBackend, JournalFileOpenLock
from optuna.storages.journal._storage import JournalOperation  # the journal format's operation codes (not exported)
from optuna.trial import FrozenTrial, TrialState

from orchestration.outputs import OutputError
from orchestration.paths import OutputKind, temporary_path

LOOKED_AT = 100  # lines read to tell a journal (some line a record) from another file
# what Optuna's replay reads of each record (a record without it ends the replay with a KeyError)
_KEYS = {
    JournalOperation.CREATE_STUDY: ("study_name", "directions"),
    JournalOperation.SET_STUDY_USER_ATTR: ("study_id", "user_attr"),
    JournalOperation.SET_STUDY_SYSTEM_ATTR: ("study_id", "system_attr"),
    JournalOperation.CREATE_TRIAL: ("study_id", "datetime_start"),
    JournalOperation.SET_TRIAL_PARAM: ("trial_id", "param_name", "param_value_internal", "distribution"),
    JournalOperation.SET_TRIAL_STATE_VALUES: ("trial_id", "state", "values"),
    JournalOperation.SET_TRIAL_INTERMEDIATE_VALUE: ("trial_id", "step", "intermediate_value"),
    JournalOperation.SET_TRIAL_USER_ATTR: ("trial_id", "user_attr"),
    JournalOperation.SET_TRIAL_SYSTEM_ATTR: ("trial_id", "system_attr"),
}
_FINISHED = {s.value for s in TrialState if s.is_finished()}


def _record(line: bytes) -> dict[str, Any] | None:
    """The journal record of one line, None if it is not one (not JSON, or not the fields Optuna reads)."""
    try:
        record = json.loads(line)
        op = JournalOperation(record["op_code"])
    except (ValueError, TypeError, KeyError):
        return None
    keys = _KEYS.get(op, ("unknown",)) + ("worker_id",)
    if op == JournalOperation.SET_TRIAL_STATE_VALUES:  # Optuna reads the start of a running trial, the end of a finished one
        keys += ("datetime_complete",) if record.get("state") in _FINISHED else ("datetime_start",)
    numbers = [record.get(k, 0) for k in ("study_id", "trial_id")]
    return record if all(k in record for k in keys) and all(type(n) is int for n in numbers) else None


def _holds_records(path: Path) -> bool:
    with open(path, "rb") as f:
        return any(_record(line) is not None for line, _ in zip(f, range(LOOKED_AT)))


JOURNAL = OutputKind("an Optuna journal", _holds_records)  # what tune --out's journal appends to without --force


@dataclass
class Salvage:
    """What was done with the damaged ``lines`` (numbered from 1) of ``journal``."""
    journal: Path
    lines: list[int]
    aside: Path  # the journal as it was
    kept: int  # finished trials kept
    again: int  # trials kept as failed: they run again
    prefix: bool  # only the records before the first damaged line could be kept

    def __str__(self) -> str:
        many = len(self.lines) > 1
        where = ", ".join(map(str, self.lines[:5])) + (f" and {len(self.lines) - 5} more" if len(self.lines) > 5 else "")
        lost = "; the records after it could not be placed: their trials run again" if self.prefix else ""
        return (f"{self.journal}: line{'s' if many else ''} {where} {'are' if many else 'is'} not an Optuna journal "
                f"record; the journal as it was is kept in {self.aside.name}, {self.kept} finished trials go on, "
                f"{self.again} the damage may have touched run again{lost}")


@dataclass
class _Replay:
    """The studies and trials of a journal as far as its readable records tell, checked record by record."""
    study_ids: dict[str, int] = field(default_factory=dict)
    created: list[int] = field(default_factory=list)  # the line of each study's creation
    opened: dict[str, int] = field(default_factory=dict)  # worker -> the study it opened last
    trials: list[dict[str, Any]] = field(default_factory=list)  # worker, study, finished, whole, at (line)
    again: set[int] = field(default_factory=set)

    def damaged(self) -> None:
        """A damaged line here: what is running may have lost a record."""
        self.again |= {i for i, t in enumerate(self.trials) if not t["finished"]}

    def apply(self, record: dict[str, Any], at: int) -> bool:
        """Whether ``record`` (line ``at``) fits what came before."""
        op, worker = record["op_code"], record["worker_id"]
        if op == JournalOperation.CREATE_STUDY:
            if record["study_name"] not in self.study_ids:
                self.study_ids[record["study_name"]] = len(self.created)
                self.created.append(at)
            self.opened[worker] = self.study_ids[record["study_name"]]
            return True
        if op == JournalOperation.CREATE_TRIAL:
            whole = record.get("state") in _FINISHED
            self.trials.append({"worker": worker, "study": record["study_id"], "finished": whole, "whole": whole,
                                "at": at})
            return self.opened.get(worker) == record["study_id"]
        if "study_id" in record:
            return self.opened.get(worker) == record["study_id"]
        trial = self.trials[record["trial_id"]] if 0 <= record["trial_id"] < len(self.trials) else None
        if trial is None or trial["finished"] or self.opened.get(worker) != trial["study"]:
            return False
        if op == JournalOperation.SET_TRIAL_STATE_VALUES:
            trial["finished"] = record["state"] in _FINISHED
            return True
        return trial["worker"] == worker

    def whole_after(self, damaged: list[int]) -> set[int]:
        """The trials written whole in one record after a damaged line, of a study created before it."""
        return {i for i, t in enumerate(self.trials)
                if t["whole"] and any(self.created[t["study"]] < line < t["at"] for line in damaged)}

    def and_later(self, again: set[int]) -> set[int]:
        """``again`` with every trial of the same study created after one of them."""
        first: dict[int, int] = {}
        for i in sorted(again):
            first.setdefault(self.trials[i]["study"], i)
        return {i for i, t in enumerate(self.trials) if i >= first.get(t["study"], len(self.trials))}


def _replayed(records: list[tuple[int, dict | None]]) -> tuple[list[dict], set[int], bool]:
    """The records to keep, the trials (by creation order) to keep as failed, and whether only the prefix
    before the first damaged line could be kept."""
    replay, damaged = _Replay(), [at for at, r in records if r is None]
    for at, record in records:
        if record is None:
            replay.damaged()
        elif not replay.apply(record, at):
            prefix, check = [], _Replay()
            for record in (r for at, r in records[:damaged[0] - 1]):
                check.apply(record, 0)
                prefix.append(record)
            return prefix, {i for i, t in enumerate(check.trials) if not t["finished"]}, True
    return [r for _, r in records if r is not None], replay.and_later(replay.again | replay.whole_after(damaged)), False


class _Records(BaseJournalBackend):
    """Optuna's journal in memory: the records read, and those the rebuild writes."""

    def __init__(self, records: list[dict[str, Any]]):
        self.records = records

    def read_logs(self, log_number_from: int) -> list[dict[str, Any]]:
        return self.records[log_number_from:]

    def append_logs(self, logs: list[dict[str, Any]]) -> None:
        self.records.extend(logs)


def _failed(t: FrozenTrial) -> FrozenTrial:
    return FrozenTrial(number=t.number, state=TrialState.FAIL, value=None, values=None, datetime_start=t.datetime_start,
                       datetime_complete=t.datetime_complete or t.datetime_start, params=t.params,
                       distributions=t.distributions, user_attrs=t.user_attrs, system_attrs=t.system_attrs,
                       intermediate_values=t.intermediate_values, trial_id=t._trial_id)


def _rebuilt(records: list[dict[str, Any]], again: set[int]) -> tuple[list[dict[str, Any]], int]:
    """The records of a journal holding the studies and trials of ``records`` (those in ``again`` as
    failed), and how many finished trials it keeps as they were."""
    old, new = JournalStorage(_Records(records)), _Records([])
    storage, kept = JournalStorage(new), 0
    for study in old.get_all_studies():
        study_id = storage.create_new_study(study.directions, study.study_name)
        for key, value in study.user_attrs.items():
            storage.set_study_user_attr(study_id, key, value)
        for key, value in study.system_attrs.items():
            storage.set_study_system_attr(study_id, key, value)
        for t in old.get_all_trials(study._study_id, deepcopy=False):
            storage.create_new_trial(study_id, template_trial=_failed(t) if t._trial_id in again else t)
            kept += t._trial_id not in again and t.state in (TrialState.COMPLETE, TrialState.PRUNED)
    return new.records, kept


def salvage(journal: Path) -> Salvage | None:
    """Rebuild ``journal`` around its damaged lines, the old one kept as ``<journal>.damaged`` (numbered if
    that exists); None when every line is a record."""
    with open(journal, "rb") as f:
        records = [(at, _record(line)) for at, line in enumerate(f, start=1)]
    damaged = [at for at, r in records if r is None]
    if not damaged:
        return None
    kept_records, again, prefix = _replayed(records)
    rebuilt, kept = _rebuilt(kept_records, again)
    aside = journal.with_name(journal.name + ".damaged")
    n = 1
    while aside.exists():
        n += 1
        aside = journal.with_name(f"{journal.name}.damaged{n}")
    part = temporary_path(journal)
    part.unlink(missing_ok=True)
    try:
        part.touch()
        if rebuilt:
            JournalFileBackend(str(part), lock_obj=JournalFileOpenLock(str(part))).append_logs(rebuilt)
        shutil.copy2(journal, aside)  # the journal as it was stays, before the rebuilt one replaces it
        os.replace(part, journal)
    except OSError as exc:
        raise OutputError.of(journal, exc) from None
    finally:
        part.unlink(missing_ok=True)
    return Salvage(journal, damaged, aside, kept, len(again), prefix)
