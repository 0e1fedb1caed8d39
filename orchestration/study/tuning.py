"""One tuning protocol for every controller, the SOTC included: the same budget, the same criterion,
the same training set, several seeds.

The protocol (docs/baselines.md, "Tuning protocol"):

* **Design parameters** (``SEARCH_SPACES``): each controller's own, searched log-uniformly in a range
  of about two decades around its nominal design: SOTC Lambda_1, Lambda_2 (both joints alike), Theta,
  R (all entries alike) and alpha_1; CT kp, kd; LQR q, r; OTC Lambda (two gains), Q and R (two weights).
* **Training set** (``training_points``): ``TRAINING_POINTS`` seeded points, initial states and
  perturbed plants drawn by ``orchestration.study.points`` with seed ``TRAINING_SEED`` and noise seeds
  from ``TRAINING_NOISE_SEED``, disjoint from both held-out sets of ``orchestration.study.fair``;
  each run lasts ``STOP_TIME`` in the pure loop.
* **Criterion**: the geometric mean over the training set of MSE_1 + MSE_2 (eq. (50)); a run that
  fails makes it infinite. The lowest wins.
* **Search** (``orchestration.study.optimize``, Optuna): per controller, limit handling and seed,
  ``protocol.BUDGET`` trials: the nominal design, then ``INITIAL_DESIGN - 1`` points of a scrambled Latin
  hypercube (``scipy.stats.qmc``, seeded with the tuning seed), then Optuna's TPE sampler, seeded per
  trial; a trial whose running criterion is not among the best ``PRUNE_PERCENTILE`` % of the complete
  trials at the same training point is pruned there (from the ``PRUNE_AFTER``-th point on).
  Then ``protocol.POLISH`` trials of CMA-ES started from the TPE phase's best
  (``orchestration.study.polish``), every training point run.
* **Convergence** (``still_improving``): doubling the CMA-ES phase moves the best by less than
  ``protocol.CONVERGED`` (its last half; the whole search's, for a store without that phase).
* **Seeds** (``protocol.SEEDS``): independent searches; each seed's best design is judged on the held-out sets.

``sotc-cosim tune`` runs the search and writes the store (recordings/tuning/tuned.json); the shipped
store (``TUNED_FILE``, so that an installed `sotc-cosim` and a sweep's ``tuning = "best"`` read the same
result) is a copy of that output; tests/docs/test_fair_store.py re-runs a sample of it.
"""
from __future__ import annotations

import functools
import hashlib
import itertools
import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterator

import numpy as np

from fmu_controller.catalog import CORES
from fmu_controller.saturation import LIMIT_HANDLINGS
from orchestration.run.scenario import load_scenario
from orchestration.run.search_space import Dimension
from orchestration.study.points import KINDS, draw_points, run_point
from orchestration.study.protocol import CONVERGED

HANDLINGS = (0, 1, 2)  # radial, joint, accel
INITIAL_DESIGN = 8  # the nominal design and a Latin hypercube, before the sampler models anything
PRUNE_AFTER = 2  # training points every trial runs before it may be pruned (one of each kind)
PRUNE_PERCENTILE = 25.0  # a trial continues while its running criterion is among this best % of complete trials
STOP_TIME = 20.0  # s, each training run (as long as the held-out runs)
TRAINING_SEED = 2026
TRAINING_NOISE_SEED = 1001  # the held-out draws use noise seeds 1..384 (orchestration.study.fair)
TRAINING_POINTS = {"initial states": 4, "perturbed": 4}
TUNED_FILE = Path(__file__).with_name("tuned.json")

# the scenario whose controller parameters are each controller's nominal design
NOMINAL_SCENARIO = {"SotcController": "paper", "CtController": "paper-ct", "LqrController": "paper-lqr",
                    "OtcController": "paper-otc"}
# design parameter -> (low, high, FMU parameters it sets); searched log-uniformly
SEARCH_SPACES: dict[str, dict[str, tuple[float, float, tuple[str, ...]]]] = {
    "SotcController": {"Lambda_1": (0.1, 30.0, ("lambda1_1", "lambda1_2")),
                       "Lambda_2": (0.1, 30.0, ("lambda2_1", "lambda2_2")),
                       "Theta": (0.1, 100.0, ("theta_1", "theta_2", "theta_3", "theta_4")),
                       "R": (0.01, 10.0, ("r_1", "r_2", "r_3", "r_4")),
                       "alpha_1": (5.0, 500.0, ("alpha1",))},
    "CtController": {"kp": (1.0, 1000.0, ("kp",)), "kd": (1.0, 100.0, ("kd",))},
    "LqrController": {"q": (0.1, 1000.0, ("q",)), "r": (1e-4, 10.0, ("r",))},
    "OtcController": {"Lambda_1": (20.0, 2000.0, ("lambda1",)), "Lambda_2": (5.0, 500.0, ("lambda2",)),
                      "Q": (0.1, 100.0, ("q",)), "R_1": (2.0, 200.0, ("r1",)), "R_2": (10.0, 1000.0, ("r2",))},
}
CONTROLLERS = tuple(SEARCH_SPACES)


def training_points() -> list[dict[str, Any]]:
    """The training set: ``TRAINING_POINTS`` of each kind, alternating (pruning compares trials point by
    point, so an early decision sees both kinds)."""
    drawn = [draw_points(TRAINING_SEED, which, TRAINING_POINTS[which], TRAINING_NOISE_SEED) for which in KINDS]
    return [p for group in itertools.zip_longest(*drawn) for p in group if p is not None]


def nominal_parameters(fmu: str) -> dict[str, float]:
    return dict(load_scenario(NOMINAL_SCENARIO[fmu]).instances["controller"].parameters)


def nominal_design(fmu: str) -> dict[str, float]:
    """The nominal point in design coordinates (each design parameter: its first FMU parameter, or the
    FMU's default when the scenario does not set it)."""
    params = nominal_parameters(fmu)
    defaults = {s.name: s.default for s in CORES[fmu].PARAMETER_SPECS}
    return {name: float(params.get(targets[0], defaults[targets[0]])) for name, (_, _, targets) in SEARCH_SPACES[fmu].items()}


def initial_design(fmu: str, seed: int) -> list[dict[str, float]]:
    """The first ``INITIAL_DESIGN`` trials of a search: the nominal design, then a scrambled Latin
    hypercube on the log scale of each design parameter, seeded with the tuning seed."""
    from scipy.stats import qmc  # here, not at the top: ``sotc-cosim``'s parser reads this module's constants

    space = SEARCH_SPACES[fmu]
    low = np.log([lo for lo, _, _ in space.values()])
    high = np.log([hi for _, hi, _ in space.values()])
    unit = qmc.LatinHypercube(d=len(space), rng=np.random.default_rng([seed, CONTROLLERS.index(fmu)]))
    rows = np.exp(qmc.scale(unit.random(INITIAL_DESIGN - 1), low, high))
    return [nominal_design(fmu)] + [{name: float(v) for name, v in zip(space, row)} for row in rows]


def parameters(fmu: str, design: dict[str, float], handling: int) -> dict[str, float]:
    """The FMU parameters of a design point under a limit handling (the nominal scenario's others kept)."""
    params = nominal_parameters(fmu)
    for name, value in design.items():
        params.update({target: value for target in SEARCH_SPACES[fmu][name][2]})
    params["limit_handling"] = float(handling)
    return params


def running_criterion(fmu: str, params: dict[str, float]) -> Iterator[float]:
    """After each training point in turn: the geometric mean of MSE_1 + MSE_2 over the points so far
    (the criterion, after the last); inf, and no further point, once a run fails."""
    logs = 0.0
    for k, point in enumerate(training_points(), start=1):
        mse = run_point(fmu, params, point, STOP_TIME)["mse"]
        if mse is None or mse <= 0.0:
            yield math.inf
            return
        logs += math.log(mse)
        yield math.exp(logs / k)


def criterion(fmu: str, params: dict[str, float]) -> float:
    """The tuning criterion of one design (every training point run)."""
    value = math.inf
    for value in running_criterion(fmu, params):
        pass
    return value


def best_so_far(values: list[float | None]) -> list[float]:
    """The lowest criterion among the trials up to each one (a pruned or failed trial: None, inf)."""
    out, best = [], math.inf
    for v in values:
        best = min(best, math.inf if v is None else v)
        out.append(best)
    return out


def last_half_improvement(values: list[float | None], start: int = 0) -> float:
    """How much the best-so-far fell over the last half of the trials from ``start`` on, relative to where
    it stood at that half (0.01: 1 %); the trials before ``start`` count only as where the best began."""
    curve = best_so_far(values)
    half, end = curve[max(start + (len(curve) - start) // 2 - 1, 0)], curve[-1]
    if half == end:
        return 0.0
    return 1.0 if math.isinf(half) else (half - end) / half


def improvement(record: dict[str, Any]) -> float:
    """What the convergence rule judges in a stored search (of the whole search when it has no CMA-ES
    phase, ``orchestration.study.polish``): the larger of the last-half improvements of its CMA-ES phase
    measured on the search's best-so-far (the TPE best where it began) and on the phase's own
    best-so-far. CMA-ES is not elitist: a phase that never comes back down to its start reads 0 on the
    first whatever it does, and the second says whether it still falls. Below ``CONVERGED``, enough."""
    start = record.get("polish_from")
    if start is None:
        return last_half_improvement(record["criterion"])
    return max(last_half_improvement(record["criterion"], start), last_half_improvement(record["criterion"][start:]))


def tpe_improvement(record: dict[str, Any]) -> float:
    """The last-half improvement of a stored search's TPE phase alone (shown beside the rule's)."""
    return last_half_improvement(record["criterion"][:record.get("polish_from", len(record["criterion"]))])


def still_improving(record: dict[str, Any]) -> bool:
    """Whether a stored search's best-so-far improves by ``CONVERGED`` or more by the rule (``improvement``)."""
    return improvement(record) >= CONVERGED


def unconverged(data: dict[str, Any]) -> list[str]:
    """The searches of a store ("<controller> <handling> seed <seed>") that still improve by the rule."""
    return [f"{fmu} {h} seed {s}" for fmu, c in data["controllers"].items() for h, per in c["handlings"].items()
            for s, r in per["seeds"].items() if still_improving(r)]


@dataclass(frozen=True)
class Ours:
    """One of our controllers under a limit handling, as a search tunes it (``optimize`` and ``polish`` take
    any problem of this shape; a foreign controller's is ``orchestration.study.benchmark_problem``): its
    ``name`` (the searches' study names start so), ``space``, ``initial`` design, ``running`` criterion and
    ``digest`` of what its trials depend on besides the loop's code."""

    fmu: str
    handling: int

    @property
    def name(self) -> str:
        return f"{self.fmu}/{LIMIT_HANDLINGS[self.handling]}"

    @property
    def space(self) -> dict[str, Dimension]:
        return {name: Dimension(name, "float", low, high, True) for name, (low, high, _) in SEARCH_SPACES[self.fmu].items()}

    def initial(self, seed: int) -> list[dict[str, float]]:
        return initial_design(self.fmu, seed)

    def running(self, design: dict[str, float]) -> Iterator[float]:
        return running_criterion(self.fmu, parameters(self.fmu, design, self.handling))

    def criterion(self, design: dict[str, float]) -> float:
        return criterion(self.fmu, parameters(self.fmu, design, self.handling))

    def digest(self, seed: int) -> str:
        """Everything a search's trials depend on besides the code of the loop (which the first trial's check
        covers)."""
        import optuna  # the parser of ``sotc-cosim`` reads this module's constants: not at the top

        text = json.dumps({"space": SEARCH_SPACES[self.fmu], "points": training_points(), "stop": STOP_TIME,
                           "initial": initial_design(self.fmu, seed), "prune_after": PRUNE_AFTER,
                           "prune_percentile": PRUNE_PERCENTILE, "optuna": optuna.__version__.split(".")[0]},
                          sort_keys=True)
        return hashlib.sha256(text.encode()).hexdigest()[:16]


# --- the stored search --------------------------------------------------------------------------------

@functools.lru_cache(maxsize=1)
def stored() -> dict[str, Any]:
    """The shipped search, read once per process (every tuned point of a sweep or a batch asks for it)."""
    return json.loads(TUNED_FILE.read_text())


def study_record(fmu: str, handling: int, seed: int | None = None, data: dict[str, Any] | None = None) -> dict[str, Any]:
    """One search of a store (default: the shipped one): ``criterion`` (every trial in order), ``state``,
    ``best`` (its index), ``best_design``; ``seed`` None is the store's first seed."""
    data = data or stored()
    seed = data["seeds"][0] if seed is None else seed
    return data["controllers"][fmu]["handlings"][LIMIT_HANDLINGS[int(handling)]]["seeds"][str(seed)]


def best_design(fmu: str, handling: int, seed: int | None = None) -> dict[str, float]:
    """The stored best design point of ``fmu`` under a handling, for a tuning seed (default: the first)."""
    return dict(study_record(fmu, handling, seed)["best_design"])


def tuned_parameters(fmu: str, handling: int, seed: int | None = None) -> dict[str, float]:
    """The FMU parameters the tuning sets for ``fmu`` under a handling (design parameters expanded)."""
    design = best_design(fmu, handling, seed)
    return {target: value for name, value in design.items() for target in SEARCH_SPACES[fmu][name][2]}


def tuned_parameter_names(fmu: str) -> set[str]:
    return {target for _, _, targets in SEARCH_SPACES.get(fmu, {}).values() for target in targets}
