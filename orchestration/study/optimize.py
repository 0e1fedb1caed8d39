"""The TPE phase of the tuning searches of ``orchestration.study.tuning``, run with Optuna and kept in its
journal storage (the CMA-ES phase that follows it from its best is ``orchestration.study.polish``).

Sampler: TPE (``optuna.samplers.TPESampler``, multivariate) for the global phase: it models every finished
trial, pruned ones included, works with pruning and, seeded, gives the same trials on every run, while
CMA-ES spends its trials in generations that all run every training point and adapts from one start, so
it is the local phase, not the global one. The first ``INITIAL_DESIGN`` trials are the
nominal design and a Latin hypercube (enqueued), the rest TPE's. Pruning: ``PercentilePruner`` on the
running criterion after each training point from the ``PRUNE_AFTER``-th on: a trial not among the best
``PRUNE_PERCENTILE`` % of the complete trials at that point stops there. (A median rule pruned none of
a 64-trial SOTC search, whose TPE trials all beat the median of a history that holds the Latin
hypercube's poor points; the SOTC's trials are most of the compute.)

Resume and determinism: each search (one controller, limit handling and seed) runs its trials one after
another in one process, and the sampler of trial i is seeded with (seed, i) (``generator_seed``), so a search gives the same
trials whether it ran at once or was stopped and resumed: a trial cut off by Ctrl-C (left running in the
journal) is marked failed and ``interrupted`` and does not count; the next run repeats it. The journal
(``journal``: an append-only file, written under Optuna's file lock, so searches on several Dask workers
can share it) is verified before it is resumed: it must hold the protocol this code states and its
first trial must give the same number again (else the code changed since, and its numbers would be
stale).
"""
from __future__ import annotations

import hashlib
import json
import math
import warnings
from pathlib import Path
from typing import Any

import optuna
from optuna.storages import JournalStorage
from optuna.storages.journal import JournalFileBackend, JournalFileOpenLock
from optuna.trial import TrialState

from fmu_controller.saturation import LIMIT_HANDLINGS
from orchestration.exit_codes import UsageError
from orchestration.study import tuning

# a run that fails completes its trial with an infinite criterion: a failed trial is one cut off (by
# an interruption, or an error that stopped the search), and the next run repeats it
FINISHED = (TrialState.COMPLETE, TrialState.PRUNED)


class JournalError(UsageError):
    """A journal that cannot be resumed by this code (another protocol, or numbers that changed)."""


def study_name(fmu: str, handling: int, seed: int) -> str:
    return f"{fmu}/{LIMIT_HANDLINGS[handling]}/seed{seed}"


def storage(journal: Path) -> JournalStorage:
    return JournalStorage(JournalFileBackend(str(journal), lock_obj=JournalFileOpenLock(str(journal))))


def protocol(fmu: str, seed: int) -> str:
    """A digest of everything a search's trials depend on besides the code of the loop (which the first
    trial's check covers)."""
    text = json.dumps({"space": tuning.SEARCH_SPACES[fmu], "points": tuning.training_points(),
                       "stop": tuning.STOP_TIME, "initial": tuning.initial_design(fmu, seed),
                       "prune_after": tuning.PRUNE_AFTER, "prune_percentile": tuning.PRUNE_PERCENTILE, "optuna": optuna.__version__.split(".")[0]}, sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def generator_seed(seed: int, stream: int) -> int:
    """The seed of a random generator of a search (numpy's legacy generators, under Optuna's samplers and
    CMA-ES, take 32 bits): stream ``stream`` of tuning seed ``seed``."""
    return (1_000_003 * seed + stream) % 2**32


def _sampler(seed: int, index: int) -> optuna.samplers.TPESampler:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", optuna.exceptions.ExperimentalWarning)
        return optuna.samplers.TPESampler(n_startup_trials=tuning.INITIAL_DESIGN, multivariate=True,
                                          constant_liar=False, seed=generator_seed(seed, index))


def open_study(journal: Path, name: str, digest: str, opened: JournalStorage | None = None, **options) -> optuna.Study:
    """The journal's study ``name`` (created if new), refused if it holds another protocol than ``digest``."""
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    study = optuna.create_study(study_name=name, storage=opened or storage(journal), direction="minimize",
                                load_if_exists=True, **options)
    if study.user_attrs.get("protocol", digest) != digest:
        raise JournalError(f"{journal} holds the search {study.study_name} of another tuning protocol; "
                           "give another --out (or remove the journal)")
    study.set_user_attr("protocol", digest)
    return study


def _open(journal: Path, fmu: str, handling: int, seed: int, opened: JournalStorage | None = None) -> optuna.Study:
    pruner = optuna.pruners.PercentilePruner(tuning.PRUNE_PERCENTILE, n_startup_trials=tuning.INITIAL_DESIGN,
                                             n_warmup_steps=tuning.PRUNE_AFTER - 1)
    study = open_study(journal, study_name(fmu, handling, seed), protocol(fmu, seed), opened, pruner=pruner)
    for t in study.get_trials(deepcopy=False, states=(TrialState.RUNNING,)):  # cut off by an interruption
        study.tell(t.number, state=TrialState.FAIL)
    return study


def finished_trials(study: optuna.Study) -> list[optuna.trial.FrozenTrial]:
    """The trials that count, in order."""
    return study.get_trials(deepcopy=False, states=FINISHED)


def _state(t: optuna.trial.FrozenTrial) -> str:
    if t.state == TrialState.PRUNED:
        return "pruned"
    return "complete" if math.isfinite(t.value) else "failed"


def _verify(study: optuna.Study, fmu: str, handling: int, trials: list) -> None:
    """The first trial (the nominal design) must give its first training number again, bit for bit:
    the running criterion after the first point, as the trial reported it (the geometric mean of one
    MSE, exp(log(mse)), which is not the MSE itself in the last bit for about half of all doubles)."""
    first = trials[0]
    if 0 not in first.intermediate_values:
        return
    params = tuning.parameters(fmu, tuning.initial_design(fmu, 0)[0], handling)
    again = next(tuning.running_criterion(fmu, params))  # runs the first training point only
    if again != first.intermediate_values[0]:
        raise JournalError(f"the journal's search {study.study_name} no longer reproduces its first trial "
                           f"({first.intermediate_values[0]!r}, now {again!r}): the code changed since it ran; "
                           "give another --out (or remove the journal)")


def _trial(study: optuna.Study, fmu: str, handling: int) -> None:
    """Ask for one trial, run its training points (pruned or failed early where it must), tell it."""
    trial = study.ask()
    design = {name: trial.suggest_float(name, low, high, log=True)
              for name, (low, high, _) in tuning.SEARCH_SPACES[fmu].items()}
    value = math.inf
    for step, value in enumerate(tuning.running_criterion(fmu, tuning.parameters(fmu, design, handling))):
        trial.report(value, step)
        if math.isfinite(value) and trial.should_prune():
            study.tell(trial, state=TrialState.PRUNED)
            return
    study.tell(trial, value)


def run_search(journal: Path, fmu: str, handling: int, seed: int, budget: int,
               opened: JournalStorage | None = None) -> int:
    """Run (or resume) one search until ``budget`` trials count; return how many ran now. ``opened``: the
    journal's storage if the caller has it open (opening one reads the whole journal)."""
    study = _open(journal, fmu, handling, seed, opened)
    done = finished_trials(study)
    if done:
        _verify(study, fmu, handling, done)
    initial = tuning.initial_design(fmu, seed)
    ran = 0
    while len(done) < budget:
        i = len(done)
        study.sampler = _sampler(seed, i)
        if i < len(initial) and not study.get_trials(deepcopy=False, states=(TrialState.WAITING,)):
            study.enqueue_trial(initial[i])
        _trial(study, fmu, handling)
        ran += 1
        done = finished_trials(study)
    return ran


def record(journal: JournalStorage, fmu: str, handling: int, seed: int, budget: int) -> dict[str, Any] | None:
    """The store's record of one search (its first ``budget`` trials), None if it has none yet."""
    if study_name(fmu, handling, seed) not in {s.study_name for s in journal.get_all_studies()}:
        return None
    study = optuna.load_study(study_name=study_name(fmu, handling, seed), storage=journal)
    trials = finished_trials(study)[:budget]
    if not trials:
        return None
    values = [t.value if t.state == TrialState.COMPLETE and math.isfinite(t.value) else None for t in trials]
    finite = [(v, i) for i, v in enumerate(values) if v is not None]
    best = min(finite)[1] if finite else 0
    seconds = sum((t.datetime_complete - t.datetime_start).total_seconds() for t in trials)
    return {"criterion": values, "state": [_state(t) for t in trials], "best": best,
            "best_design": dict(trials[best].params), "trials": len(trials), "trial_seconds": round(seconds, 1),
            "started": min(t.datetime_start for t in trials).isoformat(timespec="seconds"),
            "finished": max(t.datetime_complete for t in trials).isoformat(timespec="seconds")}
