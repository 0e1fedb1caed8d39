"""The commands run a controller FMU given as a file in a process of its own (``isolated.run_any``): one that
crashes fails its run, point or check with the reason, and the command goes on, exits 1 and keeps what
finished (the recording up to the crash, the other points). Our own FMUs keep running in the command's
process. The crashing controller is plain C (``tests/support/hostile``): SIGSEGV in its doStep at t = 0.5 s, within
check-controller's 1 s run."""
from __future__ import annotations

from pathlib import Path

import pytest
from support import hostile
from support.cli import leftovers, run

from orchestration.run import isolated
from orchestration.run.scenario import load_scenario

AT = 50  # the sample whose doStep crashes
CRASH = f"crashed: SIGSEGV in fmi2DoStep of 'controller' at t = 0.50 s (sample {AT})"


@pytest.fixture(scope="module")
def segv(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("segv")
    with pytest.MonkeyPatch.context() as patch:
        return hostile.build("segv", folder, patch, sample=AT)


@pytest.fixture(scope="module")
def loop(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("loop")
    with pytest.MonkeyPatch.context() as patch:
        return hostile.build("loop", folder, patch, sample=AT)


def _scenario(folder: Path, fmu: Path) -> Path:
    path = folder / "hostile.toml"
    path.write_text(f'extends = "paper"\nname = "hostile"\nstop_time = {hostile.STOP_TIME}\n'
                    f'[instances.controller]\nfmu = "{fmu}"\n')
    return path


def test_only_a_scenario_with_an_fmu_file_runs_in_a_child(segv, tmp_path):
    assert isolated.hosted(load_scenario(str(_scenario(tmp_path, segv))))
    assert not any(isolated.hosted(load_scenario(name)) for name in ("paper", "paper-ct", "paper-perturbed"))


def test_run_goes_on_after_a_crashed_controller_and_keeps_its_recording(segv, fmu_dir, tmp_path):
    """``run hostile.toml paper-ct``: the first crashes at t = 1 s, the second still runs; exit 1, both recordings
    open, the crashed one with every sample before the crash."""
    from support.rrd_contents import read_entities

    scenario = _scenario(tmp_path, segv)
    proc = run(["run", str(scenario), "paper-ct", "--stop-time", "2", "--fmu-dir", str(fmu_dir)], tmp_path)
    assert proc.returncode == 1, proc.stderr
    assert f"hostile: FAILED: {CRASH}" in proc.stderr.splitlines(), proc.stderr
    assert "Traceback" not in proc.stderr
    assert [line.split()[2] for line in proc.stdout.splitlines()[2:4]] == ["failed", "ok"], proc.stdout
    steps = read_entities(tmp_path / "recordings" / "hostile.rrd")["/fmu/plant"]["step"]
    assert list(steps) == list(range(AT + 1))
    assert read_entities(tmp_path / "recordings" / "paper-ct.rrd")["/fmu/plant"]["step"][-1] == 200
    assert leftovers(tmp_path) == []


def test_check_controller_says_the_run_crashed(segv, fmu_dir, tmp_path):
    """The interface meets the contract; its 1 s run reaches t = 1.00 s, where it crashes: exit 1, the reason."""
    proc = run(["check-controller", str(segv), "--fmu-dir", str(fmu_dir)], tmp_path)
    assert proc.returncode == 1, proc.stdout + proc.stderr
    assert "meets the controller contract" in proc.stdout
    assert f"  1 s run against our arm (scenario paper, rho = 4 N.m): FAILED: {CRASH}" in proc.stdout.splitlines()


def test_check_controller_says_a_torque_was_not_finite(fmu_dir, tmp_path, monkeypatch):
    """NaN torques from t = 0.5 s on: the 1 s run fails there, naming the output, the time and the sample."""
    fmu = hostile.build("nan", tmp_path, monkeypatch, sample=AT)
    monkeypatch.delenv("CC")
    proc = run(["check-controller", str(fmu), "--fmu-dir", str(fmu_dir)], tmp_path)
    assert proc.returncode == 1, proc.stdout + proc.stderr
    assert "FAILED: controller.tau1_fmu is nan at t = 0.51 s (sample 51)" in proc.stdout, proc.stdout


def test_a_sweep_point_with_a_crashed_controller_fails_alone(segv, fmu_dir, tmp_path):
    """The point's task as a Dask worker runs it (no cluster here: the worker is this process, which lives on)."""
    from orchestration.sweep.runner import fmu_blobs, point_key, run_point
    from orchestration.sweep.spec import grid_from_assignments

    sweep = grid_from_assignments(str(_scenario(tmp_path, segv)), ["controller.Kp=10,20"])
    blobs = fmu_blobs(sweep.model_names(), fmu_dir)
    rows = [run_point({"time_limit": 60.0, "state_bound": 1e3, "record": False, "point": point,
                       "key": point_key(point.scenario, {m: d for m, (d, _) in blobs.items()})}, blobs)
            for point in sweep.points()]
    assert [(r["status"], r["reason"]) for r in rows] == [("failed", CRASH)] * 2


def test_a_sweep_point_whose_controller_hangs_says_where_within_its_time_limit(loop, fmu_dir, tmp_path):
    """An endless loop in its doStep: the point's child gets no more time without an answer than the point's time
    limit, and the reason names the call and the time (not only "time limit exceeded")."""
    from orchestration.sweep.runner import fmu_blobs, point_key, run_point
    from orchestration.sweep.spec import grid_from_assignments

    [point] = grid_from_assignments(str(_scenario(tmp_path, loop)), ["controller.Kp=10"]).points()
    blobs = fmu_blobs([i.fmu for i in point.scenario.instances.values()], fmu_dir)
    row = run_point({"time_limit": 2.0, "state_bound": 1e3, "record": False, "point": point,
                     "key": point_key(point.scenario, {m: d for m, (d, _) in blobs.items()})}, blobs)
    assert row["status"] == "failed"
    assert row["reason"] == f"no answer in 2 s in fmi2DoStep of 'controller' at t = 0.50 s (sample {AT}): the process was killed"
