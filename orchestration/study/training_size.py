"""Whether the training set is large enough (issue 52, ``docs/baselines.md``, "A larger training set").

The shipped designs were tuned on ``tuning.TRAINING_POINTS`` (8 points of 20 s). Here the SOTC and the
computed-torque controller are tuned again by the same protocol (``protocol.BUDGET`` TPE trials, then
``protocol.POLISH`` of CMA-ES, the shipped tuning seed ``SEEDS``, the verdict's handling) on ``LARGER``
training points (drawn as the shipped ones: the same generator seed, so the shipped 8 are among them),
and each design is judged on every held-out draw of ``orchestration.study.fair``, as the shipped designs
are there. The generated block of ``docs/baselines.md`` (``orchestration.reports.training_tables``) sets
the two side by side.

``python -m orchestration.study.training_size [--workers N] [--journal PATH]`` runs the searches (resumable:
an Optuna journal, by default under ``build/``) and stores ``STORE``.
"""
from __future__ import annotations

import argparse
import contextlib
import json
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

from fmu_controller.saturation import LIMIT_HANDLINGS
from orchestration.outputs import atomic_write
from orchestration.study import fair, tuning
from orchestration.study.protocol import BUDGET, POLISH

LARGER = {"initial states": 16, "perturbed": 16}
CONTROLLERS = ("SotcController", "CtController")
SEEDS = (0,)
HANDLING = LIMIT_HANDLINGS.index("accel")
STORE = Path("docs") / "fair" / "training-size.json"


@contextlib.contextmanager
def larger_training_set():
    """``tuning.training_points`` gives ``LARGER`` points inside (this process only)."""
    shipped = dict(tuning.TRAINING_POINTS)
    tuning.TRAINING_POINTS.update(LARGER)
    try:
        yield
    finally:
        tuning.TRAINING_POINTS.clear()
        tuning.TRAINING_POINTS.update(shipped)


def _search(job: tuple[str, int, str]) -> tuple[str, int, dict[str, Any]]:
    from orchestration.study import optimize, polish

    fmu, seed, journal = job
    with larger_training_set():
        problem = tuning.Ours(fmu, HANDLING)
        polish.search(Path(journal), problem, seed, BUDGET, POLISH)
        return fmu, seed, polish.record(optimize.storage(Path(journal)), problem, seed, BUDGET, POLISH)


def _held_out(job: tuple[str, int, dict[str, float], int, str, int]) -> tuple[str, int, int, str, int, dict]:
    fmu, seed, params, draw, which, i = job
    return fmu, seed, draw, which, i, fair.run_point(fmu, params, fair.evaluation_points(which, draw)[i])


def design_parameters(fmu: str, design: dict[str, float]) -> dict[str, float]:
    """The FMU parameters of a design tuned here (the nominal scenario's others kept, ``fair.configurations``)."""
    return tuning.parameters(fmu, design, HANDLING)


def run(workers: int, journal: Path) -> dict[str, Any]:
    """Every search, then every held-out run of its best design."""
    jobs = [(fmu, seed, str(journal)) for fmu in CONTROLLERS for seed in SEEDS]
    with ProcessPoolExecutor(max_workers=workers) as pool:
        records = {(fmu, seed): r for fmu, seed, r in pool.map(_search, jobs)}
        runs = {f"{fmu} {seed}": {str(d): {which: [None] * fair.N_POINTS for which in fair.SETS} for d in fair.DRAWS}
                for fmu, seed in records}
        held = [(fmu, seed, design_parameters(fmu, records[fmu, seed]["best_design"]), d, which, i)
                for fmu, seed in records for d in fair.DRAWS for which in fair.SETS for i in range(fair.N_POINTS)]
        for fmu, seed, draw, which, i, m in pool.map(_held_out, held, chunksize=16):
            runs[f"{fmu} {seed}"][str(draw)][which][i] = m
    with larger_training_set():
        points = len(tuning.training_points())
    return {"training_points": points, "shipped_training_points": len(tuning.training_points()),
            "budget": BUDGET, "polish": POLISH, "handling": LIMIT_HANDLINGS[HANDLING],
            "records": {f"{fmu} {seed}": {"best_design": r["best_design"], "criterion_best": r["criterion"][r["best"]],
                                          "trials": r["trials"], "trial_seconds": r["trial_seconds"]}
                        for (fmu, seed), r in records.items()},
            "runs": runs}


def stored(root: Path) -> dict[str, Any]:
    return json.loads((root / STORE).read_text())


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--root", type=Path, default=Path(__file__).resolve().parents[2], help="the source checkout")
    ap.add_argument("--journal", type=Path, default=None, help="the searches' Optuna journal (resumable)")
    args = ap.parse_args(argv)
    journal = args.journal or args.root / "build" / "training-size.journal"
    journal.parent.mkdir(parents=True, exist_ok=True)
    data = run(args.workers, journal)
    atomic_write(args.root / STORE, json.dumps(data, indent=1) + "\n")
    print(args.root / STORE)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
