"""Watching a recording live (``--connect [--url URL]``, ``--serve``: ``orchestration.recording.live``):
the file is written as without them, and a viewer that goes away mid-run stops nothing and loses nothing
in the file, said in one line. The viewer is a real Rerun gRPC server on the loopback."""
from __future__ import annotations

import shutil
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

from orchestration.cli import main
from support.cli import TIME_LIMIT, start

try:  # the viewer's own binary: the ``rerun`` script beside Python runs it as a child, which a kill leaves behind
    import rerun_cli

    RERUN = shutil.which("rerun", path=str(Path(rerun_cli.__file__).parent))
except ImportError:
    RERUN = None


FIRST_BLOCK = 700_000  # bytes: more than a whole 1 s recording of `paper` (565 kB), less than 10 s (1.4 MB)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _wait(ready, what: str) -> None:
    deadline = time.monotonic() + TIME_LIMIT
    while not ready():
        assert time.monotonic() < deadline, f"no {what} within {TIME_LIMIT} s"
        time.sleep(0.05)


def _answers(port: int) -> bool:
    try:
        socket.create_connection(("127.0.0.1", port), timeout=1).close()
        return True
    except OSError:
        return False


@pytest.mark.parametrize("argv, says", [
    (["run", "--url", "rerun+http://127.0.0.1:9876/proxy"], "--url is the viewer of --connect"),
    (["run", "--connect", "--url", "http://127.0.0.1:9876"], "is not a Rerun viewer's URL"),
    (["run", "--connect", "--no-recording"], "--no-recording"),
])
def test_a_live_option_that_cannot_work_is_refused_in_one_line(argv, says, capsys):
    with pytest.raises(SystemExit) as exited:
        code = main(argv)
        raise SystemExit(code)
    err = capsys.readouterr().err
    assert exited.value.code == 2 and len(err.strip().splitlines()) == 1 and says in err, err


def test_the_live_options_are_those_of_run_compare_and_reproduce(capsys):
    for command in ("run", "compare", "reproduce"):
        with pytest.raises(SystemExit):
            main([command, "-h"])
        text = capsys.readouterr().out
        assert all(o in text for o in ("--connect", "--url URL", "--serve")), (command, text)


@pytest.mark.skipif(RERUN is None, reason="rerun-sdk's rerun binary (rerun_cli) is not installed")
def test_a_viewer_that_goes_away_mid_run_stops_nothing_and_the_file_is_complete(fmu_dir, tmp_path):
    port = _free_port()
    server = subprocess.Popen([RERUN, "--serve-grpc", "--bind", "127.0.0.1", "--port", str(port)],
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        _wait(lambda: _answers(port), "viewer")
        proc = start(["run", "paper", "--stop-time", "60", "--recording", "r.rrd", "--fmu-dir", str(fmu_dir),
                      "--connect", "--url", f"rerun+http://127.0.0.1:{port}/proxy"], tmp_path)
        # mid-run: the first block of samples (10 s) is in the file being written, so the viewer was reached
        # (when the file was opened); the run is held while the viewer goes, so that it goes on after
        _wait(lambda: any(p.stat().st_size > FIRST_BLOCK for p in tmp_path.glob(".r.rrd.*.part"))
              or proc.poll() is not None, "recording")
        proc.send_signal(signal.SIGSTOP)  # the command; its writer process writes what it was handed
        if proc.poll() is not None or (tmp_path / "r.rrd").exists():
            proc.send_signal(signal.SIGCONT)
            proc.communicate(timeout=TIME_LIMIT)
            pytest.skip("the run ended before the viewer could go away mid-run")
    finally:
        server.kill()
        server.wait(timeout=TIME_LIMIT)
    proc.send_signal(signal.SIGCONT)
    out, err = proc.communicate(timeout=TIME_LIMIT)
    assert proc.returncode == 0, err
    said = [line for line in err.splitlines() if "live:" in line]
    assert len(said) == 1 and "went away" in said[0] and "r.rrd" in said[0], err
    assert "Traceback" not in err and "ERROR" not in err and "recording: r.rrd" in out, (out, err)
    verified = subprocess.run([RERUN, "rrd", "verify", str(tmp_path / "r.rrd")], capture_output=True, text=True,
                              timeout=TIME_LIMIT)
    assert verified.returncode == 0, verified.stderr
    from support.rrd_contents import read_entities

    rows = read_entities(tmp_path / "r.rrd")["/joints/phi1"]
    assert list(rows["step"]) == list(range(len(rows["step"]))), "a step is missing"
    assert rows["sim_time"][-1] == 60_000_000_000, rows["sim_time"][-3:]  # to the end of the run


_SERVE = """
import socket, sys, urllib.request
import rerun as rr
from orchestration.recording import live
grpc_port, web_port = map(int, sys.argv[2:])
live.ask(live.Live(serve=True, grpc_port=grpc_port, web_port=web_port))
from orchestration.recording.rrd_file import RecordingFile
f = RecordingFile(sys.argv[1], None)
f.stream.log("x", rr.Scalars([1.0]))
f.flush()
socket.create_connection(("127.0.0.1", grpc_port), timeout=5).close()
page = urllib.request.urlopen(f"http://127.0.0.1:{web_port}/", timeout=30)
f.close()
print("served", page.status)
"""


def test_serve_hosts_a_grpc_server_and_a_web_viewer_beside_the_file(tmp_path):
    grpc_port, web_port = _free_port(), _free_port()
    proc = subprocess.run([sys.executable, "-c", _SERVE, str(tmp_path / "s.rrd"), str(grpc_port), str(web_port)],
                          capture_output=True, text=True, timeout=TIME_LIMIT)
    assert proc.returncode == 0 and proc.stdout.split() == ["served", "200"], proc.stderr
    assert f"web viewer at http://127.0.0.1:{web_port}" in proc.stderr, proc.stderr
    if RERUN is not None:
        verified = subprocess.run([RERUN, "rrd", "verify", str(tmp_path / "s.rrd")], capture_output=True, text=True,
                                  timeout=TIME_LIMIT)
        assert verified.returncode == 0, verified.stderr
