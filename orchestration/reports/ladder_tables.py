"""The ladder of perturbations of the initial state (``comparison.PERTURBATIONS``) for every design the fair
comparison judges (``fair.configurations``: each controller nominal and tuned by each seed, the SOTC also with
learning off, under every handling of the bound): how far MSE_1 + MSE_2 of its 100 s run from section 4's
initial state moves at each size of the ladder (docs/robustness.md, "Sensitivity to the initial state").

The figures are the stored runs of ``perturbed`` (90 designs: their nominal runs are not computed again to
render the table; tests/docs/test_perturbed_store.py recomputes a sample). A design whose metric moves by more
than ``JUMP`` at some size "jumps": a fourth printed digit would not
hold. A closed loop that depends smoothly on its initial state moves in proportion to the size (the ratio of
the move to the size is its gain); one with a decision in it that a change turns does not.
"""
from __future__ import annotations

from typing import Any

from fmu_controller.catalog import LABELS
from fmu_controller.saturation import LIMIT_HANDLINGS
from orchestration.markdown import number, table
from orchestration.reports import perturbed
from orchestration.study import fair
from orchestration.study.comparison import LADDER_DIRECTIONS, LADDER_SIZES, mse_sum
from orchestration.study.parting import STOP_TIME
from orchestration.study.tuning import CONTROLLERS, HANDLINGS
from orchestration.study.tuning import stored as stored_tuning

JUMP = 1e-3  # a relative move above 0.1 % changes the fourth significant digit of the metric
# a smooth response moves the metric by at most a few tens of times the size here (every baseline's nominal
# design, every design with learning off); a decision a perturbation turns moves it by far more
GAIN = 1e3


def relative_moves(nominal: dict[str, Any], others: list[dict[str, Any]]) -> list[float]:
    """How far MSE_1 + MSE_2 of each of ``others`` lies from the nominal run's, relative to it."""
    base = mse_sum(nominal)
    return [abs(mse_sum(o) - base) / base for o in others]


def moves(nominal: dict[str, Any], others: list[dict[str, Any]]) -> list[float]:
    """The largest relative move over the directions of each size of the ladder (``others`` in
    ``PERTURBATIONS``' order: size by size, ``LADDER_DIRECTIONS`` each)."""
    rel = relative_moves(nominal, others)
    return [max(rel[k:k + LADDER_DIRECTIONS]) for k in range(0, len(rel), LADDER_DIRECTIONS)]


def _designs() -> list[tuple[int, str, list[float]]]:
    """(handling, label, moves) of every design of the fair comparison."""
    out = []
    for h in HANDLINGS:
        for label, (fmu, params) in fair.configurations(h).items():
            out.append((h, label, moves(*perturbed.design(fmu, params, STOP_TIME, check=False))))
    return out


def _cell(move: float) -> str:
    text = f"{number(100 * move, '.2g')} %"
    return f"**{text}**" if move > JUMP else text


def ladder_table() -> str:
    """One row per design: the largest move at each size, bold above ``JUMP``, and the largest ratio of move to size."""
    rows = [[LIMIT_HANDLINGS[h], label, *map(_cell, m), number(_gain(m), ".2g")] for h, label, m in _designs()]
    header = ["limit handling", "design", *(f"{s:g}" for s in LADDER_SIZES), "largest move / size"]
    return (f"MSE_1 + MSE_2 of the {STOP_TIME:g} s run from section 4's initial state: its largest relative move over "
            f"{LADDER_DIRECTIONS} seeded directions (angles and velocities) at each size, bold above "
            f"{100 * JUMP:g} %.\n\n" + table(header, rows))


def tuning_table() -> str:
    """Whether the tuning prefers designs that jump: per controller and handling, the nominal design against the
    tuned seeds (and, for the SOTC, the same designs with learning off)."""
    found = {(h, label): m for h, label, m in _designs()}
    seeds = stored_tuning()["seeds"]

    def count(h: int, labels: list[str]) -> str:
        jumps = sum(max(found[h, label]) > JUMP for label in labels)
        steep = sum(_gain(found[h, label]) > GAIN for label in labels)
        return f"{jumps} / {steep} of {len(labels)}"

    rows = []
    for fmu in CONTROLLERS:
        for off in ("", ", learning off") if fmu == "SotcController" else ("",):
            tuned = [fair.tuned_label(fmu, s) + off for s in seeds]
            rows += [[f"{LABELS[fmu]}{off}", LIMIT_HANDLINGS[h], count(h, [f"{LABELS[fmu]} nominal{off}"]), count(h, tuned)]
                     for h in HANDLINGS]
    return (f"Each cell: designs that jump (a move over {100 * JUMP:g} %) / designs whose largest move exceeds "
            f"{GAIN:g} times its size (a decision turned, however small its effect).\n\n"
            + table(["controller", "limit handling", "nominal design", "tuned designs"], rows))


def _gain(m: list[float]) -> float:
    """The largest ratio of a move to the size of its perturbation."""
    return max(v / s for v, s in zip(m, LADDER_SIZES))
