"""The best-so-far curves of the stored tuning search (docs/fair/best-so-far.png): one panel per
controller and limit handling, one curve per tuning seed, the criterion relative to the search's final
best, so a panel shows at a glance whether the last half of the budget still improved it.

    python -m orchestration.reports.tuning_plots    # redraw from orchestration/study/tuned.json
"""
from __future__ import annotations

import argparse
from pathlib import Path

from fmu_controller.catalog import LABELS
from fmu_controller.saturation import LIMIT_HANDLINGS
from orchestration.outputs import save_figure
from orchestration.study.tuning import CONTROLLERS, CONVERGED, HANDLINGS, best_so_far, stored

PLOT = Path("docs") / "fair" / "best-so-far.png"


def plot(root: Path) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    data = stored()
    fig, axes = plt.subplots(len(CONTROLLERS), len(HANDLINGS), figsize=(13, 11), sharex=True)
    for row, fmu in zip(axes, CONTROLLERS):
        for ax, h in zip(row, HANDLINGS):
            seeds = data["controllers"][fmu]["handlings"][LIMIT_HANDLINGS[h]]["seeds"]
            for seed, r in seeds.items():
                curve = best_so_far(r["criterion"])
                ax.plot(range(1, len(curve) + 1), [c / curve[-1] for c in curve], label=f"seed {seed}")
            ax.axvline(data["budget"] / 2, color="grey", lw=0.8, ls=":")
            if data.get("polish"):
                ax.axvline(data["budget"] + 0.5, color="black", lw=0.8, ls=":")  # trials are numbered from 1
            ax.axhline(1 + CONVERGED, color="grey", lw=0.8, ls="--")
            ax.set_ylim(0.98, 1.3)
            ax.set_title(f"{LABELS[fmu]}, {LIMIT_HANDLINGS[h]}", fontsize=10)
    for ax in axes[-1]:
        ax.set_xlabel("trial")
    for row in axes:
        row[0].set_ylabel("best so far / final best")
    axes[0][0].legend(fontsize=8)
    phases = (f"{data['budget']} TPE + {data['polish']} CMA-ES trials per search (grey dotted: half the TPE phase; "
              "black dotted: CMA-ES starts" if data.get("polish") else
              f"{data['budget']} trials per search (dotted: half the budget")
    fig.suptitle(f"Best-so-far criterion, {phases};\ndashed: {100 * CONVERGED:g} % above the final best)")
    fig.tight_layout()
    (root / PLOT).parent.mkdir(parents=True, exist_ok=True)
    return save_figure(fig, root / PLOT, 70)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--root", type=Path, default=Path(__file__).resolve().parents[2], help="the source checkout")
    print(plot(ap.parse_args(argv).root))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
