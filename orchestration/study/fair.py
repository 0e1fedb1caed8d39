"""The fair comparison: every controller, nominal and tuned, judged on points its tuning never saw.

The tuning (``orchestration.study.tuning``) used one run: the nominal `paper` loop. Here each
controller runs, at its nominal design and at its tuned design under each limit handling (the SOTC
also with its critic's learning off, alpha1 = alpha2 = 1e-9, at both designs), on two sets of
``N_POINTS`` seeded points (``evaluation_points``):

* ``initial states``: the paper's plant, initial angles drawn uniformly over the workspace
  (phi1 in [-pi, pi], phi2 in [-2.5, 2.5] rad), at rest;
* ``perturbed``: fresh initial angles, and the plant's five model parameters each off by a uniform
  factor in [0.8, 1.2] (the controllers keep the nominal model), step disturbances in [-0.5, 0.5] N.m
  and sinusoidal ones up to 0.5 N.m on both joints, measurement noise std_phi log-uniform in
  [1e-4, 1e-3] rad (std_dphi ten times that) with its own seed per point.

Each run lasts ``EVAL_STOP_TIME`` in the pure loop (the FMU run sample for sample:
tests/fmu/test_pure_loop_perturbed.py). Measures, stated before the runs: Table 1's MSE_1 + MSE_2
(eq. (50)) over the run, and the post-transient error max_i max |e_i| over its last half. The
statistics are ``orchestration.study.statistics``.

``python -m orchestration.study.fair`` runs everything and stores ``docs/fair/evaluation.json`` with
one box plot per set and measure; the tables in docs/ and README are generated from the stored file
(``orchestration.reports.fair_tables``), and a slow test re-runs a sample of it.
"""
from __future__ import annotations

import argparse
import json
import math
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

from fmu_controller.catalog import CORES, LABELS
from fmu_controller.saturation import LIMIT_HANDLINGS
from fmu_plant.dynamics import ArmParameters, IntegrationError
from orchestration.outputs import atomic_write
from orchestration.run.metrics import tracking_metrics
from orchestration.study.pure_loop import Perturbation, simulate
from orchestration.study.sotc_study import NO_LEARNING
from orchestration.study.tuning import CONTROLLERS, HANDLINGS, nominal_parameters, tuned_parameters

N_POINTS = 16
EVAL_SEED = 7
EVAL_STOP_TIME = 20.0
SETS = ("initial states", "perturbed")
MEASURES = {"mse": "MSE_1 + MSE_2 over the run [rad^2]", "tail": "max |e| over the last half [rad]"}
STORE = Path("docs") / "fair" / "evaluation.json"
NOMINAL_ARM = ArmParameters()


def evaluation_points(which: str) -> list[dict[str, Any]]:
    """``N_POINTS`` seeded points of one evaluation set (see the module docstring)."""
    rng = np.random.default_rng([EVAL_SEED, SETS.index(which)])
    points = []
    for i in range(N_POINTS):
        point: dict[str, Any] = {"phi0": [float(rng.uniform(-math.pi, math.pi)), float(rng.uniform(-2.5, 2.5))]}
        if which == "perturbed":
            scale = rng.uniform(0.8, 1.2, 5)
            point["plant"] = {k: float(getattr(NOMINAL_ARM, k) * s) for k, s in zip(("p1", "p2", "p3", "f1", "f2"), scale)}
            std = float(10 ** rng.uniform(-4, -3))
            point["perturbation"] = {"step1": float(rng.uniform(-0.5, 0.5)), "step2": float(rng.uniform(-0.5, 0.5)),
                                     "sin1": float(rng.uniform(0, 0.5)), "sin2": float(rng.uniform(0, 0.5)),
                                     "std_phi": std, "std_dphi": 10 * std, "seed": i + 1}
        points.append(point)
    return points


def configurations(handling: int) -> dict[str, tuple[str, dict[str, float]]]:
    """label -> (controller FMU, parameters) of every configuration compared under one handling."""
    out = {}
    for fmu in CONTROLLERS:
        nominal = {**nominal_parameters(fmu), "limit_handling": float(handling)}
        tuned = {**nominal, **tuned_parameters(fmu, handling)}
        out[f"{LABELS[fmu]} nominal"] = (fmu, nominal)
        out[f"{LABELS[fmu]} tuned"] = (fmu, tuned)
        if fmu == "SotcController":
            out[f"{LABELS[fmu]} nominal, learning off"] = (fmu, {**nominal, **NO_LEARNING})
            out[f"{LABELS[fmu]} tuned, learning off"] = (fmu, {**tuned, **NO_LEARNING})
    return out


def run_point(fmu: str, params: dict[str, float], point: dict[str, Any],
              stop_time: float = EVAL_STOP_TIME) -> dict[str, float | None]:
    """The measures of one run (None for a run that failed)."""
    try:
        res = simulate(CORES[fmu](**params), stop_time=stop_time, phi0=tuple(point["phi0"]),
                       arm=ArmParameters(**point["plant"]) if "plant" in point else None,
                       perturbation=Perturbation(**point.get("perturbation", {})))
    except (IntegrationError, ArithmeticError, ValueError):
        return {"mse": None, "tail": None, "max_tau_norm": None}
    m = tracking_metrics(res.t, res.error, res.tau)
    finite = lambda v: v if v is not None and math.isfinite(v) else None  # noqa: E731
    return {"mse": finite(sum(m["mse"])) if None not in m["mse"] else None,
            "tail": finite(max(m["max_abs_error_last_half"])), "max_tau_norm": finite(m["max_tau_norm"])}


def _job(job: tuple[int, str, str, int]) -> tuple[int, str, str, int, dict]:
    handling, label, which, i = job
    fmu, params = configurations(handling)[label]
    return handling, label, which, i, run_point(fmu, params, evaluation_points(which)[i])


def evaluate(workers: int = 2) -> dict[str, Any]:
    jobs = [(h, label, which, i) for h in HANDLINGS for label in configurations(h) for which in SETS
            for i in range(N_POINTS)]
    with ProcessPoolExecutor(max_workers=workers) as pool:
        done = list(pool.map(_job, jobs, chunksize=8))
    runs: dict[str, Any] = {}
    for h, label, which, i, m in done:
        cell = runs.setdefault(LIMIT_HANDLINGS[h], {}).setdefault(label, {}).setdefault(which, [None] * N_POINTS)
        cell[i] = m
    return {"n_points": N_POINTS, "seed": EVAL_SEED, "stop_time": EVAL_STOP_TIME,
            "points": {which: evaluation_points(which) for which in SETS}, "runs": runs}


def stored(root: Path) -> dict[str, Any]:
    return json.loads((root / STORE).read_text())


def measure(data: dict[str, Any], handling: str, label: str, which: str, name: str) -> list[float | None]:
    return [m[name] for m in data["runs"][handling][label][which]]


def plot(data: dict[str, Any], root: Path) -> list[Path]:
    """One box plot per evaluation set and measure: every configuration, per handling."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    paths = []
    for which in SETS:
        for name, title in MEASURES.items():
            fig, axes = plt.subplots(1, len(HANDLINGS), figsize=(15, 5), sharey=True)
            for ax, h in zip(axes, HANDLINGS):
                labels = list(data["runs"][LIMIT_HANDLINGS[h]])
                values = [[v for v in measure(data, LIMIT_HANDLINGS[h], lab, which, name) if v] for lab in labels]
                ax.boxplot(values, orientation="horizontal", tick_labels=labels)
                ax.set_xscale("log")
                ax.set_title(f"{LIMIT_HANDLINGS[h]}")
                ax.set_xlabel(title)
            fig.suptitle(f"{which}: {N_POINTS} seeded points, {EVAL_STOP_TIME:g} s each")
            fig.tight_layout()
            path = root / STORE.parent / f"{which.replace(' ', '_')}-{name}.png"
            tmp = path.with_name(f".{path.name}.part.png")
            fig.savefig(tmp, dpi=80)
            plt.close(fig)
            tmp.replace(path)
            paths.append(path)
    return paths


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--root", type=Path, default=Path(__file__).resolve().parents[2], help="the source checkout")
    ap.add_argument("--plots-only", action="store_true", help="redraw the plots from the stored runs")
    args = ap.parse_args(argv)
    if args.plots_only:
        data = stored(args.root)
    else:
        data = evaluate(args.workers)
        (args.root / STORE.parent).mkdir(parents=True, exist_ok=True)
        atomic_write(args.root / STORE, json.dumps(data, indent=1) + "\n")
    for path in [args.root / STORE, *plot(data, args.root)]:
        print(path)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
