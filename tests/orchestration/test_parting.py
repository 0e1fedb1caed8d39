"""Where nearby runs part (orchestration.study.parting): the log of decisions leaves the run as it is, and a
stored parting (docs/parting.json) is what the runs give now."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from fmu_controller.sotc import SotcCore
from fmu_controller.sotc_stack import SWAP_MARGIN
from fmu_plant.dynamics import STEP_SIZE as T
from orchestration.reports.parting_tables import STORE, stored
from orchestration.study.comparison import NOMINAL, PERTURBATIONS, initial_state
from orchestration.study.parting import SHIFTS, SOLVE, STOP_TIME, limit_margin, logged_run, parting
from orchestration.study.pure_loop import simulate

pytestmark = pytest.mark.slow  # 100 s loops
REPO = Path(__file__).resolve().parents[2]  # the checkout's store (the installed package has no docs/)


def _first() -> tuple[str, dict]:
    label, r = next(iter(stored(REPO).items()))
    return label, r


def test_the_log_and_its_probe_leave_the_run_and_the_swaps_as_they_are():
    _, r = _first()
    params = dict(r["params"])
    plain = SotcCore(**params)
    want = simulate(plain, stop_time=STOP_TIME, **initial_state((0.0,) * 4))
    got, log = logged_run(params, (0.0,) * 4, probe=3)  # the margin searched at the fourth offer
    assert np.array_equal(got.outputs, want.outputs) and np.array_equal(got.y, want.y)
    assert sum(row >= 0 for _, row in log.decisions) == plain.stack.swaps > 0
    assert len(log.decisions) > 3 and log.was_probed and (log.probed is None or log.probed in SHIFTS)


def test_the_margin_search_keeps_the_tie_window_open():
    """A shift moves the swap rule's tie window by as much (``margin + shift``); from SWAP_MARGIN on the window is
    empty and every re-decision refuses, so the search stays below it."""
    assert SHIFTS[0] == 1e-16 and max(SHIFTS) < SWAP_MARGIN < 10 * max(SHIFTS)


def _first_of(kind: str | None) -> str:
    """The label of the first stored pair that ``kind`` (a decision's ``what``, or None: no logged decision) parted."""
    return next(label for label, r in stored(REPO).items() if (r["decided_by"] or {}).get("what") == kind)


@pytest.mark.parametrize("kind", [SOLVE, None], ids=["the solve", "no logged decision"])
def test_a_stored_parting_is_what_the_runs_give(kind):
    label = _first_of(kind)
    r = stored(REPO)[label]
    got = parting(dict(r["params"]), r["perturbation"])
    assert got == {k: v for k, v in r.items() if k not in ("params", "move")}, f"{label}: rerun {STORE}"


class _Outputs:
    """A run's outputs at one sample, for ``limit_margin``."""

    def __init__(self, **values: float):
        self.values = values

    def out(self, name: str) -> np.ndarray:
        return np.array([self.values.get(name, 0.0)])


@pytest.mark.parametrize("form, want", [(0.0, (34.0 ** 0.5 - 4.0) / 4.0), (1.0, 0.5)], ids=["the norm", "each joint"])
def test_the_limits_margin_is_how_far_the_torque_it_was_given_lay_outside_rho(form, want):
    """tau* + tau^a + PE (PE on both joints), rho = 4: (4.5 + 0.5, -3.5 + 0.5) = (5, -3), whose norm the
    limit takes as printed ((sqrt(34) - 4) / 4), and (2, -6) where it clips each joint ((6 - 4) / 4)."""
    run = (_Outputs(tau_star1=3.0, tau_a1=1.5, tau_star2=-2.0, tau_a2=-1.5, pe=0.5) if form == 0.0 else
           _Outputs(tau_star1=1.0, tau_a1=0.5, tau_star2=-4.0, tau_a2=-2.5, pe=0.5))
    core = SotcCore(actuator_form=form, rho=4.0)
    assert core.actuator_per_joint == (form == 1.0)
    assert limit_margin(core, run, 0) == pytest.approx(want, rel=1e-15)


def test_where_the_implicit_solve_parted_the_runs_both_took_a_solution():
    """A stored pair the solve parted: at that sample both runs' z_v solve its equation (residual at rounding
    level), and they differ by a tenth of a rad/s or more: two branches, not a failed solve."""
    pairs = [(r, r["decided_by"]) for r in stored(REPO).values() if r["decided_by"] and r["decided_by"]["what"] == SOLVE]
    assert pairs
    r, d = pairs[0]
    k = int(round(d["t"] / T))
    runs = [logged_run(dict(r["params"]), p)[0] for p in (NOMINAL, PERTURBATIONS[r["perturbation"]])]
    assert all(run.out("zv_residual")[k] < 1e-12 for run in runs)
    assert max(abs(runs[0].out(n)[k] - runs[1].out(n)[k]) for n in ("z3", "z4")) == d["moves"][0] > 0.1
