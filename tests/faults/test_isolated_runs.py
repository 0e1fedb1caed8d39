"""A foreign controller FMU that crashes, exits, hangs, answers NaN or fmi2Error fails only its own run
(``orchestration.run.isolated``): the run's reason names the fault, the FMI call, the instance and the
time; every sample before the fault is in the result and was handed to the observer; the test process
lives on, no child process is left and nothing is left in TMPDIR. The hostile FMUs are plain C
(``tests/support/hostile``), built once per session; they misbehave from their doStep at t = 1.00 s."""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from support import hostile
from support.children import children as _children
from support.cli import leftovers

from orchestration.run import interrupt, isolated, master
from orchestration.run.scenario import ScenarioError, load_scenario

SAMPLES_BEFORE = hostile.FAULT_SAMPLE + 1  # t_0 .. t_100: the doStep of t_100 misbehaves
BLOCK = 30  # 101 = 3 blocks sent + 11 samples the parent takes from the shared tail after a crash
AT = f"in fmi2DoStep of 'controller' at t = 1.00 s (sample {hostile.FAULT_SAMPLE})"


@pytest.fixture(scope="session")
def hostile_paths(fmu_paths, tmp_path_factory) -> dict[str, Path]:
    folder = tmp_path_factory.mktemp("hostile")
    with pytest.MonkeyPatch.context() as patch:
        built = {hostile.identifier(f): hostile.build(f, folder, patch) for f in hostile.FAULTS}
    return {**fmu_paths, **built}


@pytest.fixture
def tmpdir_env(tmp_path, monkeypatch) -> Path:
    """The child's TMPDIR in ``tmp_path/tmp`` (``support.cli.leftovers`` reads it)."""
    (tmp_path / "tmp").mkdir()
    monkeypatch.setenv("TMPDIR", str(tmp_path / "tmp"))
    return tmp_path


class Seen:
    """An observer keeping every call (copies of the blocks)."""

    def __init__(self, on_block=None):
        self.started, self.finished, self.on_block = False, None, on_block
        self.times: list[np.ndarray] = []
        self.rows: dict[str, list[np.ndarray]] = {}

    def start(self, scenario, columns, parameters) -> None:
        self.started = True

    def block(self, time, rows) -> None:
        self.times.append(time.copy())
        for name, part in rows.items():
            self.rows.setdefault(name, []).append(part.copy())
        if self.on_block:
            self.on_block()

    def finish(self, result) -> None:
        self.finished = result

    @property
    def samples(self) -> int:
        return sum(len(t) for t in self.times)


def test_our_fmus_in_a_child_give_the_samples_of_the_run_in_this_process(fmu_paths):
    scenario = load_scenario("paper").with_stop_time(hostile.STOP_TIME)
    seen = Seen()
    here = master.run(scenario, fmu_paths)
    there = isolated.run(scenario, fmu_paths, seen, block_size=BLOCK)
    assert not there.failed and there.error is None and there.samples == here.samples == 201
    assert np.array_equal(there.time, here.time) and there.parameters == here.parameters and there.fmus == here.fmus
    for name, outputs in here.outputs.items():
        assert np.array_equal(np.concatenate(seen.rows[name]), np.column_stack(list(outputs.values())))
        for variable, values in outputs.items():
            assert np.array_equal(there.outputs[name][variable], values), (name, variable)
    assert seen.finished is there and np.array_equal(np.concatenate(seen.times), here.time)


@pytest.mark.parametrize("fault, reason", [
    ("segv", f"crashed: SIGSEGV {AT}"),
    ("abort", f"crashed: SIGABRT {AT}"),
    ("exit", f"ended with exit code 3 {AT}"),
    ("loop", f"no answer in 1 s {AT}: the process was killed"),
    ("error", f"fmi2DoStep failed with status 3 (error). at t = 1.00 s (sample 100) -- controller: fmi2DoStep: "
              "hostile fault at t = 1.00 s"),
    ("nan", "controller.tau1 is nan at t = 1.01 s (sample 101): an output that is not a finite number stops the run"),
])
def test_a_hostile_fmu_fails_its_run_with_the_reason_and_every_sample_before(hostile_paths, tmpdir_env, fault,
                                                                              reason):
    before = _children()
    seen = Seen()
    result = isolated.run(hostile.scenario(fault), hostile_paths, seen, block_size=BLOCK, answer_s=1.0)
    assert result.failed and result.error == reason and not result.interrupted
    assert result.samples == seen.samples == SAMPLES_BEFORE and seen.started and seen.finished is result
    assert np.array_equal(result.time, np.arange(SAMPLES_BEFORE) * 0.01)
    assert np.isfinite(np.concatenate(seen.rows["controller"])).all()
    assert np.array_equal(result.outputs["controller"]["tau1"], np.concatenate(seen.rows["controller"])[:, 0])
    if fault == "error":  # the FMU's own message crossed the process boundary
        assert [(r.instance, r.message, r.sample) for r in result.logs if r.status == "ERROR"] == [
            ("controller", "fmi2DoStep: hostile fault at t = 1.00 s", hostile.FAULT_SAMPLE)]
    assert _children() == before
    assert leftovers(tmpdir_env) == []


@pytest.fixture
def deferred():
    """Signals deferred as the commands defer them; the flag they set cleared again afterwards."""
    try:
        with interrupt.signals_deferred():
            yield
    finally:
        interrupt.STATE.requested, interrupt.STATE.signum = False, None


def test_a_signal_to_the_parent_stops_the_child_between_two_steps(fmu_paths, tmpdir_env, deferred):
    """SIGTERM once the first block arrived: the child is told and stops between two steps."""
    before = _children()
    seen = Seen(on_block=lambda: interrupt.requested() or os.kill(os.getpid(), signal.SIGTERM))
    result = isolated.run(load_scenario("paper"), fmu_paths, seen, block_size=10, keep_samples=False)
    assert result.interrupted and result.failed and result.error.startswith("interrupted by SIGTERM after t = ")
    assert 10 <= result.samples == seen.samples < 10001 and seen.finished is result
    assert _children() == before
    assert leftovers(tmpdir_env) == []


def test_a_wrong_scenario_is_raised_as_in_this_process(hostile_paths):
    scenario = hostile.scenario("nan")
    missing = {m: p for m, p in hostile_paths.items() if m != hostile.identifier("nan")}
    with pytest.raises(ScenarioError, match="instance 'controller': no built FMU for model 'HostileNan'"):
        isolated.run(scenario, missing)
    with pytest.raises(ScenarioError, match="answer_s must be > 0"):
        isolated.run(scenario, hostile_paths, answer_s=0.0)


def test_the_master_in_this_process_runs_a_plain_c_fmu_up_to_its_error(hostile_paths):
    """fmi2Instantiate gets calloc and free, which FMI 2.0 requires: the C FMU refused to start without them."""
    result = master.run(hostile.scenario("error"), hostile_paths)
    assert result.error.startswith("fmi2DoStep failed with status 3 (error). at t = 1.00 s (sample 100)")
    assert result.samples == SAMPLES_BEFORE


KILLED_PARENT = """
import json, sys
from pathlib import Path
sys.path.insert(0, sys.argv[1])
from support import hostile
from orchestration.run import isolated
isolated.run(hostile.scenario("loop"), {m: Path(p) for m, p in json.loads(sys.argv[2]).items()}, answer_s=600)
"""


def _state(pid: int) -> str | None:
    """The process's state letter (Z: a zombie), None once it is gone."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (OSError, IndexError):
        return None


def test_a_child_whose_parent_is_killed_dies_with_it(hostile_paths, tmp_path):
    """SIGKILL of the process that runs a hung FMU in its child: the kernel kills the child too."""
    if not sys.platform.startswith("linux"):
        pytest.skip("the parent-death signal is Linux's")
    paths = json.dumps({m: str(p) for m, p in hostile_paths.items()})
    parent = subprocess.Popen([sys.executable, "-c", KILLED_PARENT, str(Path(__file__).parents[1]), paths])
    deadline = time.monotonic() + 120  # a bound for a broken test, not a timing assumption
    child = None
    while child is None and time.monotonic() < deadline and parent.poll() is None:
        for status in Path("/proc").glob("[0-9]*/cmdline"):
            try:
                if b"_child_main" in status.read_bytes() and _ppid(int(status.parent.name)) == parent.pid:
                    child = int(status.parent.name)
            except (OSError, ValueError):
                continue
        time.sleep(0.05)
    assert child is not None, "the run's child never started"
    parent.kill()
    parent.wait()
    while _state(child) not in (None, "Z") and time.monotonic() < deadline:
        time.sleep(0.05)
    assert _state(child) in (None, "Z")


def _ppid(pid: int) -> int:
    return int(Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[1])


def test_a_binary_for_another_platform_only_fails_the_run_during_set_up(hostile_paths, tmp_path):
    import zipfile

    import fmpy

    moved = tmp_path / "HostileNan.fmu"
    with zipfile.ZipFile(hostile_paths["HostileNan"]) as src, zipfile.ZipFile(moved, "w") as out:
        for item in src.infolist():
            out.writestr(item.filename.replace(f"binaries/{fmpy.platform}/", "binaries/win64/"), src.read(item))
    seen = Seen()
    result = isolated.run(hostile.scenario("nan"), {**hostile_paths, "HostileNan": moved}, seen)
    assert result.failed and "during set-up" in result.error and "HostileNan" in result.error, result.error
    assert result.samples == seen.samples == 0 and seen.finished is result


def test_an_observer_that_fails_in_this_process_stops_the_child(fmu_paths):
    def refuse():
        raise OSError(28, "No space left on device")

    before = _children()
    seen = Seen(on_block=refuse)
    result = isolated.run(load_scenario("paper"), fmu_paths, seen, block_size=10)
    assert result.failed and result.error == "observer failed: OSError: [Errno 28] No space left on device"
    assert seen.finished is result and result.samples >= 10 and len(seen.times) == 1
    assert _children() == before


def test_a_recording_of_a_run_whose_fmu_crashed_holds_every_sample_before_it(hostile_paths, tmp_path):
    """The recorder of ``sotc-cosim run`` in this process, with its blocks of 1000: all 101 samples come from
    the child's shared tail after the crash."""
    from support.rrd_contents import read_entities

    from orchestration.recording import BLOCK_SIZE
    from orchestration.recording.writer_process import recorder_for

    target = tmp_path / "crashed.rrd"
    with recorder_for(target, 1, None) as recorder:
        result = isolated.run(hostile.scenario("segv"), hostile_paths, recorder, block_size=BLOCK_SIZE)
    assert result.error == f"crashed: SIGSEGV {AT}" and BLOCK_SIZE > SAMPLES_BEFORE
    steps = {entity: list(rows["step"]) for entity, rows in read_entities(target).items()}
    instances = {f"/fmu/{name}" for name in ("plant", "reference", "controller")}
    assert instances <= set(steps) and all(steps[e] == list(range(SAMPLES_BEFORE)) for e in instances)
    assert steps["/events/run"] == [hostile.FAULT_SAMPLE]  # the failure, at the last sample recorded


def test_a_crash_of_an_fmi3_controller_file_is_said_in_fmi3_terms(tmp_path):
    """Where the child was, for a controller given as a file (not in ``fmu_paths``): its own model description
    says FMI 3.0, so the call is fmi3DoStep (it fell back to FMI 2.0's names)."""
    from types import SimpleNamespace

    from support import fmi3_pd

    from orchestration.run import child

    fmu = fmi3_pd.build(tmp_path)
    (tmp_path / "s.toml").write_text(f'extends = "paper"\n[instances.controller]\nfmu = "{fmu}"\n')
    scenario = load_scenario(str(tmp_path / "s.toml"))
    code = child.calls(scenario.instances).index(("controller", "step")) + 1
    parent = SimpleNamespace(header=np.array([100, code, 0, 0]), scenario=scenario, fmu_paths={})
    assert isolated._Parent.where(parent) == "in fmi3DoStep of 'controller' at t = 1.00 s (sample 100)"
