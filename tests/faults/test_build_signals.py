"""Signals while FMUs are being built (the first ``run``, ``build``, ``export-ssp``), through the installed
console script: SIGTERM or SIGHUP at a seeded random moment of the build, sent to the command's
process group or to its PID alone, stops the build child with the command (within a second), says
so in one line, exits 128 + the signal, and leaves nothing in ``$TMPDIR`` and no process behind;
after SIGKILL of the command no child outlives it to write into the FMU folder; a later build
removes the folders a killed one left."""
from __future__ import annotations

import os
import random
import signal
import subprocess
import threading
import time
from pathlib import Path

import pytest

from support.cli import SCRIPT, env_for, leftovers, run, warm_core_cache

from orchestration.outputs import private_root

pytestmark = pytest.mark.slow  # builds in subprocesses, signalled at random moments

PICKS = random.Random(27)  # the moments, reproducible
MODELS = ["ArmPlant", "ReferenceTrajectory"]  # two small FMUs: a moment inside the second is in a build
STOPPED = "stopped while building FMUs; nothing ran"
# the cores the second FMU built compiles (the others come from the cache, as after a user's first build): the
# moment falls into a compile, and the first FMU's build does not compile for seconds before it
COMPILED_HERE = ("fmu_plant/trajectory", "fmu_controller/saturation")


def _descendants(tmp: Path) -> list[str]:
    """Processes (but this one) whose environment holds this test's TMPDIR: the command's children."""
    marker = f"TMPDIR={tmp}".encode()
    found = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit() or int(entry.name) == os.getpid():
            continue
        try:
            if marker in (entry / "environ").read_bytes().split(b"\0"):
                found.append((entry / "cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")[:120])
        except OSError:
            continue
    return found


def _settled(tmp: Path, seconds: float = 10.0) -> list[str]:
    """The command's processes still there once they had ``seconds`` to end."""
    deadline = time.monotonic() + seconds
    while _descendants(tmp) and time.monotonic() < deadline:
        time.sleep(0.1)
    return _descendants(tmp)


class _Lines:
    """The command's stderr, read as it comes (build progress goes there)."""

    def __init__(self, proc: subprocess.Popen):
        self.lines: list[str] = []
        self.thread = threading.Thread(target=lambda: self.lines.extend(proc.stderr), daemon=True)
        self.thread.start()

    def wait_for(self, text: str, timeout: float = 300) -> None:
        deadline = time.monotonic() + timeout
        while not any(text in line for line in self.lines) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert any(text in line for line in self.lines), self.lines


def _build_then_signal(args: list[str], cwd: Path, signum: int, group: bool, marker: str = f"[2/{len(MODELS)}]"):
    """Start ``args``; once the build shows ``marker`` (the second FMU's build started), wait a random moment
    and send ``signum`` to the process group or the PID; return (exit code, stdout, stderr lines)."""
    warm_core_cache(cwd, leave=COMPILED_HERE)
    proc = subprocess.Popen(_script_cmd(args), cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env=env_for(cwd), start_new_session=True)
    lines = _Lines(proc)
    lines.wait_for(marker)
    time.sleep(PICKS.uniform(0.0, 1.5))
    if group:
        os.killpg(proc.pid, signum)
    else:
        proc.send_signal(signum)
    code = proc.wait(timeout=120)
    lines.thread.join(timeout=10)
    out = proc.stdout.read()
    proc.stdout.close()
    return code, out, [line.rstrip("\n") for line in lines.lines]


def _script_cmd(args: list[str]) -> list[str]:
    return [SCRIPT, *args]


@pytest.mark.parametrize("signum, group", [(signal.SIGTERM, True), (signal.SIGTERM, False), (signal.SIGHUP, False)],
                         ids=["SIGTERM-group", "SIGTERM-pid", "SIGHUP-pid"])
def test_a_signal_during_build_stops_it_and_leaves_nothing(signum, group, tmp_path):
    code, _, err = _build_then_signal(["build", "--out", str(tmp_path / "fmus"), *MODELS], tmp_path, signum,
                                      group)
    assert code == 128 + signum, err
    assert err[-1] == f"sotc-cosim: interrupted ({signal.Signals(signum).name}): {STOPPED}", err
    assert not any("Traceback" in line for line in err), err
    finished = [line for line in err if line.startswith(f"[{len(MODELS)}/{len(MODELS)}] {MODELS[-1]}: ")]
    assert finished == [], f"the build went on after the signal: {finished}"  # it was: every FMU built
    assert _settled(tmp_path / "tmp") == []
    assert leftovers(tmp_path, folders=True) == []  # no sotc_stage_*, no sotc_cython_*
    assert not (tmp_path / "fmus" / "ReferenceTrajectory.fmu").exists()  # nothing half-built or later


def test_sigterm_during_the_first_run_stops_its_build_and_runs_nothing(tmp_path):
    """paper-ct needs three FMUs: the signal falls into the build of the second, to the process group."""
    code, out, err = _build_then_signal(["run", "paper-ct", "--stop-time", "1", "--fmu-dir", str(tmp_path / "fmus")],
                                        tmp_path, signal.SIGTERM, group=True, marker="[2/3]")
    assert code == 143, err
    assert err[-1] == f"sotc-cosim: interrupted (SIGTERM): {STOPPED}"
    assert out == "" and not (tmp_path / "recordings").exists()  # no run started, no recording
    assert _settled(tmp_path / "tmp") == [] and leftovers(tmp_path, folders=True) == []


def test_after_sigkill_of_the_command_no_build_child_writes_fmus(tmp_path):
    out = tmp_path / "fmus"
    warm_core_cache(tmp_path, leave=COMPILED_HERE)
    proc = subprocess.Popen(_script_cmd(["build", "--out", str(out), *MODELS]), cwd=tmp_path, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=env_for(tmp_path))
    lines = _Lines(proc)
    lines.wait_for(f"[2/{len(MODELS)}]")
    proc.kill()  # the command alone: its children are not signalled by anyone but the kernel
    proc.wait(timeout=30)
    assert _settled(tmp_path / "tmp") == []  # the parent-death signal ended the build child and the compiler
    before = sorted(p.name for p in out.iterdir())
    time.sleep(2.0)
    assert sorted(p.name for p in out.iterdir()) == before and "ReferenceTrajectory.fmu" not in before


def test_a_later_build_removes_what_a_killed_build_left(tmp_path):
    from orchestration.scratch import owner_prefix

    dead = subprocess.Popen(["true"])
    dead.wait()
    stale = tmp_path / "tmp" / (owner_prefix("sotc_stage_").rsplit("-", 2)[0] + f"-{dead.pid}-x")
    stale.mkdir(parents=True)
    (stale / "resources").mkdir()
    alive = tmp_path / "tmp" / (owner_prefix("sotc_stage_") + "mine")  # this test's own: kept
    alive.mkdir()
    warm_core_cache(tmp_path)  # about what the build removes, not about compiling
    proc = run(["build", "--out", str(tmp_path / "fmus"), "Disturbance"], tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert "Disturbance.fmu" in proc.stdout.strip().splitlines()[-1], proc.stdout
    assert not stale.exists() and alive.exists()


def test_a_sweep_removes_the_scratch_a_killed_coordinator_left(fmu_dir, tmp_path):
    """A coordinator killed with SIGKILL leaves its Dask scratch (56 MB once); the next sweep on
    this host removes it once its owner process is gone, and its own scratch at the end."""
    from orchestration.scratch import scratch_name

    dead = subprocess.Popen(["true"])
    dead.wait()
    root = private_root(tmp_path / "tmp")
    stale = root / "scratch" / f"{scratch_name().split('-')[0]}-{dead.pid}-1" / "dask"
    stale.mkdir(parents=True)
    root.chmod(0o700)
    (stale / "spill.bin").write_bytes(b"\0" * 100_000)
    proc = run(["sweep", "paper", "--set", "controller.rho=3", "--stop-time", "0.05", "--workers", "1",
                "--out", "out", "--fmu-dir", str(fmu_dir)], tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert list((root / "scratch").iterdir()) == []


def test_build_says_why_the_cores_stay_python(tmp_path):
    env = {**env_for(tmp_path), "SOTC_COSIM_COMPILE": "0"}
    proc = subprocess.run([SCRIPT, "build", "--out", "fmus", "ReferenceTrajectory"], cwd=tmp_path, env=env,
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert "hot cores stay Python: SOTC_COSIM_COMPILE=0 asks for Python cores" in proc.stderr.splitlines()[0]
    assert "[1/1] ReferenceTrajectory" in proc.stderr  # a line per FMU while it builds
    assert proc.stdout.strip().endswith("ReferenceTrajectory.fmu: Python only (SOTC_COSIM_COMPILE=0 asks for Python cores)")
