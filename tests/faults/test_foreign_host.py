"""The benchmark's loop in a child process that serves many runs (orchestration.study.foreign_host): a run
through the host equals ForeignLoop in this process bit for bit; a controller FMU that crashes, hangs or writes
NaN torques fails only its own run, with the reason, and the next run works (in a new child where the old one
was lost); no child is left after close and nothing in TMPDIR. The hostile FMUs (tests/support/hostile)
misbehave from their doStep at sample 10 (t = 0.10 s); a run of 0.05 s ends before it."""
from __future__ import annotations

import signal
from pathlib import Path

import numpy as np
import pytest
from support import hostile
from support.children import children
from support.cli import leftovers
from support.example_controller import PORTS, built_fmu

from orchestration.run import interrupt
from orchestration.study.foreign_host import ForeignHost
from orchestration.study.foreign_loop import ForeignLoop
from orchestration.study.pure_loop import metrics

FAULT_SAMPLE = 10
STOP, BEFORE = 0.5, 0.05  # a run that reaches the fault, one that ends before it
GAINS = {"Kp": 10.0, "Kd": 3.0, "umax": 10.0}  # the actuator cuts (tests/orchestration/test_foreign_loop.py)
AT = f"in fmi2DoStep of 'controller' at t = 0.10 s (sample {FAULT_SAMPLE})"


@pytest.fixture(scope="module")
def built(tmp_path_factory) -> dict[str, Path]:
    folder = tmp_path_factory.mktemp("host")
    with pytest.MonkeyPatch.context() as patch:
        faults = {f: hostile.build(f, folder, patch, sample=FAULT_SAMPLE) for f in ("segv", "loop", "nan")}
    return {**faults, "example": built_fmu(folder)}


@pytest.fixture
def tmpdir_env(tmp_path, monkeypatch) -> Path:
    """The child's TMPDIR in ``tmp_path/tmp`` (``support.cli.leftovers`` reads it)."""
    (tmp_path / "tmp").mkdir()
    monkeypatch.setenv("TMPDIR", str(tmp_path / "tmp"))
    return tmp_path


def test_a_run_through_the_host_equals_the_loop_in_this_process_bit_for_bit(built, tmpdir_env):
    before = children()
    with ForeignLoop(built["example"], PORTS) as loop:
        here = loop.run(GAINS, stop_time=STOP)
    with ForeignHost(built["example"], PORTS) as host:
        lean = host.run(GAINS, stop_time=STOP)
        full = host.run(GAINS, stop_time=STOP, samples=True)
        assert children() - before == {host.proc.pid} and host.restarts == 0
    assert not lean.failed and lean.error is None and lean.samples is None
    assert lean.metrics == full.metrics == metrics(here) and lean.cuts == full.cuts == here.cuts > 0
    for name in ("t", "y", "ref", "outputs"):
        assert np.array_equal(getattr(full.samples, name), getattr(here, name)), name
    assert full.samples.names == here.names
    assert children() == before
    assert leftovers(tmpdir_env) == []


@pytest.mark.parametrize("fault, reason, answer_s", [
    ("segv", f"crashed: SIGSEGV {AT}", 30.0),
    ("loop", f"no answer in 1 s {AT}: the process was killed", 1.0),
])
def test_a_crash_or_a_hang_fails_its_run_and_the_next_runs_in_a_new_child(built, tmpdir_env, fault, reason,
                                                                           answer_s):
    before = children()
    with ForeignHost(built[fault], answer_s=answer_s) as host:
        first = host.proc.pid
        failed = host.run(stop_time=STOP)
        assert failed.failed and failed.error == reason and failed.metrics == {}
        assert children() == before and host.proc is None  # the child is gone, none started yet
        ok = host.run(stop_time=BEFORE)
        assert not ok.failed and ok.metrics and host.restarts == 1 and host.proc.pid != first
    assert children() == before
    assert leftovers(tmpdir_env) == []


def test_a_nan_torque_fails_its_run_in_the_same_child(built):
    with ForeignHost(built["nan"]) as host:
        first = host.proc.pid
        failed = host.run(stop_time=STOP)
        ok = host.run(stop_time=BEFORE)
        assert host.proc.pid == first and host.restarts == 0
    assert failed.failed and failed.error.startswith("IntegrationError: ")
    assert failed.error.endswith(f"at t = 0.11 s (sample {FAULT_SAMPLE + 1})")
    assert not ok.failed and ok.cuts == 0


def test_a_wrong_argument_or_port_map_is_raised_here(built):
    with ForeignHost(built["example"], PORTS) as host:
        with pytest.raises(TypeError):
            host.run(GAINS, stop_tme=STOP)
        with pytest.raises(ValueError, match="must be a positive integer multiple"):
            host.run(GAINS, stop_time=0.005)
        assert not host.run(GAINS, stop_time=BEFORE).failed and host.runs == 1
    with pytest.raises(ValueError, match="answer_s must be > 0"):
        ForeignHost(built["example"], PORTS, answer_s=0.0)
    before = children()
    with pytest.raises(ValueError, match=r"PdController.fmu: ScenarioError: instance 'controller': ports tau1, tau2"):
        ForeignHost(built["example"])  # its own names, not the contract's: the child refused to load it
    assert children() == before


def test_a_deferred_signal_kills_the_child_and_the_run_is_interrupted(built, tmpdir_env):
    """The flag a deferred SIGTERM sets (``orchestration.run.interrupt``), up while the child runs a hang."""
    before = children()
    try:
        with ForeignHost(built["loop"]) as host:
            interrupt.STATE.requested, interrupt.STATE.signum = True, signal.SIGTERM
            result = host.run(stop_time=STOP)
            assert host.proc is None
    finally:
        interrupt.STATE.requested, interrupt.STATE.signum = False, None
    assert result.failed and result.interrupted
    assert result.error.startswith("interrupted by SIGTERM ") and result.error.endswith(": the process was killed")
    assert children() == before
