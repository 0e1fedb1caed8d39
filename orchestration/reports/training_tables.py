"""The generated block of ``docs/baselines.md`` on the training set's size (issue 52): the SOTC and CT tuned
on the larger training set (``orchestration.study.training_size``) beside the shipped designs of the same
seed, judged on the same held-out draws (``orchestration.study.fair``), and whether the larger set is
adopted by the rule stated beforehand: a verdict of the SOTC against CT on any draw that changes, or a
held-out ratio SOTC / CT that leaves the shipped designs' interval."""
from __future__ import annotations

from pathlib import Path

from fmu_controller.catalog import LABELS
from orchestration.markdown import number, table
from orchestration.study import fair, training_size
from orchestration.study.statistics import geometric_interval, level, paired

SOTC, CT = training_size.CONTROLLERS


def _larger(data: dict, fmu: str, seed: int, which: str, draw: int) -> list:
    return [m["mse"] for m in data["runs"][f"{fmu} {seed}"][str(draw)][which]]


def _shipped(evaluation: dict, handling: str, fmu: str, seed: int, which: str, draw: int) -> list:
    return fair.measure(evaluation, handling, fair.tuned_label(fmu, seed), which, "mse", draw)


def _cell(i) -> str:
    return f"{number(i.value, '.3g')} [{number(i.low, '.3g')}, {number(i.high, '.3g')}]"


def comparison(root: Path) -> str:
    """Per seed, set and draw: SOTC / CT on the held-out MSE with the designs tuned on each training set, the
    verdicts, and the decision."""
    data, evaluation = training_size.stored(root), fair.stored(root)
    handling, draws = data["handling"], evaluation["draws"]
    seeds = sorted({int(k.split()[1]) for k in data["records"]})
    m = 2 * len(seeds) * len(fair.SETS)  # on each draw, the two training sets' verdicts, stated together
    rows, moved = [], []
    for seed in seeds:
        for which in fair.SETS:
            for d in draws:
                small = paired(_shipped(evaluation, handling, SOTC, seed, which, d),
                               _shipped(evaluation, handling, CT, seed, which, d), m)
                large = paired(_larger(data, SOTC, seed, which, d), _larger(data, CT, seed, which, d), m)
                outside = not small.ratio.low <= large.ratio.value <= small.ratio.high
                if large.verdict != small.verdict or outside:
                    moved.append(f"seed {seed}, {which}, draw {d}")
                rows.append([seed, which, d, f"{_cell(small.ratio)}: {small.said}", f"{_cell(large.ratio)}: {large.said}",
                             "yes" if outside else "no"])
    designs = [[LABELS[fmu.split()[0]], fmu.split()[1], ", ".join(f"{k} {v:.4g}" for k, v in r["best_design"].items()),
                number(r["criterion_best"], ".4g"), r["trials"], f"{r['trial_seconds'] / 60:.0f} min"]
               for fmu, r in data["records"].items()]
    pooled = [[LABELS[fmu], which, _cell(geometric_interval([v for d in draws for v in _larger(data, fmu, s, which, d)])),
               _cell(geometric_interval(fair.measure(evaluation, handling, fair.tuned_label(fmu, s), which, "mse")))]
              for fmu in training_size.CONTROLLERS for s in seeds for which in fair.SETS]
    same = []  # each controller's larger-set design against its shipped design, on the same points
    for fmu in training_size.CONTROLLERS:
        for seed in seeds:
            for which in fair.SETS:
                per = [paired(_larger(data, fmu, seed, which, d), _shipped(evaluation, handling, fmu, seed, which, d),
                              len(training_size.CONTROLLERS) * len(seeds) * len(fair.SETS)) for d in draws]
                same.append([LABELS[fmu], seed, which, *(f"{_cell(v.ratio)}: {v.said}" for v in per)])
    decision = (f"**Adopted**: {'; '.join(moved)} moved beyond the shipped designs' verdict or interval." if moved else
                "**Not adopted**: on every draw and set the verdict of the SOTC against CT is the same with both training "
                "sets, and every ratio of the larger set's designs lies inside the shipped designs' interval.")
    return "\n".join([
        f"Tuned on {data['training_points']} training points (the shipped {data['shipped_training_points']} among them) "
        f"by the shipped protocol ({data['budget']} TPE then {data['polish']} CMA-ES trials, under {handling}):", "",
        table(["controller", "seed", "tuned design", "criterion (its training set)", "trials", "trial time"], designs), "",
        "Held-out MSE, every draw's points together (geometric mean [95 %]):", "",
        table(["controller", "set", f"tuned on {data['training_points']} points",
               f"tuned on {data['shipped_training_points']} points (shipped)"], pooled), "",
        f"SOTC / CT on each draw, the same seed's designs, paired on the same points; on each draw {m} verdicts "
        f"stated together, each interval at {100 * level(m):.5g} %:", "",
        table(["seed", "set", "draw", f"tuned on {data['shipped_training_points']} points (shipped)",
               f"tuned on {data['training_points']} points", "ratio outside the shipped interval"], rows), "",
        "The larger set's design against the shipped one of the same controller and seed, paired on the same "
        f"points (A: tuned on {data['training_points']}, B: tuned on {data['shipped_training_points']}; on each draw "
        f"{len(same)} verdicts stated together). One tuning seed: a difference here may be the seed's as much as the "
        "training set's.", "",
        table(["controller", "seed", "set", *(f"draw {d}: A / B" for d in draws)], same), "",
        decision])
