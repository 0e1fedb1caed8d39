"""A full disk, a file-size limit, a read-only folder, two writers of one path: each command ends
with one line naming the path and the errno (exit 1), or refuses before running (exit 2); nothing
hangs (every child runs under a time limit), nothing partial is left where results go."""
from __future__ import annotations

import json

import pytest

from support.cli import leftovers, one_line, run, start

SHORT = ["--stop-time", "20"]  # about 1.8 MB of recording: more than the 1 MB disk, more than 1 MB of limit


def test_a_full_disk_ends_a_recorded_run_in_one_line(full_disk, fmu_dir, tmp_path):
    proc = run(["run", "paper", *SHORT, "--recording", str(full_disk / "r.rrd"), "--fmu-dir", str(fmu_dir)], tmp_path)
    assert proc.returncode == 1
    assert one_line(proc.stderr) == f"sotc-cosim: error: cannot write {full_disk / 'r.rrd'}: [Errno 28] No space left on device"
    assert list(full_disk.iterdir()) == [] and leftovers(tmp_path) == []


@pytest.mark.parametrize("command", ["summary", "reproduce"])
def test_a_full_disk_ends_other_outputs_in_one_line_and_keeps_nothing_partial(command, full_disk, fmu_dir, tmp_path):
    with open(full_disk / "filler", "wb", buffering=0) as f:  # fill the disk to the last byte
        try:
            while f.write(b"\0" * 4096):
                pass
        except OSError:
            pass
    if command == "summary":
        args = ["run", "paper", "--stop-time", "1", "--no-recording", "--summary", str(full_disk / "s.json")]
    else:
        args = ["reproduce", "--stop-time", "0.5", "--out", str(full_disk / "out"), "--recording", str(tmp_path / "r.rrd")]
    proc = run([*args, "--fmu-dir", str(fmu_dir)], tmp_path)
    assert proc.returncode == 1, proc.stderr
    assert "[Errno 28] No space left on device" in one_line(proc.stderr)
    written = sorted(p.name for p in full_disk.rglob("*") if p.is_file())
    assert written == ["filler"] and leftovers(tmp_path) == []


def test_a_file_size_limit_ends_a_recorded_run_in_one_line(fmu_dir, tmp_path):
    target = tmp_path / "out" / "r.rrd"
    target.parent.mkdir()  # a file output's folder must exist (tests/orchestration/test_cli_refusals.py)
    proc = run(["run", "paper", *SHORT, "--recording", str(target), "--fmu-dir", str(fmu_dir)], tmp_path,
               limit_bytes=1024 * 1024)
    assert proc.returncode == 1
    assert one_line(proc.stderr) == f"sotc-cosim: error: cannot write {target}: [Errno 27] File too large"
    assert list((tmp_path / "out").iterdir()) == [] and leftovers(tmp_path) == []


@pytest.mark.parametrize("option", ["--recording", "--summary", "--fmu-dir"])
def test_a_read_only_folder_is_refused_before_anything_runs(option, read_only, fmu_dir, tmp_path):
    target = read_only / ("fmus" if option == "--fmu-dir" else "x.out")
    args = ["run", "paper", "--stop-time", "1", option, str(target)]
    proc = run(args + ([] if option == "--fmu-dir" else ["--fmu-dir", str(fmu_dir)]), tmp_path)
    assert proc.returncode == 2
    assert "Read-only file system" in one_line(proc.stderr) and option in proc.stderr


def test_a_second_writer_of_one_recording_is_refused_and_the_first_finishes(fmu_dir, tmp_path):
    target = tmp_path / "shared.rrd"
    # long enough that the second starts while the first still writes (30 s took under a second compiled)
    args = ["run", "paper", "--stop-time", "300", "--recording", str(target), "--fmu-dir", str(fmu_dir)]
    first = start(args, tmp_path)
    lock = tmp_path / ".shared.rrd.lock"
    try:
        for _ in range(4800):  # at most 240 s: a loaded CI machine can take that long to start a run
            if lock.exists() or first.poll() is not None:
                break
            __import__("time").sleep(0.05)
        second = run(args, tmp_path)
    finally:
        out, err = first.communicate(timeout=240)
    assert second.returncode == 2
    assert "another sotc-cosim is writing it now" in one_line(second.stderr)
    assert first.returncode == 0, err
    assert target.is_file() and not lock.exists()


def test_a_second_sweep_into_one_folder_is_refused(fmu_dir, tmp_path):
    out = tmp_path / "sweep"
    (out).mkdir()
    (out / ".sotc-cosim.lock").touch()
    import fcntl
    import os

    fd = os.open(out / ".sotc-cosim.lock", os.O_RDWR)
    fcntl.flock(fd, fcntl.LOCK_EX)  # another sweep holds the folder
    try:
        proc = run(["sweep", "paper", "--set", "controller.rho=3,4", "--stop-time", "0.5", "--out", str(out),
                    "--fmu-dir", str(fmu_dir)], tmp_path)
    finally:
        os.close(fd)
    assert proc.returncode == 2
    assert "--out" in one_line(proc.stderr) and "another sotc-cosim is writing it now" in proc.stderr
    assert not (out / "points.jsonl").exists()


def test_the_summary_is_written_whole(fmu_dir, tmp_path):
    target = tmp_path / "s.json"
    proc = run(["run", "paper", "--stop-time", "1", "--no-recording", "--summary", str(target), "--fmu-dir",
                str(fmu_dir)], tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert json.loads(target.read_text())["status"] == "ok"
    assert sorted(p.name for p in tmp_path.iterdir() if p.name.startswith(".")) == []
