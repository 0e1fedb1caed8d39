"""The ladder on the held-out points (``orchestration.study.heldout_ladder``) under the verdict's handling,
stored in ``STORE`` and printed in docs/robustness.md: how far each design's held-out MSE moves when the
initial state of each point moves far below any measurement.

    python -m orchestration.reports.heldout_tables     # every design of the fair comparison (13 CPU minutes compiled)
"""
from __future__ import annotations

import argparse
import json
import math
import statistics
from pathlib import Path
from typing import Any

from fmu_controller.saturation import LIMIT_HANDLINGS
from orchestration.markdown import number, table
from orchestration.outputs import atomic_write
from orchestration.reports.fair_tables import BASELINES, SOTC, VERDICT_HANDLING
from orchestration.reports.ladder_tables import JUMP
from orchestration.study import heldout_ladder
from orchestration.study.comparison import LADDER_SIZES
from orchestration.study.fair import EVAL_STOP_TIME, tuned_label
from orchestration.study.tuning import stored as stored_tuning

STORE = "docs/heldout-ladder.json"


def write(root: Path, workers: int = 2) -> int:
    """Run every design at every point of ``heldout_ladder`` and store the runs in ``root/STORE``; returns the
    number of runs."""
    designs = heldout_ladder.compute(LIMIT_HANDLINGS.index(VERDICT_HANDLING), workers)
    data = {"handling": VERDICT_HANDLING, "draw": heldout_ladder.DRAW, "n_points": heldout_ladder.N_POINTS,
            "stop_time": EVAL_STOP_TIME, "copies": [list(p) for p in heldout_ladder.COPIES], "designs": designs}
    atomic_write(root / STORE, json.dumps(data, indent=1, sort_keys=True) + "\n")
    return sum(len(runs) for d in designs.values() for point in d["mse"].values() for runs in point)


def stored(root: Path) -> dict[str, Any]:
    return json.loads((root / STORE).read_text())


def _points(design: dict[str, Any]) -> list[list[float | None]]:
    """Every point's runs (as drawn, then each copy), the sets one after the other."""
    return [runs for which in sorted(design["mse"]) for runs in design["mse"][which]]


def _mean(values: list[float | None]) -> float | None:
    return None if None in values else math.fsum(values) / len(values)


def copy_means(design: dict[str, Any]) -> list[float | None]:
    """The mean MSE over the points of the runs as drawn, then of each perturbed copy (None if one failed)."""
    runs = _points(design)
    return [_mean([r[k] for r in runs]) for k in range(len(runs[0]))]


def spreads(design: dict[str, Any]) -> list[float]:
    """Per point whose runs all finished: (largest - smallest MSE over its runs) / the MSE as drawn."""
    return [(max(r) - min(r)) / r[0] for r in _points(design) if None not in r]


def moving(design: dict[str, Any]) -> int:
    """The points whose MSE moves by more than ``JUMP`` (relative) under some copy."""
    return sum(max(abs(v - r[0]) for v in r[1:]) > JUMP * r[0] for r in _points(design) if None not in r)


def differences(a: dict[str, Any], b: dict[str, Any]) -> list[float | None]:
    """The mean paired difference of design a's MSE less b's over the same points, as drawn and under each copy."""
    pairs = list(zip(_points(a), _points(b)))
    return [_mean([None if x[k] is None or y[k] is None else x[k] - y[k] for x, y in pairs])
            for k in range(len(pairs[0][0]))]


def best_baseline(designs: dict[str, Any], seeds: list[int]) -> str:
    """The tuned baseline design with the lowest mean MSE as drawn."""
    def as_drawn(label: str) -> float:
        mean = copy_means(designs[label])[0]
        return math.inf if mean is None else mean

    return min((tuned_label(f, s) for f in BASELINES for s in seeds), key=as_drawn)


def flips(d: list[float | None]) -> int | None:
    """Under how many copies a difference (as drawn first, ``differences``) has the other sign (None: a run failed)."""
    return None if None in d else sum((v > 0) != (d[0] > 0) for v in d[1:])


def _sign_cell(d: list[float | None]) -> str:
    n = flips(d)
    if n is None:
        return "-"
    kept = "keeps its sign" if not n else f"**sign flips under {n} of {len(d) - 1}**"
    return f"{number(d[0], '.3g')} ({number(min(d[1:]), '.3g')} to {number(max(d[1:]), '.3g')}), {kept}"


def _percent(v: float) -> str:
    return f"{number(100 * v, '.2g' if v < 1 else '.0f')} %"


def _row(label: str, design: dict[str, Any], against: dict[str, Any] | None) -> list[str]:
    """A design's cells; ``against``: the design its difference is taken to (None: no difference)."""
    means, spread = copy_means(design), spreads(design)
    move = None if None in means else max(abs(m - means[0]) for m in means[1:]) / means[0]
    copies = "-" if move is None else f"{number(min(means[1:]))}–{number(max(means[1:]))}"
    return [label, number(means[0]), copies, "-" if move is None else _percent(move),
            _percent(statistics.median(spread)), _percent(max(spread)), f"{moving(design)} of {len(spread)}",
            "" if against is None else _sign_cell(differences(design, against))]


def table_of(data: dict[str, Any], seeds: list[int]) -> str:
    """One row per stored design: its mean held-out MSE as drawn and over the copies, the spread per point, the
    points that move, and for a tuned SOTC design its difference to the best tuned baseline under every copy."""
    designs = data["designs"]
    best = best_baseline(designs, seeds)
    tuned_sotc = [tuned_label(SOTC, s) for s in seeds]
    rows = [_row(label, d, designs[best] if label in tuned_sotc else None) for label, d in designs.items()]
    n = 2 * data["n_points"]
    copies = len(data["copies"])
    caption = (f"MSE_1 + MSE_2 of the {data['stop_time']:g} s runs under {data['handling']} at the first "
               f"{data['n_points']} points of each held-out set of draw {data['draw']} ({n} points), each as drawn and "
               f"with its initial state changed by each size of the ladder ({LADDER_SIZES[0]:g} to {LADDER_SIZES[-1]:g}) "
               f"in its first seeded direction ({copies} copies). Mean: over the {n} points as drawn; over the copies: "
               f"the smallest and largest mean of a copy, and its largest move from the mean as drawn. Per point: "
               f"(largest - smallest MSE over its {copies + 1} runs) / its MSE as drawn, the median and the largest over "
               f"the points; the points whose MSE moves by more than {100 * JUMP:g} % under some copy. Against {best} "
               f"(the tuned baseline with the lowest mean as drawn): the tuned SOTC's mean paired difference of the MSE "
               f"as drawn (the range over the copies), and whether every copy gives it the same sign.")
    header = ["design", "mean MSE", "mean over the copies", "largest move of the mean", "per point: median spread",
              "largest spread", f"points moving > {100 * JUMP:g} %", f"SOTC - {best}"]
    kept = sum(flips(differences(designs[label], designs[best])) == 0 for label in tuned_sotc)
    return (caption + "\n\n" + table(header, rows) + f"\n\nThe tuned SOTC's mean paired difference to {best} keeps "
            f"its sign under every copy for {kept} of its {len(seeds)} tuning seeds.")


def block(root: Path) -> str:
    """The generated block of docs/robustness.md."""
    return table_of(stored(root), stored_tuning()["seeds"])


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m orchestration.reports.heldout_tables", description=__doc__.splitlines()[0])
    ap.add_argument("--workers", type=int, default=2)
    args = ap.parse_args(argv)
    root = Path(__file__).resolve().parents[2]
    print(f"{STORE}: {write(root, args.workers)} runs")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
