"""SIGINT, SIGTERM and SIGHUP at seeded random moments of ``run``, ``reproduce`` and ``sweep``: the
command stops between two steps, exits with 128 + the signal's number, says so in one line, keeps
what finished (the recordings verify), and leaves no temporary folder behind."""
from __future__ import annotations

import random
import signal
import subprocess
import sys
import threading
from pathlib import Path

import pytest

from support.cli import SIGNALS, env_for, exit_code_of, leftovers, one_line, signal_when, start

pytestmark = pytest.mark.slow  # full runs in subprocesses, signalled at random moments

RERUN = str(Path(sys.executable).with_name("rerun"))
PICKS = random.Random(19)  # the moments, reproducible


def _verify(path: Path) -> None:
    proc = subprocess.run([RERUN, "rrd", "verify", str(path)], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr


def _recorded(folder: Path, name: str, size: int):
    """True once the recording being written has ``size`` bytes (a moment inside the run)."""
    return lambda: any(p.stat().st_size >= size for p in folder.glob(f".{name}.*.part"))


@pytest.mark.parametrize("signum", SIGNALS, ids=lambda s: signal.Signals(s).name)
def test_a_signal_stops_a_recorded_run_between_two_steps(signum, fmu_dir, tmp_path):
    target = tmp_path / "r.rrd"
    proc = start(["run", "paper", "--recording", str(target), "--fmu-dir", str(fmu_dir)], tmp_path)
    code, out, err = signal_when(proc, _recorded(tmp_path, "r.rrd", PICKS.randint(200_000, 5_000_000)), signum)
    assert code == exit_code_of(signum), err
    assert one_line(err) == (f"sotc-cosim: interrupted ({signal.Signals(signum).name}): stopped between two steps; "
                             "finished results were kept")
    assert "interrupted" in out  # the metrics table says how far the run got
    _verify(target)
    assert leftovers(tmp_path) == [] and sorted(p.name for p in tmp_path.glob(".*")) == []


class _Lines:
    """The lines a running command has printed on stdout so far (read by a thread), for ``signal_when``."""

    def __init__(self, proc: subprocess.Popen):
        self.proc, self.lines = proc, []
        self.thread = threading.Thread(target=lambda: self.lines.extend(proc.stdout), daemon=True)
        self.thread.start()

    def seen(self, text: str):
        return lambda: any(text in line for line in list(self.lines))

    def communicate(self, timeout: float):
        try:
            self.proc.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            self.proc.kill()  # a hang fails the test and leaves no process behind
            raise
        self.thread.join(timeout)
        return "".join(self.lines), self.proc.stderr.read()


def test_sigterm_keeps_reproduces_finished_runs(fmu_dir, tmp_path):
    out_dir = tmp_path / "out"
    proc = start(["reproduce", "--stop-time", "30", "--out", str(out_dir), "--recording", str(tmp_path / "all.rrd"),
                  "--fmu-dir", str(fmu_dir)], tmp_path)
    lines = _Lines(proc)  # the signal comes once a run has finished (it came after 3-5 s: too early under load)
    proc.communicate = lines.communicate
    code, out, err = signal_when(proc, lines.seen("reproduce: 1/"), signal.SIGTERM)
    assert code == 143, err
    assert "interrupted (SIGTERM)" in one_line(err)
    table = (out_dir / "table1.md").read_text()
    assert "this run" in table  # the runs that finished are in the table
    _verify(tmp_path / "all.rrd")
    assert leftovers(tmp_path) == []


def test_sigterm_stops_a_sweep_keeps_its_points_and_its_temporary_folders_go(fmu_dir, tmp_path):
    out = tmp_path / "sweep"
    proc = start(["sweep", "paper", "--set", "plant.phi1_0=0.1,0.2,0.3,0.4,0.5,0.6,0.7,0.8", "--stop-time", "20",
                  "--workers", "1", "--record", "--out", str(out), "--fmu-dir", str(fmu_dir)], tmp_path)
    jsonl = out / "points.jsonl"
    code, stdout, err = signal_when(proc, lambda: jsonl.is_file() and jsonl.read_text().count("\n") >= 1,
                                    signal.SIGTERM)
    assert code == 143, err
    assert "interrupted (SIGTERM)" in one_line(err) and "resume with" in stdout
    rows = jsonl.read_text().splitlines()
    assert 1 <= len(rows) < 8
    for rrd in (out / "points").glob("*.rrd"):
        _verify(rrd)
    assert leftovers(tmp_path) == []  # no point's temporary folder, no run's unpacked FMUs


def _loaded(proc: subprocess.Popen, library: str):
    """True once ``library`` is mapped into the process: a moment inside its imports."""
    def ready() -> bool:
        try:
            return library in Path(f"/proc/{proc.pid}/maps").read_text()
        except OSError:
            return False
    return ready


def test_a_signal_during_the_imports_stops_the_command_in_one_line(tmp_path):
    """The handlers come first: a SIGTERM while the command still imports its libraries (8 s under
    load) killed it silently (exit -15)."""
    if not Path("/proc/self/maps").is_file():
        pytest.skip("no /proc/PID/maps here to see the imports happen")
    proc = start(["run", "paper", "--stop-time", "1", "--no-recording", "--fmu-dir", "fmus"], tmp_path)
    code, out, err = signal_when(proc, _loaded(proc, "numpy"), signal.SIGTERM)
    assert code == 143, (code, err)
    assert one_line(err) == "sotc-cosim: interrupted (SIGTERM): stopped before anything ran"
    assert not (tmp_path / "fmus").exists() and leftovers(tmp_path) == []


SLOW_PARSE = """import sys, time, tomllib
def slow(text):
    print("parsing", flush=True)
    time.sleep(600)
tomllib.loads = slow
from orchestration.cli import main
sys.exit(main(sys.argv[1:]))
"""


def test_sigterm_during_a_slow_parse_exits_143(tmp_path):
    """A parse the bounds let through but that takes long (a big file on a slow machine; here tomllib
    made to sleep): the signal ends it at once (it was deferred until the parse ended)."""
    (tmp_path / "big.toml").write_text("[run]\nstop_time = 1.0\n")
    proc = subprocess.Popen([sys.executable, "-c", SLOW_PARSE, "run", "big.toml", "--fmu-dir", "fmus"], cwd=tmp_path,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env_for(tmp_path))
    lines = _Lines(proc)
    proc.communicate = lines.communicate
    code, out, err = signal_when(proc, lines.seen("parsing"), signal.SIGTERM, timeout=120)
    assert code == 143, (code, err)
    assert "interrupted (SIGTERM)" in one_line(err)
    assert not (tmp_path / "fmus").exists() and leftovers(tmp_path) == []
