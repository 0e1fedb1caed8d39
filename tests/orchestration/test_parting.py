"""Where nearby runs part (orchestration.study.parting): the log of decisions leaves the run as it is, and a
stored parting (docs/parting.json) is what the runs give now."""
from __future__ import annotations

import numpy as np
import pytest

from fmu_controller.sotc import SotcCore
from pathlib import Path

from orchestration.reports.parting_tables import STORE, stored
from orchestration.study.comparison import initial_state
from fmu_controller.sotc_stack import SWAP_MARGIN
from orchestration.study.parting import SHIFTS, STOP_TIME, logged_run, parting
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


def test_a_stored_parting_is_what_the_runs_give():
    label, r = _first()
    got = parting(dict(r["params"]), r["perturbation"])
    assert got == {k: v for k, v in r.items() if k not in ("params", "move")}, f"{label}: rerun {STORE}"
