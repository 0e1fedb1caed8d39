"""The one Dask setup of sweep, tune and optimum (``orchestration.sweep.cluster``): the same options,
no dashboard warning, scratch folders the stale cleanup knows, honest progress from the first line."""
from __future__ import annotations

import errno
import logging
import socket
import subprocess
import sys
import warnings
from pathlib import Path

import pytest

from orchestration.cli import main
from orchestration.outputs import private_folder
from orchestration.scratch import owner_prefix
from orchestration.sweep import cluster


def _refusal(argv: list[str], capsys) -> str:
    try:
        code = main(argv)
    except SystemExit as exc:  # argparse's refusal
        code = exc.code
    assert code == 2, argv
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1, lines
    return lines[0]


@pytest.mark.parametrize("command", [["sweep", "paper", "--set", "controller.rho=3"], ["tune"], ["optimum"]])
def test_workers_and_scheduler_mean_the_same_in_every_command(command, capsys):
    both = _refusal([*command, "--workers", "2", "--scheduler", "tcp://localhost:1"], capsys)
    assert "--scheduler: not allowed with argument --workers" in both
    bad = _refusal([*command, "--scheduler", "notanaddress"], capsys)
    assert "--scheduler notanaddress: not a Dask scheduler address" in bad
    assert "--workers" in _refusal([*command, "--workers", "0"], capsys)


def _hold_port(port: int) -> socket.socket | None:
    sock = socket.socket()
    try:
        sock.bind(("", port))
    except OSError as exc:
        sock.close()
        if exc.errno != errno.EADDRINUSE:
            raise
        return None  # already held by another program: the situation under test anyway
    sock.listen()
    return sock


def test_a_local_cluster_runs_tasks_with_no_dashboard_warning_and_leaves_no_scratch():
    held = _hold_port(8787)
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            opened = cluster.open_client(None, 1)
            scratch = private_folder("scratch") / opened.scratch
            futures = [opened.client.submit(pow, 2, n, pure=False) for n in range(3)]
            results: list[int] = []
            try:
                interrupted = cluster.follow(futures, lambda f: results.append(f.result()))
            finally:
                cluster.shutdown(opened, futures, False)
    finally:
        if held is not None:
            held.close()
    assert not interrupted and sorted(results) == [1, 2, 4]
    assert not [w for w in caught if "already in use" in str(w.message)]
    assert not scratch.exists()


def test_a_scratch_folder_of_a_killed_command_goes_at_the_next_start():
    """tune and optimum keep their files in ``cluster.scratch_folder()``; a SIGKILL leaves it behind."""
    child = ("import os, signal; from orchestration.outputs import private_folder; "
             "from orchestration.sweep.cluster import scratch_folder; "
             "print(private_folder('scratch') / scratch_folder(), flush=True); os.kill(os.getpid(), signal.SIGKILL)")
    proc = subprocess.run([sys.executable, "-c", child], capture_output=True, text=True, timeout=120)
    assert proc.returncode == -9, proc.stderr
    left = Path(proc.stdout.strip())
    assert left.is_dir()
    mine = cluster.scratch_folder()
    assert not left.exists()
    (private_folder("scratch") / mine).rmdir()


def test_tune_with_one_search_counts_one_running(tmp_path, capsys):
    from orchestration.cli.tune_commands import Listener
    from orchestration.sweep.tuning_jobs import TuneOutcome

    listener = Listener(tmp_path / "tuned.json", 2, None)
    listener.started(TuneOutcome(searches=1, trials_before=0), total=3)
    listener.trial("one")
    listener.close()
    assert "1 running" in capsys.readouterr().out


def test_optimum_says_what_it_does_before_the_long_first_steps(monkeypatch, capsys):
    pytest.importorskip("casadi", reason="CasADi is missing: pip install '.[optimum]' (the test extra has it)")
    from orchestration.study import optimum_scores
    from orchestration.sweep import optimum_jobs

    seen = {}

    def learned_weights():
        seen["before learning"] = capsys.readouterr().out
        return [0.0]

    def solve_states(indices, horizon, objective, learned, cold, workers, scheduler, listener):
        listener.submitted(len(indices))
        seen["after submitting"] = capsys.readouterr().out
        return optimum_jobs.OptimumOutcome(interrupted=True)

    monkeypatch.setattr(optimum_scores, "learned_weights", learned_weights)
    monkeypatch.setattr(optimum_jobs, "solve_states", solve_states)
    main(["optimum", "--states", "3", "--workers", "2"])
    assert "optimum: 3 initial states" in seen["before learning"]
    assert "the paper run learns" in seen["before learning"]
    assert "solving 3 states, 2 at a time" in seen["after submitting"]


def test_an_unreachable_scheduler_is_named_and_leaves_no_scratch(monkeypatch):
    """Only this process's folders count: other commands on the machine may make theirs meanwhile. (A second
    of retrying the refused connection instead of the command's ten: the same error, 9 s of the suite less.)"""
    monkeypatch.setattr(cluster, "CONNECT_TIMEOUT", "1s")

    def own() -> set:
        return set(private_folder("scratch").glob(owner_prefix("") + "*"))

    before = own()
    with pytest.raises(ValueError, match="--scheduler tcp://127.0.0.1:1: cannot reach a Dask scheduler"):
        cluster.open_client("tcp://127.0.0.1:1", None)
    assert own() <= before


class _Heard(logging.Handler):
    def __init__(self):
        super().__init__(logging.DEBUG)
        self.records: list[logging.LogRecord] = []

    def emit(self, record: logging.LogRecord) -> None:
        self.records.append(record)


def test_closing_the_cluster_we_own_prints_no_comm_closed_tracebacks():
    """1 small sweep in 5 ended with distributed's CommClosedError tracebacks on the terminal: the
    connections closing while the cluster stops, logged by the client, the scheduler and the workers.
    Here the closing logs them, as it did then; none reaches a handler, and the workers are told first."""
    from distributed.comm.core import CommClosedError

    logs = [logging.getLogger(name) for name in ("distributed.client", "distributed.core", "asyncio")]
    heard, sent = _Heard(), []

    def comm_closed(log: logging.Logger) -> None:
        try:
            raise CommClosedError("in <TCP (closed) ConnectionPool.heartbeat_worker>: Stream is closed")
        except CommClosedError:
            log.exception("Exception while handling op")

    class Client:
        def run(self, function):
            sent.append(function)

        def close(self, timeout):
            comm_closed(logs[0])
            comm_closed(logs[2])

    class Local:
        workers: dict = {}

        def close(self, timeout):
            comm_closed(logs[1])

    for log in logs:
        log.addHandler(heard)
    try:
        cluster.shutdown(cluster.Cluster(Client(), Local(), cluster.scratch_folder()), [], interrupted=False)
        assert heard.records == [] and sent == [cluster.quiet]
        comm_closed(logs[1])  # and after the shutdown, logging is as it was
        assert len(heard.records) == 1
    finally:
        for log in logs:
            log.removeHandler(heard)
