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

import math
import warnings
from pathlib import Path
from typing import Any

import optuna
from optuna.storages import JournalStorage
from optuna.storages.journal import JournalFileBackend, JournalFileOpenLock
from optuna.trial import TrialState

from orchestration.exit_codes import UsageError
from orchestration.run.search_space import Dimension
from orchestration.study import tuning

# a run that fails completes its trial with an infinite criterion: a failed trial is one cut off (by
# an interruption, or an error that stopped the search), and the next run repeats it
FINISHED = (TrialState.COMPLETE, TrialState.PRUNED)


class JournalError(UsageError):
    """A journal that cannot be resumed by this code (another protocol, or numbers that changed)."""


def study_name(problem, seed: int) -> str:
    """The study of one search of ``problem`` (``tuning.Ours``, or a foreign controller's): its name and seed."""
    return f"{problem.name}/seed{seed}"


def storage(journal: Path) -> JournalStorage:
    return JournalStorage(JournalFileBackend(str(journal), lock_obj=JournalFileOpenLock(str(journal))))


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


def _open(journal: Path, problem, seed: int, opened: JournalStorage | None = None) -> optuna.Study:
    pruner = optuna.pruners.PercentilePruner(tuning.PRUNE_PERCENTILE, n_startup_trials=tuning.INITIAL_DESIGN,
                                             n_warmup_steps=tuning.PRUNE_AFTER - 1)
    study = open_study(journal, study_name(problem, seed), problem.digest(seed), opened, pruner=pruner)
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


def _verify(study: optuna.Study, problem, trials: list) -> None:
    """The first trial (the nominal design) must give its first training number again, bit for bit:
    the running criterion after the first point, as the trial reported it (the geometric mean of one
    MSE, exp(log(mse)), which is not the MSE itself in the last bit for about half of all doubles)."""
    first = trials[0]
    if 0 not in first.intermediate_values:
        return
    again = next(problem.running(problem.initial(0)[0]))  # runs the first training point only
    if again != first.intermediate_values[0]:
        raise JournalError(f"the journal's search {study.study_name} no longer reproduces its first trial "
                           f"({first.intermediate_values[0]!r}, now {again!r}): the code changed since it ran; "
                           "give another --out (or remove the journal)")


def distribution(dim: Dimension) -> optuna.distributions.BaseDistribution:
    """The Optuna distribution ``suggest`` draws a dimension from (for a trial added by the CMA-ES phase)."""
    if dim.kind == "choice":
        return optuna.distributions.CategoricalDistribution(list(dim.choices))
    if dim.kind == "int":
        return optuna.distributions.IntDistribution(int(dim.low), int(dim.high), log=dim.log)
    return optuna.distributions.FloatDistribution(dim.low, dim.high, log=dim.log)


def suggest(trial: optuna.Trial, dim: Dimension) -> float:
    """The trial's value of one dimension: a float or a whole number in its range (log-scaled if it says so),
    or one of its choices."""
    if dim.kind == "choice":
        return trial.suggest_categorical(dim.name, list(dim.choices))
    if dim.kind == "int":
        return trial.suggest_int(dim.name, int(dim.low), int(dim.high), log=dim.log)
    return trial.suggest_float(dim.name, dim.low, dim.high, log=dim.log)


def _trial(study: optuna.Study, problem) -> None:
    """Ask for one trial, run its training points (pruned or failed early where it must), tell it; a failed
    run's reason (``problem.failure``, where the problem gives one) is kept with the trial."""
    trial = study.ask()
    design = {name: suggest(trial, dim) for name, dim in problem.space.items()}
    value = math.inf
    for step, value in enumerate(problem.running(design)):
        trial.report(value, step)
        if math.isfinite(value) and trial.should_prune():
            study.tell(trial, state=TrialState.PRUNED)
            return
    if not math.isfinite(value) and getattr(problem, "failure", None):
        trial.set_user_attr("failure", problem.failure)
    study.tell(trial, value)


def run_search(journal: Path, problem, seed: int, budget: int, opened: JournalStorage | None = None) -> int:
    """Run (or resume) one search of ``problem`` until ``budget`` trials count; return how many ran now.
    ``opened``: the journal's storage if the caller has it open (opening one reads the whole journal)."""
    study = _open(journal, problem, seed, opened)
    done = finished_trials(study)
    if done:
        _verify(study, problem, done)
    initial = problem.initial(seed)
    ran = 0
    while len(done) < budget:
        i = len(done)
        study.sampler = _sampler(seed, i)
        if i < len(initial) and not study.get_trials(deepcopy=False, states=(TrialState.WAITING,)):
            study.enqueue_trial(initial[i])
        _trial(study, problem)
        ran += 1
        done = finished_trials(study)
    return ran


def record(journal: JournalStorage, problem, seed: int, budget: int) -> dict[str, Any] | None:
    """The store's record of one search (its first ``budget`` trials), None if it has none yet."""
    if study_name(problem, seed) not in {s.study_name for s in journal.get_all_studies()}:
        return None
    study = optuna.load_study(study_name=study_name(problem, seed), storage=journal)
    trials = finished_trials(study)[:budget]
    if not trials:
        return None
    values = [t.value if t.state == TrialState.COMPLETE and math.isfinite(t.value) else None for t in trials]
    finite = [(v, i) for i, v in enumerate(values) if v is not None]
    best = min(finite)[1] if finite else 0
    seconds = sum((t.datetime_complete - t.datetime_start).total_seconds() for t in trials)
    failures = {str(i): t.user_attrs["failure"] for i, t in enumerate(trials) if "failure" in t.user_attrs}
    out = {"criterion": values, "state": [_state(t) for t in trials], "best": best,
           "best_design": dict(trials[best].params), "trials": len(trials), "trial_seconds": round(seconds, 1),
           "started": min(t.datetime_start for t in trials).isoformat(timespec="seconds"),
           "finished": max(t.datetime_complete for t in trials).isoformat(timespec="seconds")}
    return out | ({"failures": failures} if failures else {})  # a failed run's reason, by trial number
