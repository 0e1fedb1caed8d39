"""One tuning protocol for every controller, the SOTC included: the same budget, the same criterion.

The protocol, fixed before any search ran (docs/baselines.md, "Tuning protocol"):

* **Design parameters** (``SEARCH_SPACES``): each controller's own, searched log-uniformly in a range
  of about two decades around its nominal design: SOTC Lambda_1, Lambda_2 (both joints alike), Theta,
  R (all entries alike) and alpha_1; CT kp, kd; LQR q, r; OTC Lambda (two gains), Q and R (two weights).
* **Budget**: ``BUDGET`` evaluated points per controller and per limit handling: the nominal design
  (the scenario's parameters, the paper's for the SOTC and the OTC) and ``BUDGET - 1`` points of a
  Latin hypercube drawn with ``SEED`` (the same draw, in each controller's own dimensions).
* **Handlings**: each of radial, joint and accel (``fmu_controller.saturation``), for every controller.
* **Criterion**: Table 1's metric, MSE_1 + MSE_2 (eq. (50)) of the 100 s `paper` loop from the
  paper's initial state; a run that fails counts as infinite. The lowest wins.
* **Tuning set**: that one nominal run. Everything the comparison judges afterwards
  (``orchestration.study.fair``) runs on initial states and perturbed plants the search never saw.

``python -m orchestration.study.tuning`` runs the search and stores it (``TUNED_FILE``, shipped with
the package, so that an installed `sotc-cosim` and a sweep's ``tuning = "best"`` read the same
result); tests/docs/test_tuning_store.py re-runs a sample of it and fails when the stored file and
the code disagree.
"""
from __future__ import annotations

import argparse
import functools
import json
import math
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

from fmu_controller.catalog import CORES
from fmu_controller.saturation import LIMIT_HANDLINGS
from orchestration.outputs import atomic_write
from orchestration.run.metrics import tracking_metrics
from orchestration.run.scenario import load_scenario
from orchestration.study.pure_loop import simulate

BUDGET = 16
SEED = 2026
HANDLINGS = (0, 1, 2)  # radial, joint, accel
TUNING_STOP_TIME = 100.0
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


def nominal_parameters(fmu: str) -> dict[str, float]:
    return dict(load_scenario(NOMINAL_SCENARIO[fmu]).instances["controller"].parameters)


def nominal_design(fmu: str) -> dict[str, float]:
    """The nominal point in design coordinates (each design parameter: its first FMU parameter, or the
    FMU's default when the scenario does not set it)."""
    params = nominal_parameters(fmu)
    defaults = {s.name: s.default for s in CORES[fmu].PARAMETER_SPECS}
    return {name: float(params.get(targets[0], defaults[targets[0]])) for name, (_, _, targets) in SEARCH_SPACES[fmu].items()}


def design_points(fmu: str) -> list[dict[str, float]]:
    """The ``BUDGET`` design points of ``fmu``: nominal first, then a seeded Latin hypercube (log scale)."""
    space = SEARCH_SPACES[fmu]
    rng = np.random.default_rng(SEED)
    n = BUDGET - 1
    points = [nominal_design(fmu)]
    columns = {}
    for name, (low, high, _) in space.items():
        u = (rng.permutation(n) + rng.uniform(size=n)) / n  # one sample in each of n strata
        columns[name] = np.exp(np.log(low) + u * (np.log(high) - np.log(low)))
    points += [{name: float(f"{columns[name][i]:.4g}") for name in space} for i in range(n)]
    return points


def parameters(fmu: str, design: dict[str, float], handling: int) -> dict[str, float]:
    """The FMU parameters of a design point under a limit handling (the nominal scenario's others kept)."""
    params = nominal_parameters(fmu)
    for name, value in design.items():
        params.update({target: value for target in SEARCH_SPACES[fmu][name][2]})
    params["limit_handling"] = float(handling)
    return params


def criterion(fmu: str, params: dict[str, float], stop_time: float = TUNING_STOP_TIME) -> float:
    """MSE_1 + MSE_2 (eq. (50)) of the nominal `paper` loop; inf for a run that fails."""
    try:
        res = simulate(CORES[fmu](**params), stop_time=stop_time)
    except (ArithmeticError, ValueError, RuntimeError):  # IntegrationError, a refused state
        return math.inf
    mse = tracking_metrics(res.t, res.error, res.tau)["mse"]
    value = math.inf if None in mse else float(sum(mse))
    return value if math.isfinite(value) else math.inf


def _evaluate(job: tuple[str, int, int]) -> tuple[str, int, int, float]:
    fmu, handling, i = job
    return fmu, handling, i, criterion(fmu, parameters(fmu, design_points(fmu)[i], handling))


def search(workers: int = 2) -> dict[str, Any]:
    """Every controller's whole budget under every handling, and the best point of each."""
    jobs = [(fmu, h, i) for fmu in CONTROLLERS for h in HANDLINGS for i in range(BUDGET)]
    with ProcessPoolExecutor(max_workers=workers) as pool:
        done = list(pool.map(_evaluate, jobs, chunksize=4))
    result: dict[str, Any] = {"budget": BUDGET, "seed": SEED, "criterion": "mse1 + mse2, 100 s `paper` loop",
                              "controllers": {}}
    for fmu in CONTROLLERS:
        points = design_points(fmu)
        per_handling = {}
        for h in HANDLINGS:
            values = [v for f, hh, _, v in sorted(done, key=lambda d: d[2]) if f == fmu and hh == h]
            best = int(np.argmin(values))
            per_handling[LIMIT_HANDLINGS[h]] = {"criterion": [None if math.isinf(v) else v for v in values],
                                                "best": best, "best_design": points[best]}
        result["controllers"][fmu] = {"designs": points, "handlings": per_handling}
    return result


@functools.lru_cache(maxsize=1)
def stored() -> dict[str, Any]:
    """The stored search, read once per process (every tuned point of a sweep or a batch asks for it)."""
    return json.loads(TUNED_FILE.read_text())


def best_design(fmu: str, handling: int) -> dict[str, float]:
    """The stored best design point of ``fmu`` under a handling (the README's "tuned" rows)."""
    return dict(stored()["controllers"][fmu]["handlings"][LIMIT_HANDLINGS[int(handling)]]["best_design"])


def tuned_parameters(fmu: str, handling: int) -> dict[str, float]:
    """The FMU parameters the tuning sets for ``fmu`` under a handling (design parameters expanded)."""
    design = best_design(fmu, handling)
    return {target: value for name, value in design.items() for target in SEARCH_SPACES[fmu][name][2]}


def tuned_parameter_names(fmu: str) -> set[str]:
    return {target for _, _, targets in SEARCH_SPACES.get(fmu, {}).values() for target in targets}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--workers", type=int, default=2)
    args = ap.parse_args(argv)
    atomic_write(TUNED_FILE, json.dumps(search(args.workers), indent=1) + "\n")
    print(TUNED_FILE)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
