"""SIGINT, SIGTERM and SIGHUP at seeded random moments of ``run``, ``reproduce`` and ``sweep``: the
command stops between two steps, exits with 128 + the signal's number, says so in one line, keeps
what finished (the recordings verify), and leaves no temporary folder behind."""
from __future__ import annotations

import random
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from support.cli import SIGNALS, exit_code_of, leftovers, one_line, signal_when, start

pytestmark = pytest.mark.slow  # full runs in subprocesses, signalled at random moments

RERUN = str(Path(sys.executable).with_name("rerun"))
PICKS = random.Random(19)  # the moments, reproducible


def _verify(path: Path) -> None:
    proc = subprocess.run([RERUN, "rrd", "verify", str(path)], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr


def _after(seconds: float):
    due = time.monotonic() + seconds
    return lambda: time.monotonic() >= due


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


def test_sigterm_keeps_reproduces_finished_runs(fmu_dir, tmp_path):
    out_dir = tmp_path / "out"
    proc = start(["reproduce", "--stop-time", "30", "--out", str(out_dir), "--recording", str(tmp_path / "all.rrd"),
                  "--fmu-dir", str(fmu_dir)], tmp_path)
    code, out, err = signal_when(proc, _after(PICKS.uniform(3.0, 5.0)), signal.SIGTERM)
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
