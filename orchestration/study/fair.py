"""The fair comparison: every controller, nominal and tuned, judged on points its tuning never saw.

The tuning (``orchestration.study.tuning``) ran on its training set, one search per seed. Here each
controller runs, at its nominal design and at each tuning seed's best design under each limit
handling (the SOTC also with its critic's learning off, alpha1 = alpha2 = 1e-9, at each of those
designs), on two held-out sets of ``N_POINTS`` seeded points, drawn ``len(DRAWS)`` times independently
(``evaluation_points``, ``orchestration.study.points``: generator seed ``draw``, noise seeds from
``1 + N_POINTS * k`` for the k-th draw; the training set's seeds differ from all of them):

* ``initial states``: the paper's plant, initial angles drawn uniformly over the workspace
  (phi1 in [-pi, pi], phi2 in [-2.5, 2.5] rad), at rest;
* ``perturbed``: fresh initial angles, and the plant's five model parameters each off by a uniform
  factor in [0.8, 1.2] (the controllers keep the nominal model), step disturbances in [-0.5, 0.5] N.m
  and sinusoidal ones up to 0.5 N.m on both joints, measurement noise std_phi log-uniform in
  [1e-4, 1e-3] rad (std_dphi ten times that) with its own seed per point.

Each run lasts ``EVAL_STOP_TIME`` in the pure loop (the FMU run sample for sample:
tests/fmu/test_pure_loop_perturbed.py). Measures, stated before the runs: Table 1's MSE_1 + MSE_2
(eq. (50)) over the run, and the post-transient error max_i max |e_i| over its last half. The
statistics are ``orchestration.study.statistics``; each verdict is taken on each draw apart, and what
the README states is what every draw gives (``orchestration.reports.fair_tables``). Why 3 draws of 128:
with 16 points one README verdict held on 2 of 4 draws (issue 52), with 128 on every one.

``python -m orchestration.study.fair`` runs everything and stores ``docs/fair/evaluation.json`` (with
each configuration's parameters, so ``--reuse`` keeps the runs of those that did not change, and
``--controllers`` evaluates in stages while other searches still run) with one box plot per set and
measure; the tables in docs/ and README are generated from the stored file
(``orchestration.reports.fair_tables``), and a test re-runs a sample of it.
"""
from __future__ import annotations

import argparse
import json
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any


from fmu_controller.catalog import LABELS
from fmu_controller.saturation import LIMIT_HANDLINGS
from orchestration.outputs import atomic_write, save_figure
from orchestration.study import points
from orchestration.study.protocol import HELD_OUT_POINTS
from orchestration.study.sotc_study import NO_LEARNING
from orchestration.study.tuning import CONTROLLERS, HANDLINGS, nominal_parameters, stored as stored_tuning, tuned_parameters

N_POINTS = HELD_OUT_POINTS  # per set and draw
DRAWS = (7, 8, 9)  # generator seeds of the held-out draws (7: the one shipped before issue 52)
EVAL_STOP_TIME = 20.0
SETS = points.KINDS
MEASURES = {"mse": "MSE_1 + MSE_2 over the run [rad^2]", "tail": "max |e| over the last half [rad]"}
STORE = Path("docs") / "fair" / "evaluation.json"


def evaluation_points(which: str, draw: int = DRAWS[0]) -> list[dict[str, Any]]:
    """``N_POINTS`` seeded points of one held-out set in one draw (see the module docstring)."""
    return points.draw_points(draw, which, N_POINTS, 1 + N_POINTS * DRAWS.index(draw))


def tuned_label(fmu: str, seed: int) -> str:
    return f"{LABELS[fmu]} tuned, seed {seed}"


def configurations(handling: int, controllers=CONTROLLERS) -> dict[str, tuple[str, dict[str, float]]]:
    """label -> (controller FMU, parameters) of every configuration compared under one handling: each
    controller nominal and tuned by each seed of the stored search (the SOTC also with learning off)."""
    out = {}
    for fmu in controllers:
        nominal = {**nominal_parameters(fmu), "limit_handling": float(handling)}
        designs = {f"{LABELS[fmu]} nominal": nominal}
        designs |= {tuned_label(fmu, s): {**nominal, **tuned_parameters(fmu, handling, s)} for s in stored_tuning()["seeds"]}
        for label, params in designs.items():
            out[label] = (fmu, params)
            if fmu == "SotcController":
                out[f"{label}, learning off"] = (fmu, {**params, **NO_LEARNING})
    return out


def run_point(fmu: str, params: dict[str, float], point: dict[str, Any]) -> dict[str, float | None]:
    """The measures of one held-out run (None for a run that failed)."""
    return points.run_point(fmu, params, point, EVAL_STOP_TIME)


def _job(job: tuple) -> tuple:
    handling, label, fmu, params, which, i, point = job
    return handling, label, which, i, run_point(fmu, params, point)


def evaluate(workers: int = 2, controllers=CONTROLLERS, previous: dict[str, Any] | None = None) -> dict[str, Any]:
    """Every configuration of ``controllers`` on both held-out sets. The runs of a configuration whose
    parameters equal those it has in ``previous`` (a stored evaluation) are taken from there, and its
    other configurations are kept: an evaluation can go in stages, each controller as soon as its tuning
    searches are finished."""
    same = previous and previous.get("draws") == list(DRAWS) and previous.get("n_points") == N_POINTS
    old = previous if same and "configurations" in previous else {"configurations": {}, "runs": {}}
    runs: dict[str, Any] = {}
    params_of: dict[str, Any] = {}
    drawn = {which: [p for d in DRAWS for p in evaluation_points(which, d)] for which in SETS}
    jobs = []
    for h in HANDLINGS:
        handling = LIMIT_HANDLINGS[h]
        for label, (fmu, params) in configurations(h, controllers).items():
            params_of.setdefault(handling, {})[label] = params
            if old["configurations"].get(handling, {}).get(label) == params:
                runs.setdefault(handling, {})[label] = old["runs"][handling][label]
                continue
            runs.setdefault(handling, {})[label] = {which: {name: [None] * len(drawn[which]) for name in MEASURES}
                                                    for which in SETS}
            jobs += [(handling, label, fmu, params, which, i, p) for which in SETS for i, p in enumerate(drawn[which])]
    with ProcessPoolExecutor(max_workers=workers) as pool:
        for handling, label, which, i, m in pool.map(_job, jobs, chunksize=32):
            for name in MEASURES:
                runs[handling][label][which][name][i] = m[name]
    others = {LABELS[f] for f in CONTROLLERS if f not in controllers}
    for handling, stored_runs in old["runs"].items():  # a stage: the other controllers' runs stay
        for label, cell in stored_runs.items():
            if label.split()[0] in others:
                runs.setdefault(handling, {})[label] = cell
                params_of.setdefault(handling, {})[label] = old["configurations"][handling][label]
    return {"n_points": N_POINTS, "draws": list(DRAWS), "stop_time": EVAL_STOP_TIME, "seeds": stored_tuning()["seeds"],
            "points": {str(d): {which: evaluation_points(which, d) for which in SETS} for d in DRAWS},
            "configurations": params_of, "runs": runs}


def stored(root: Path) -> dict[str, Any]:
    return json.loads((root / STORE).read_text())


def measure(data: dict[str, Any], handling: str, label: str, which: str, name: str,
            draw: int | None = None) -> list[float | None]:
    """One measure of one configuration on one set: over every draw in turn, or on the draw ``draw``."""
    values = data["runs"][handling][label][which][name]
    if draw is None:
        return values
    k, n = data["draws"].index(draw), data["n_points"]
    return values[k * n:(k + 1) * n]


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
            fig.suptitle(f"{which}: {len(DRAWS)} draws of {N_POINTS} seeded points, {EVAL_STOP_TIME:g} s each")
            fig.tight_layout()
            paths.append(save_figure(fig, root / STORE.parent / f"{which.replace(' ', '_')}-{name}.png", 80))
    return paths


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--root", type=Path, default=Path(__file__).resolve().parents[2], help="the source checkout")
    ap.add_argument("--plots-only", action="store_true", help="redraw the plots from the stored runs")
    ap.add_argument("--controllers", nargs="+", choices=CONTROLLERS, default=list(CONTROLLERS),
                    help="evaluate only these (a stage: with --reuse, the stored runs of the others stay)")
    ap.add_argument("--reuse", action="store_true",
                    help="keep the stored runs of every configuration whose parameters did not change")
    args = ap.parse_args(argv)
    if args.plots_only:
        data = stored(args.root)
    else:
        previous = stored(args.root) if args.reuse and (args.root / STORE).is_file() else None
        data = evaluate(args.workers, args.controllers, previous)
        (args.root / STORE.parent).mkdir(parents=True, exist_ok=True)
        atomic_write(args.root / STORE, json.dumps(data, separators=(",", ":")) + "\n")
    for path in [args.root / STORE, *plot(data, args.root)]:
        print(path)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
