"""Acceptance of ``sotc-cosim sweep``: six short points on a 2-worker LocalCluster, one refused and
one over its time limit; Ctrl-C part-way keeps the finished points, the rerun resumes without
recomputing them, a second run gives identical tables, ``--record`` writes a .rrd per point.

The console script runs in a subprocess from a folder outside the repository (as a user runs it),
and receives SIGINT in its whole process group, as a terminal's Ctrl-C does. Nothing here depends
on speed: the time-limited point needs 5000 s of simulation, which takes far longer than its
4 s limit on any machine, and the interrupt is sent while that point is still running.
"""
import csv
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

from rerun.chunk import RrdReader

SWEEP = """
name = "tiny"
description = "six short points: one refused at initialization (a singular plant), one over its time limit"
scenario = "paper-ct"
stop_time = 1.0
combine = "paired"
time_limit = 4.0

[[axis]]
name = "controller.kp"
values = [25.0, 50.0, 75.0, 100.0, 200.0, 400.0]

[[axis]]
name = "stop_time"
values = [1.0, 5000.0, 1.0, 1.0, 2.0, 1.0]

# each value inside its declared range, but with p3 = 1 the plant's D(phi) is singular for some phi:
# the FMU refuses it at initialization (an out-of-range value would refuse the whole sweep up front)
[[axis]]
name = "plant.p3"
values = [0.242, 0.242, 1.0, 0.242, 0.242, 0.242]
"""
CLI = str(Path(sys.executable).with_name("sotc-cosim"))


def _sweep(tmp_path, fmu_dir, out, *extra):
    return [CLI, "sweep", str(tmp_path / "tiny.toml"), "--workers", "2", "--out", str(out), "--fmu-dir", str(fmu_dir), *extra]


def _lines(path):
    return path.read_text().splitlines() if path.is_file() else []


def test_sweep_interrupt_resume_determinism_and_recordings(fmu_dir, tmp_path):
    (tmp_path / "tiny.toml").write_text(SWEEP)
    first = tmp_path / "first"
    # 1. interrupted part-way: SIGINT to the process group once two points are stored
    proc = subprocess.Popen(_sweep(tmp_path, fmu_dir, first, "--record"), cwd=tmp_path, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, start_new_session=True)
    try:
        while len(_lines(first / "points.jsonl")) < 2 and proc.poll() is None:
            time.sleep(0.05)
        os.killpg(proc.pid, signal.SIGINT)
        out, err = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
    assert proc.returncode == 130, (out, err)
    kept = _lines(first / "points.jsonl")
    assert 2 <= len(kept) < 6
    assert f"resume with: sotc-cosim sweep {tmp_path / 'tiny.toml'} --out {first}" in out
    assert "Traceback" not in err
    assert all(json.loads(line)["index"] != 1 for line in kept)  # the time-limited point was still running

    # 2. the same command resumes: the stored points are kept as they were and not run again
    resumed = subprocess.run(_sweep(tmp_path, fmu_dir, first, "--record"), cwd=tmp_path, capture_output=True, text=True,
                             timeout=300)
    assert resumed.returncode == 1, resumed.stderr  # two points failed
    assert f"6 points, {len(kept)} already in" in resumed.stdout
    after = _lines(first / "points.jsonl")
    assert after[:len(kept)] == kept and len(after) == 6
    assert sorted(json.loads(line)["index"] for line in after) == list(range(6))  # none computed twice

    # 3. the table and the failure records
    with open(first / "points.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert [r["index"] for r in rows] == [str(i) for i in range(6)]
    assert [r["status"] for r in rows] == ["ok", "failed", "failed", "ok", "ok", "ok"]
    assert [float(r["controller.kp"]) for r in rows] == [25.0, 50.0, 75.0, 100.0, 200.0, 400.0]
    assert rows[1]["reason"] == "time limit of 4 s exceeded" and rows[1]["mse_1"] == ""
    assert "'p3'" in rows[2]["reason"] and "must exceed p3^2" in rows[2]["reason"]
    assert all(float(r["mse_1"]) > 0 and float(r["max_norm_tau"]) <= 4.0 + 1e-9 for r in rows if r["status"] == "ok")
    summary = (first / "summary.md").read_text()
    assert "6 of 6 points stored, 4 ok, 2 failed" in summary and "## Axis `controller.kp`" in summary
    assert (first / "plots" / "controller.kp.png").stat().st_size > 0
    overlay = {c.entity_path for c in RrdReader(first / "sweep.rrd").stream().to_chunks()}
    assert {f"/points/{i:04d}/e{j}" for i in (0, 3, 4, 5) for j in (1, 2)} <= overlay  # every finished point

    # 4. a per-point recording with a unique recording id and the point's parameters as properties
    stored = [json.loads(line) for line in after]
    recordings = {r["index"]: first / r["recording"] for r in stored if r["status"] == "ok"}
    assert sorted(recordings) == [0, 3, 4, 5]
    ids = set()
    for index, path in recordings.items():
        reader = RrdReader(path)
        ids |= {entry.recording_id for entry in reader.recordings()}
        props = [c for c in reader.stream().to_chunks() if c.entity_path == "/__properties/sweep_point"]
        values = props[0].to_record_batch().to_pylist()[0]
        assert values["controller/kp"] == [float(rows[index]["controller.kp"])]
    assert len(ids) == len(recordings)

    # 5. the same file and seed give identical tables in a fresh folder
    second = tmp_path / "second"
    again = subprocess.run(_sweep(tmp_path, fmu_dir, second), cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert again.returncode == 1, again.stderr
    assert (second / "points.csv").read_text() == (first / "points.csv").read_text()
    assert (second / "summary.md").read_text() == (first / "summary.md").read_text()
