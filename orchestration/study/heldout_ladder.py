"""The sensitivity to the initial state on the held-out points the fair comparison judges on (docs/robustness.md,
"Sensitivity to the initial state"; issue AE).

Each design of ``fair.configurations`` runs at the first ``N_POINTS`` points of each held-out set of the draw
``DRAW`` as drawn (``fair.evaluation_points``) and with the point's initial state changed by each size of the
ladder in its first direction (``COPIES``, applied as ``comparison.initial_state`` applies a perturbation:
relative for the angles, in rad/s for the velocities); each run records MSE_1 + MSE_2 (``fair.run_point``).
``orchestration.reports.heldout_tables`` stores the runs and prints what they show.
"""
from __future__ import annotations

from concurrent.futures import ProcessPoolExecutor
from typing import Any

from orchestration.progress import Progress
from orchestration.study import fair
from orchestration.study.comparison import LADDER_DIRECTIONS, LADDER_SIZES, NOMINAL, PERTURBATIONS, initial_state

N_POINTS = 32  # per set: 64 points x 7 runs x 30 designs, 13 CPU minutes with the compiled cores
DRAW = fair.DRAWS[0]
# the perturbations of each point: every size of the ladder in its first direction
COPIES = tuple(PERTURBATIONS[k * LADDER_DIRECTIONS] for k in range(len(LADDER_SIZES)))


def points() -> dict[str, list[dict[str, Any]]]:
    """The held-out points of each set that are run."""
    return {which: fair.evaluation_points(which, DRAW)[:N_POINTS] for which in fair.SETS}


def perturbed(point: dict[str, Any], perturbation: tuple[float, ...]) -> dict[str, Any]:
    """``point`` with its initial state changed by ``perturbation``."""
    return {**point, **initial_state(perturbation, point["phi0"])}


def point_runs(fmu: str, params: dict[str, float], point: dict[str, Any]) -> list[float | None]:
    """MSE_1 + MSE_2 of the run at ``point`` as drawn and under each of ``COPIES`` (None for a failed run)."""
    return [fair.run_point(fmu, params, perturbed(point, p))["mse"] for p in (NOMINAL, *COPIES)]


def _job(job: tuple) -> tuple:
    label, which, i, fmu, params, point = job
    return label, which, i, point_runs(fmu, params, point)


def compute(handling: int, workers: int = 2) -> dict[str, Any]:
    """label -> {"fmu", "params" (sorted pairs), "mse": set -> one ``point_runs`` per point} of every design of
    ``fair.configurations(handling)``, on ``workers`` processes (progress on stdout)."""
    drawn = points()
    out: dict[str, Any] = {}
    jobs = []
    for label, (fmu, params) in fair.configurations(handling).items():
        out[label] = {"fmu": fmu, "params": sorted([k, v] for k, v in params.items()),
                      "mse": {which: [None] * len(ps) for which, ps in drawn.items()}}
        jobs += [(label, which, i, fmu, params, p) for which, ps in drawn.items() for i, p in enumerate(ps)]
    progress = Progress(len(jobs), "held-out points", workers)
    with ProcessPoolExecutor(max_workers=workers) as pool:
        for label, which, i, runs in pool.map(_job, jobs, chunksize=8):
            out[label]["mse"][which][i] = runs
            progress.update(None not in runs)
    progress.close()
    return out
