"""Where two nearby runs of an SOTC design part, and which decision parted them (docs/robustness.md,
"Sensitivity to the initial state"; issue AE).

A pair is a design's 100 s run from section 4's initial state and its run under one perturbation of the
ladder (``comparison.PERTURBATIONS``). Both run in the pure loop with a ``DecisionLog`` in place of the CL
stack: it keeps every decision on a sample offered to the full stack (the row it replaces, or -1) with the
time of the offer. The runs part at the first sample where their angles differ by more than ``APART``; what
decided it is the first offer the two runs decide differently, if that comes first, with its margin in each
run: the smallest shift of every threshold of the swap rule (the gain, the rank's margin and the tie window,
moved together as ``swap_margin`` moves them), relative to trace(M), that changes that run's decision.
Otherwise the first of the other decisions whose flags differ (the bound (5), the actuator limit, the tuning
law (30)/(31)) is named, without a margin. ``orchestration.reports.parting_tables`` picks the pairs and
stores them.
"""
from __future__ import annotations

from typing import Any

import numpy as np

from fmu_controller.sotc import SotcCore
from fmu_controller.sotc_math import N_BASIS
from fmu_controller.sotc_stack import CLStack
from fmu_numerics.fixed_linalg import trace
from orchestration.study.comparison import PERTURBATIONS, initial_state
from orchestration.study.pure_loop import simulate

STOP_TIME = 100.0  # s
APART = 1e-3  # rad: two runs whose angles differ by more have visibly parted
SHIFTS = tuple(10.0 ** -k for k in range(16, 1, -1))  # the shifts tried, relative to trace(M): 1e-16 .. 1e-2
FLAGS = ("tuning_law", "tau_a_bounded", "chi_a_bounded", "tau_limited")  # the other decisions, as outputs


class DecisionLog(CLStack):
    """A ``CLStack`` that logs every swap decision (time, row or -1) and, at the offer numbered ``probe``, the
    smallest threshold shift that changes it (``probed``; None when no shift in ``SHIFTS`` does)."""

    def __init__(self, stack: CLStack, probe: int = -1):
        super().__init__(stack.P, stack.selection, stack.replay_form, stack.constants)
        self.now = 0.0
        self.decisions: list[tuple[float, int]] = []
        self.probe = probe
        self.probed: float | None = None

    def _swap_row(self, eta, spectrum, shift: float = 0.0) -> int:
        row = super()._swap_row(eta, spectrum, shift)
        if len(self.decisions) == self.probe:
            self.probed = self._margin(eta, row)
        self.decisions.append((self.now, row))
        return row

    def _margin(self, eta, row: int) -> float | None:
        scale = trace(self.M, N_BASIS)
        for rel in SHIFTS:
            for d in (rel * scale, -rel * scale):
                if super()._swap_row(eta, self.spectrum(d), d) != row:
                    return rel
        return None


class _Clocked:
    """A controller core whose stack's log knows the time of each offer (``advance`` offers)."""

    def __init__(self, core: SotcCore, log: DecisionLog):
        self.core, self.log = core, log

    def output_names(self):
        return self.core.output_names()

    @property
    def outputs(self):
        return self.core.outputs

    def evaluate(self, t, y, r) -> None:
        self.core.evaluate(t, y, r)

    def advance(self, t: float, dt: float) -> None:
        self.log.now = t
        self.core.advance(t, dt)


def logged_run(params: dict[str, float], perturbation: tuple[float, ...], probe: int = -1):
    """The run of an SOTC design from section 4's initial state changed by ``perturbation``, and its log."""
    core = SotcCore(**params)
    core.stack = log = DecisionLog(core.stack, probe)
    return simulate(_Clocked(core, log), stop_time=STOP_TIME, **initial_state(perturbation)), log


def _first_flag(a, b, before: int) -> tuple[str, float] | None:
    """The first of ``FLAGS`` whose value differs between runs a and b before sample ``before``."""
    found = []
    for name in FLAGS:
        diff = np.nonzero(a.out(name)[:before] != b.out(name)[:before])[0]
        if len(diff):
            found.append((int(diff[0]), name))
    return (min(found)[1], float(a.t[min(found)[0]])) if found else None


def parting(params: dict[str, float], index: int) -> dict[str, Any]:
    """Where the design's nominal run and its run under ``PERTURBATIONS[index]`` part, and what decided it."""
    a, log_a = logged_run(params, (0.0,) * 4)
    b, log_b = logged_run(params, PERTURBATIONS[index])
    apart = np.nonzero(np.abs(a.y[:, :2] - b.y[:, :2]).max(axis=1) > APART)[0]
    end = int(apart[0]) if len(apart) else len(a.t)
    out: dict[str, Any] = {"perturbation": index, "apart_t": float(a.t[end]) if len(apart) else None}
    first = next((i for i, (x, y) in enumerate(zip(log_a.decisions, log_b.decisions)) if x != y), None)
    if first is not None and (out["apart_t"] is None or log_a.decisions[first][0] <= out["apart_t"]):
        margins = [logged_run(params, p, first)[1].probed for p in ((0.0,) * 4, PERTURBATIONS[index])]
        out["decided_by"] = {"what": "CL stack swap", "t": log_a.decisions[first][0],
                             "rows": [log_a.decisions[first][1], log_b.decisions[first][1]], "margins": margins}
    else:
        flag = _first_flag(a, b, end)
        out["decided_by"] = None if flag is None else {"what": flag[0], "t": flag[1]}
    return out

