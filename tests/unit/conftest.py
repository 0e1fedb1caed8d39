"""Fixtures of the unit tests: the 100 s pure closed-loop runs several SOTC tests share (about 1 s each,
computed once per session)."""
from __future__ import annotations

import pytest
from support.sotc import T, scenario_params

from fmu_controller.sotc import SotcCore
from orchestration.study.pure_loop import simulate


@pytest.fixture(scope="session")
def paper_run():
    ctrl = SotcCore(**scenario_params("paper"))
    return ctrl, simulate(ctrl, stop_time=100.0, step=T)


@pytest.fixture(scope="session")
def pe_only_run():
    ctrl = SotcCore(**scenario_params("paper-pe-only"))
    return ctrl, simulate(ctrl, stop_time=100.0, step=T)
