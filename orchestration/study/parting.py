"""Where two nearby runs of an SOTC design part, and which decision parted them (docs/robustness.md,
"Sensitivity to the initial state"; issue AE).

A pair is a design's 100 s run from section 4's initial state and its run under one perturbation of the
ladder (``comparison.PERTURBATIONS``). Both run in the pure loop with a ``DecisionLog`` in place of the CL
stack: it keeps every decision on a sample offered to the full stack (the row it replaces, or -1) with the
time of the offer. A smooth closed loop carries the change of the initial state along in proportion; the
difference of the two states jumps where a decision turns. The jump is the first sample where the
difference exceeds ``GROWTH`` times the initial one, and what turned it is the last decision before that
sample that the two runs take differently: an offer to the full stack decided otherwise, or one of the
other decisions whose flags the core outputs (the tuning law (30)/(31), the bound (5), the actuator limit;
at one sample the offer comes after the flags), or the implicit solve of z_v (docs/paper-notes.md 2.4) taking
another branch of its equation (``SOLVE_GAIN``; at one sample it comes before the flags, as step 1 of the core). The runs part visibly where their angles differ by more
than ``APART``. A swap decision comes with its margin in each run: the smallest shift of every threshold of the swap
rule (the gain, the rank's margin and the tie window, moved together as ``swap_margin`` moves them),
relative to trace(M), that changes that run's decision, searched below the rule's own margin
(``SWAP_MARGIN``: a larger shift empties the tie window, and every re-decision refuses); None when none
there does, i.e. the decision is clear of rounding and it was the change of the state that turned it. The
actuator limit comes with its margin in each run too: how far the torque it was given (tau* + tau^a + PE,
summed as the core sums it) lay outside the limit, relative to rho (negative: inside, where the limit left
it); the other flags come without one. ``orchestration.reports.parting_tables`` picks the pairs and stores them.
"""
from __future__ import annotations

from typing import Any

import numpy as np

from fmu_controller.saturation import saturate_norm
from fmu_controller.sotc import SotcCore
from fmu_controller.sotc_math import N_BASIS
from fmu_controller.sotc_stack import SWAP_MARGIN, CLStack
from fmu_numerics.fixed_linalg import trace
from orchestration.study.comparison import NOMINAL, PERTURBATIONS, initial_state
from orchestration.study.pure_loop import simulate

STOP_TIME = 100.0  # s
APART = 1e-3  # rad: two runs whose angles differ by more have visibly parted
GROWTH = 1e4  # a smooth loop amplifies the initial change by a few tens here (docs/robustness.md, the ladder)
# the shifts tried, relative to trace(M): powers of ten from 1e-16 up to below SWAP_MARGIN (2.2e-13)
SHIFTS = tuple(10.0 ** -k for k in range(16, 0, -1) if 10.0 ** -k < SWAP_MARGIN)
FLAGS = ("tuning_law", "tau_a_bounded", "chi_a_bounded", "tau_limited")  # the other decisions, as outputs
SOLVE = "implicit solve"  # the z_v of (6)/(28) (docs/paper-notes.md 2.4), on another branch of its equation
# the solve took another branch at a sample where both runs solve the equation (residual below RESIDUAL) and
# their z_v lie more than BRANCH apart and SOLVE_GAIN times further apart than what it is solved from
SOLVE_GAIN, BRANCH, RESIDUAL = 1e4, 1e-3, 1e-9  # -, rad/s, rad/s


class DecisionLog(CLStack):
    """A ``CLStack`` that logs every swap decision (time, row or -1) and, at the offer numbered ``probe``, the
    smallest threshold shift that changes it (``probed``; None when no shift in ``SHIFTS`` does; ``was_probed``)."""

    def __init__(self, stack: CLStack, probe: int = -1):
        super().__init__(stack.P, stack.selection, stack.replay_form, stack.constants)
        self.now = 0.0
        self.decisions: list[tuple[float, int]] = []
        self.probe = probe
        self.probed: float | None = None
        self.was_probed = False

    def _swap_row(self, eta, spectrum, shift: float = 0.0) -> int:
        row = super()._swap_row(eta, spectrum, shift)
        if len(self.decisions) == self.probe:
            self.probed, self.was_probed = self._margin(eta, row), True
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


def _last_flag(a, b, before: int) -> tuple[int, str] | None:
    """(sample, name) of the last of ``FLAGS`` whose value differs between runs a and b before sample ``before``
    (at one sample, the last in ``FLAGS``' order)."""
    found = []
    for order, name in enumerate(FLAGS):
        diff = np.nonzero(a.out(name)[:before] != b.out(name)[:before])[0]
        if len(diff):
            found.append((int(diff[-1]), order, name))
    return (max(found)[0], max(found)[2]) if found else None


def limit_margin(core: SotcCore, run, k: int) -> float:
    """(||tau|| - rho) / rho of the torque the actuator limit of ``core``'s design was given at sample ``k`` of
    ``run`` (per joint, the larger |tau_j|, where the limit clips each joint)."""
    raw = [run.out(f"tau_star{j}")[k] + run.out(f"tau_a{j}")[k] + run.out("pe")[k] for j in (1, 2)]
    size = max(abs(raw[0]), abs(raw[1])) if core.actuator_per_joint else saturate_norm(raw[0], raw[1], core.rho)[2]
    return float((size - core.rho) / core.rho)


def _solve_moves(a, b) -> tuple[np.ndarray, np.ndarray]:
    """Per sample, between the runs a and b: how far the implicit solve's z_v (the outputs z3, z4) differs, and
    how far what it is solved from (the plant state and W; the reference is the same)."""
    dz = np.maximum(np.abs(a.out("z3") - b.out("z3")), np.abs(a.out("z4") - b.out("z4")))
    dw = np.max([np.abs(a.out(f"W{k}") - b.out(f"W{k}")) for k in range(1, N_BASIS + 1)], axis=0)
    return dz, np.maximum(np.abs(a.y - b.y).max(axis=1), dw)


def _solve_turns(a, b, dz: np.ndarray, inputs: np.ndarray, before: int) -> int | None:
    """The last sample before ``before`` where the solve took another branch in one of the runs a and b (see
    ``SOLVE_GAIN``)."""
    solved = np.maximum(a.out("zv_residual"), b.out("zv_residual")) <= RESIDUAL
    turned = np.nonzero(((dz > SOLVE_GAIN * inputs) & (dz > BRANCH) & solved)[:before])[0]
    return int(turned[-1]) if len(turned) else None


def _largest(values: np.ndarray, t: np.ndarray) -> list[float]:
    """[the largest of ``values``, the time of its sample]."""
    k = int(np.argmax(values))
    return [float(values[k]), float(t[k])]


def _step_growth(t: np.ndarray, d: np.ndarray, jump: int) -> list[float]:
    """[factor, time]: the largest growth of the state difference ``d`` from one sample to the next, up to the
    jump (a decision turned gives many orders of magnitude at once; an amplifying loop, less per sample)."""
    k = np.arange(min(jump, len(d) - 1))
    k = k[d[k] > 0.0]
    return _largest(d[k + 1] / d[k], t[k + 1])


def parting(params: dict[str, float], index: int) -> dict[str, Any]:
    """Where the design's nominal run and its run under ``PERTURBATIONS[index]`` part, and what decided it."""
    a, log_a = logged_run(params, NOMINAL)
    b, log_b = logged_run(params, PERTURBATIONS[index])
    apart = np.nonzero(np.abs(a.y[:, :2] - b.y[:, :2]).max(axis=1) > APART)[0]
    d = np.abs(a.y - b.y).max(axis=1)
    grown = np.nonzero(d > GROWTH * d[0])[0]
    jump = int(grown[0]) if len(grown) else len(a.t)
    out: dict[str, Any] = {"perturbation": index, "apart_t": float(a.t[apart[0]]) if len(apart) else None,
                           "jump_t": float(a.t[jump]) if len(grown) else None, "step_growth": _step_growth(a.t, d, jump)}
    # offers made at t < t[jump] (an offer at t moves the state from the next sample on)
    differ = [i for i, (x, y) in enumerate(zip(log_a.decisions, log_b.decisions)) if x != y and x[0] < a.t[jump - 1] + 1e-9]
    last = differ[-1] if differ else None
    flag = _last_flag(a, b, jump)
    dz, inputs = _solve_moves(a, b)
    solve = _solve_turns(a, b, dz, inputs, jump)
    ahead = inputs[:jump] > 0.0  # the largest ratio of the solve's move to its inputs' up to the jump
    out["solve_gain"] = _largest(dz[:jump][ahead] / inputs[:jump][ahead], a.t[:jump][ahead])
    if solve is not None and (flag is None or solve >= flag[0]):  # at one sample the solve comes first (step 1)
        flag = (solve, SOLVE)
    if last is not None and (flag is None or log_a.decisions[last][0] >= float(a.t[flag[0]])):
        margins = [logged_run(params, p, last)[1].probed for p in (NOMINAL, PERTURBATIONS[index])]
        out["decided_by"] = {"what": "CL stack swap", "t": log_a.decisions[last][0],
                             "rows": [log_a.decisions[last][1], log_b.decisions[last][1]], "margins": margins}
    elif flag is None:
        out["decided_by"] = None
    else:
        out["decided_by"] = {"what": flag[1], "t": float(a.t[flag[0]])}
        if flag[1] == "tau_limited":
            core = SotcCore(**params)
            out["decided_by"]["margins"] = [limit_margin(core, r, flag[0]) for r in (a, b)]
        if flag[1] == SOLVE:  # how far z_v and the torque moved, and how far what z_v is solved from
            k = flag[0]
            torque = max(abs(a.out(n)[k] - b.out(n)[k]) for n in ("tau1", "tau2"))
            out["decided_by"]["moves"] = [float(dz[k]), float(torque), float(inputs[k])]
    return out

