"""The benchmark's plots, from its store: the criterion's best-so-far against the trial per seed
(``criterion.png``), and the held-out error of each seed beside our tuned SOTC's on the same points
(``heldout.png``)."""
from __future__ import annotations

import math
from pathlib import Path

from fmu_controller.catalog import LABELS
from orchestration.outputs import save_figure
from orchestration.reports.benchmark_report import _ours
from orchestration.study import fair
from orchestration.study.benchmark_reference import load as reference
from orchestration.study.tuning import CONVERGED, best_so_far

SOTC = LABELS["SotcController"]


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def criterion_plot(store: dict, path: Path) -> Path:
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(8, 4.5))
    curves = 0
    for seed, per in store["seeds_results"].items():
        curve = [c if math.isfinite(c) else math.nan for c in best_so_far(per["search"]["criterion"])]
        if math.isnan(curve[-1]):  # none of its trials ran to the end: no curve
            ax.plot([], [], label=f"seed {seed}: no trial ran to the end")
            continue
        ax.plot(range(1, len(curve) + 1), curve, label=f"seed {seed}")
        curves += 1
    ax.axvline(store["budget"] + 0.5, color="black", lw=0.8, ls=":")  # trials are numbered from 1
    if curves:
        ax.set_yscale("log")
    ax.set_xlabel("trial")
    ax.set_ylabel("best so far: geometric mean of MSE_1 + MSE_2 [rad^2]")
    ax.legend(fontsize=8)
    ax.set_title(f"{store['budget']} TPE + {store['polish']} CMA-ES trials (dotted: CMA-ES starts); converged: the CMA-ES "
                 f"phase's last half moved the best by < {100 * CONVERGED:g} %", fontsize=8)
    fig.tight_layout()
    return save_figure(fig, path, 80)


def heldout_plot(store: dict, path: Path) -> Path:
    ref = reference()
    plt = _pyplot()
    fig, axes = plt.subplots(1, len(fair.SETS), figsize=(12, 4.5), sharey=True)
    for ax, which in zip(axes, fair.SETS):
        labels, values = [], []
        for seed, per in store["seeds_results"].items():
            labels.append(f"this controller, seed {seed}")
            values.append([v for v in per["heldout"][which]["mse"] if v])
            if seed in ref["runs"][SOTC]:
                labels.append(f"{SOTC} tuned, seed {seed}")
                values.append([v for v in _ours(ref, SOTC, seed, which, "mse", None, store["points"]) if v])
        ax.boxplot(values, orientation="horizontal", tick_labels=labels)
        ax.set_xscale("log")
        ax.set_xlabel(fair.MEASURES["mse"])
        ax.set_title(f"{which}: {len(store['draws'])} draws of {store['points']} held-out points")
    fig.tight_layout()
    return save_figure(fig, path, 80)
