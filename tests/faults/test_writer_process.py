"""``sotc-cosim run`` writes its recording in a child process: a child that dies ends the run in one
line and leaves no temporary file; a command that is killed leaves no child behind, and the child
finalises the recording it was writing."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from support.cli import TIME_LIMIT, leftovers, one_line, start

pytestmark = pytest.mark.slow  # runs in subprocesses, killed in the middle

RERUN = str(Path(sys.executable).with_name("rerun"))


def _writing(folder: Path, name: str):
    """True once the recording being written has a first block in its temporary file."""
    return lambda: any(p.stat().st_size > 100_000 for p in folder.glob(f".{name}.*.part"))


def _children(pid: int) -> list[int]:
    return [int(c) for c in Path(f"/proc/{pid}/task/{pid}/children").read_text().split()]


def _gone(pid: int) -> bool:
    """The process ``pid`` has ended (reaped, or a zombie waiting for its parent to reap it)."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().split()[2] == "Z"
    except FileNotFoundError:
        return True


def _started(target: Path, fmu_dir: Path) -> tuple[subprocess.Popen, int]:
    """``run paper`` recording to ``target``, once its writer has written a first block; and the writer."""
    proc = start(["run", "paper", "--recording", str(target), "--fmu-dir", str(fmu_dir)], target.parent)
    ready = _writing(target.parent, target.name)
    deadline = time.monotonic() + TIME_LIMIT
    while not ready() and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.05)
    writer, = _children(proc.pid)
    return proc, writer


def test_a_writer_that_dies_ends_the_run_in_one_line(fmu_dir, tmp_path):
    target = tmp_path / "r.rrd"
    proc, writer = _started(target, fmu_dir)
    os.kill(writer, signal.SIGKILL)
    out, err = proc.communicate(timeout=TIME_LIMIT)
    assert proc.returncode == 1, err
    assert one_line(err) == (f"sotc-cosim: error: cannot write {target}: [Errno 32] Broken pipe: the recording's "
                             f"writer (process {writer}) was killed by SIGKILL")
    assert not target.exists() and sorted(p.name for p in tmp_path.glob(".*")) == []
    assert leftovers(tmp_path) == []


def test_a_killed_command_leaves_no_writer_and_a_finished_recording(fmu_dir, tmp_path):
    target = tmp_path / "r.rrd"
    proc, writer = _started(target, fmu_dir)
    proc.kill()
    proc.communicate(timeout=TIME_LIMIT)  # returns once the writer, which holds stdout too, has ended
    assert _gone(writer)
    verified = subprocess.run([RERUN, "rrd", "verify", str(target)], capture_output=True, text=True)
    assert verified.returncode == 0, verified.stderr  # finalised by the writer, with a "run aborted" event


# ``sotc-cosim run`` whose writer cannot create its temporary file (its folder does not exist): the
# recorder fails at its start, which the command learns with the first block
UNWRITABLE_START = ("import sys\nimport orchestration.outputs as o\nreal = o.temporary_path\n"
                    "o.temporary_path = lambda path, pid=None: real(path.parent / 'no-such-folder' / path.name, pid)\n"
                    "from orchestration.cli import main\nsys.exit(main(sys.argv[1:]))")


def test_a_recording_that_cannot_start_ends_the_run_in_one_line(fmu_dir, tmp_path):
    """The failed start comes back with the first block, and the blocks after it (sent before that answer
    was read) are answered with the same failure, not a traceback of a recorder that has no stream."""
    target = tmp_path / "x.rrd"
    proc = subprocess.run([sys.executable, "-c", UNWRITABLE_START, "run", "paper-ct", "--stop-time", "20",
                           "--recording", str(target), "--fmu-dir", str(fmu_dir)], cwd=tmp_path, capture_output=True,
                          text=True, timeout=TIME_LIMIT)
    assert proc.returncode == 1, proc.stderr
    assert one_line(proc.stderr).startswith(f"sotc-cosim: error: cannot write {target}: "), proc.stderr
    assert "Traceback" not in proc.stderr and not target.exists() and leftovers(tmp_path) == []
