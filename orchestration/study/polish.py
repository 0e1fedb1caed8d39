"""The second phase of every tuning search: CMA-ES (``cmaes``, the implementation Optuna's own
CmaEsSampler wraps) started from the best design of the TPE phase (``orchestration.study.optimize``), and
the store of both phases.

Why a second phase (docs/baselines.md, "Tuning protocol"): TPE's best moves in jumps, from one basin of
the criterion to another, and a jump can come late: one SOTC search was flat from trial 256 to 512 and
then fell 1.67 % by trial 1024. No budget of a global search shows that no later jump will come. What a
search can show is that its best design is the bottom of its basin; that is what this phase does, and
what the convergence rule (``tuning.still_improving``) judges. Which basin a search ends in is what the
independent tuning seeds sample, and a verdict is stated only where every seed gives it.

Coordinates: each design parameter (its log where its range is log-scaled: all of ours,
``tuning.SEARCH_SPACES``), scaled to [0, 1] over its search range; a whole-number parameter is rounded from
its position, and a choice is not moved (it keeps the TPE best's value: CMA-ES has no geometry for it). The start is the TPE phase's best design; the initial step ``SIGMA0`` of that
cube; the population CMA-ES's default for the dimension; the generator seeded from the tuning seed.
Every trial runs all its training points (CMA-ES ranks every candidate of a generation; a failed run
ranks last).

Resume and determinism: a trial enters the journal only once its criterion is known (``add_trial``), so
an interrupted one leaves nothing and runs again. A resumed phase replays CMA-ES from its start: each
candidate it asks for must be the journal's trial of that number (to ``MATCH``, relative: the
eigendecomposition may round otherwise on another machine), and the journal's design and criterion are
told in its place. An uninterrupted run tells the design as stored too, so both give the same trials.
"""
from __future__ import annotations

import datetime
import hashlib
import json
import math
import sys
from pathlib import Path
from typing import Any

import cmaes
import numpy as np
import optuna
from optuna.trial import TrialState

from fmu_controller.saturation import LIMIT_HANDLINGS
from orchestration.paths import json_kind
from orchestration.run.search_space import Dimension
from orchestration.study import optimize, tuning

COUNTED = (TrialState.COMPLETE,)  # the CMA-ES phase's trials (added complete, never pruned)
SIGMA0 = 0.1  # the initial step, in the unit cube of the log-scaled search space
MATCH = 1e-9  # a replayed candidate and the journal's trial of its number agree to this (relative)
FAILED = sys.float_info.max  # a failed run's value for CMA-ES's ranking: behind every finite criterion
STREAM = 2**31  # CMA-ES's generator (optimize.generator_seed): out of reach of the TPE phase's, one per trial number


def study_name(problem, seed: int, budget: int) -> str:
    """The phase started from the best of the TPE phase's first ``budget`` trials."""
    return f"{optimize.study_name(problem, seed)}/cma-es-after-{budget}"


def _ranges(problem) -> list[Dimension]:
    """The dimensions CMA-ES moves (every range; a choice keeps the TPE best's value)."""
    return [d for d in problem.space.values() if d.kind != "choice"]


def _scale(problem) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per moved dimension: whether log-scaled, and its low and width on that scale."""
    dims = _ranges(problem)
    logs = np.array([d.log for d in dims], dtype=bool)
    low = np.where(logs, np.log([d.low if d.log else 1.0 for d in dims]), [d.low for d in dims])
    high = np.where(logs, np.log([d.high if d.log else 1.0 for d in dims]), [d.high for d in dims])
    return logs, low, high - low


def to_unit(problem, design: dict[str, float]) -> np.ndarray:
    logs, low, width = _scale(problem)
    values = np.array([design[d.name] for d in _ranges(problem)], dtype=float)
    return (np.where(logs, np.log(np.where(logs, values, 1.0)), values) - low) / width


def from_unit(problem, unit: np.ndarray, start: dict[str, float] | None = None) -> dict[str, float]:
    """The design at ``unit`` (clipped to the cube), a whole number where a dimension is "int", and each
    choice as in ``start``."""
    logs, low, width = _scale(problem)
    scaled = low + np.clip(unit, 0.0, 1.0) * width
    values = np.where(logs, np.exp(scaled), scaled)
    out: dict[str, float] = {}
    for d, v in zip(_ranges(problem), values):
        # exp(log(x)) may leave the range by a rounding; the bounds are the space's own numbers
        v = min(max(float(v), d.low), d.high)
        out[d.name] = int(round(v)) if d.kind == "int" else v
    return {name: out[name] if name in out else start[name] for name in problem.space}


def _protocol(problem, seed: int, start: dict[str, float]) -> str:
    # not cmaes's version: a version that asks for other candidates is refused by the replay itself
    text = json.dumps({"tpe": problem.digest(seed), "start": start, "sigma0": SIGMA0}, sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def _open(journal: Path, problem, seed: int, budget: int, start: dict[str, float], opened=None) -> optuna.Study:
    return optimize.open_study(journal, study_name(problem, seed, budget), _protocol(problem, seed, start), opened)


def _distributions(problem) -> dict[str, optuna.distributions.BaseDistribution]:
    return {name: optimize.distribution(d) for name, d in problem.space.items()}


def _evaluate(study: optuna.Study, problem, design: dict[str, float]) -> float:
    """Run one candidate on every training point and add it to the journal, complete, in one write (a failed
    run's reason with it, where the problem gives one)."""
    started = datetime.datetime.now()
    value = problem.criterion(design)
    failure = getattr(problem, "failure", None) if not math.isfinite(value) else None
    trial = optuna.trial.create_trial(params=design, distributions=_distributions(problem), value=value,
                                      user_attrs={"failure": failure} if failure else None)
    trial.datetime_start = started
    study.add_trial(trial)
    return value


def _replayed(study: optuna.Study, trial: optuna.trial.FrozenTrial, design: dict[str, float]) -> tuple[dict, float]:
    if not all(design[name] == trial.params[name] or math.isclose(design[name], trial.params[name], rel_tol=MATCH)
               for name in design):
        raise optimize.JournalError(f"the journal's search {study.study_name} no longer replays its trial "
                                    f"{trial.number} ({trial.params}, now {design}): the code changed since it ran; "
                                    "give another --out (or remove the journal)")
    return dict(trial.params), trial.value


def run_polish(journal: Path, problem, seed: int, budget: int, trials: int, start: dict[str, float], opened=None) -> int:
    """Run (or resume) the CMA-ES phase from ``start`` until ``trials`` count; return how many ran now.
    ``opened``: the journal's storage if the caller has it open. A space whose only dimension is a choice
    has nothing to move: its phase runs no trial."""
    study = _open(journal, problem, seed, budget, start, opened)
    done = study.get_trials(deepcopy=False, states=COUNTED)
    mean = to_unit(problem, start)
    if not len(mean):
        return 0
    cma = cmaes.CMA(mean=mean, sigma=SIGMA0, bounds=np.array([[0.0, 1.0]] * len(mean)),
                    seed=optimize.generator_seed(seed, STREAM))
    ran, k = 0, 0
    while k < trials:
        told = []
        for _ in range(min(cma.population_size, trials - k)):
            design = from_unit(problem, cma.ask(), start)
            if k < len(done):
                design, value = _replayed(study, done[k], design)
            else:
                value = _evaluate(study, problem, design)
                ran += 1
            told.append((to_unit(problem, design), value if math.isfinite(value) else FAILED))
            k += 1
        if len(told) == cma.population_size:
            cma.tell(told)
    return ran


def search(journal: Path, problem, seed: int, budget: int, polish: int) -> int:
    """One whole search: the TPE phase until ``budget`` trials count, then ``polish`` CMA-ES trials from its
    best design; return how many trials ran now. The journal is read once (each reading parses all of it:
    seconds, at the stored study's size)."""
    opened = optimize.storage(journal)
    ran = optimize.run_search(journal, problem, seed, budget, opened)
    if polish <= 0:
        return ran
    first = optimize.record(opened, problem, seed, budget)
    return ran + run_polish(journal, problem, seed, budget, polish, first["best_design"], opened)


def _polish_record(journal, problem, seed: int, budget: int, polish: int) -> dict[str, Any] | None:
    name = study_name(problem, seed, budget)
    if name not in {s.study_name for s in journal.get_all_studies()}:
        return None
    trials = optuna.load_study(study_name=name, storage=journal).get_trials(deepcopy=False, states=COUNTED)
    return {"trials": trials[:polish]} if trials else None


def record(journal, problem, seed: int, budget: int, polish: int) -> dict[str, Any] | None:
    """The store's record of one search: its TPE phase (``optimize.record``) followed by its CMA-ES phase;
    ``polish_from`` is the trial number where the CMA-ES phase starts, ``polish_start`` the design it starts from."""
    r = optimize.record(journal, problem, seed, budget)
    if r is None or polish <= 0 or r["trials"] < budget:
        return r
    extra = _polish_record(journal, problem, seed, budget, polish)
    if extra is None:
        return r
    trials, start = extra["trials"], r["best_design"]
    values = [t.value if math.isfinite(t.value) else None for t in trials]
    r["criterion"] = r["criterion"] + values
    r["state"] = r["state"] + ["complete" if v is not None else "failed" for v in values]
    finite = [(v, i) for i, v in enumerate(r["criterion"]) if v is not None]
    if finite:
        r["best"] = min(finite)[1]
        r["best_design"] = dict(trials[r["best"] - budget].params) if r["best"] >= budget else r["best_design"]
    failures = {str(budget + i): t.user_attrs["failure"] for i, t in enumerate(trials) if "failure" in t.user_attrs}
    if failures:
        r["failures"] = {**r.get("failures", {}), **failures}
    r["polish_from"], r["polish_start"] = budget, start
    r["trials"] = len(r["criterion"])
    r["trial_seconds"] = round(r["trial_seconds"] + sum((t.datetime_complete - t.datetime_start).total_seconds()
                                                        for t in trials), 1)
    r["finished"] = max([r["finished"]] + [t.datetime_complete.isoformat(timespec="seconds") for t in trials])
    return r


STORE = json_kind("a tune store (JSON with budget and controllers)", ("budget", "controllers"))  # what --out replaces


def store(path: Path, controllers, handlings, seeds, budget: int, polish: int) -> dict[str, Any]:
    """The store (``tuning.TUNED_FILE``'s shape) of these searches in the journal at ``path``."""
    journal = optimize.storage(path)
    out: dict[str, Any] = {
        "budget": budget, "polish": polish, "seeds": list(seeds), "training_points": len(tuning.training_points()),
        "criterion": f"geometric mean of MSE_1 + MSE_2 over the training points, {tuning.STOP_TIME:g} s each",
        "sampler": f"optuna {optuna.__version__} TPESampler (multivariate), {tuning.INITIAL_DESIGN} initial trials "
                   f"(nominal + scipy.stats.qmc Latin hypercube), PercentilePruner({tuning.PRUNE_PERCENTILE:g}) from point "
                   f"{tuning.PRUNE_AFTER} on" + (f"; then {polish} trials of CMA-ES (cmaes {cmaes.__version__}, "
                                                 f"sigma0 {SIGMA0:g} of the log-scaled range) from the best" if polish else ""),
        "controllers": {}}
    for fmu in controllers:
        per_handling = {}
        for h in handlings:
            problem = tuning.Ours(fmu, h)
            seeds_done = {str(s): r for s in seeds if (r := record(journal, problem, s, budget, polish)) is not None}
            per_handling[LIMIT_HANDLINGS[h]] = {"seeds": seeds_done}
        out["controllers"][fmu] = {"handlings": per_handling}
    records = [r for c in out["controllers"].values() for h in c["handlings"].values() for r in h["seeds"].values()]
    out["complete"] = len(records) == len(controllers) * len(handlings) * len(seeds) and all(
        r["trials"] == budget + polish for r in records)
    out["trial_seconds"] = round(sum(r["trial_seconds"] for r in records), 1)
    return out
