"""A run in a child process, for a scenario with an FMU from elsewhere (a foreign controller): a
SIGSEGV, an abort, an ``exit()`` or an endless loop inside the FMU ends that run, never the command.

``run`` has ``master.run``'s contract. The child (a fresh interpreter, started with fork and exec: the
parent may hold threads) runs ``master.run`` on the scenario and streams back, over a socket, the
observer's calls as they come: the parent hands them to its own observer (a recording in the parent
holds every sample up to a failure) and builds the result from them. Besides, the child keeps in a
shared memory file (``memfd``, no file on disk) where the run is (the sample, the instance and the
FMI call under way: ``master._Clock``) and the samples not yet sent, so that after the child died the
parent still has every sample before the fault and says where it happened:

- the child died of a signal or exited: ``crashed: SIGSEGV in fmi2DoStep of 'controller' at t = 1.00 s
  (sample 100)``, ``ended with exit code 3 in fmi2DoStep of ...``;
- nothing moved for ``answer_s`` seconds (``SETUP_S`` at least while the FMUs are loaded): the child is
  killed, ``no answer in 30 s in fmi2DoStep of 'controller' at t = ...``;
- an output that is not a finite number stops the run there: ``controller.tau1 is nan at t = 1.01 s
  (sample 101)``; an FMI error fails it as ``master.run`` does, with the FMUs' messages;
- a signal the command defers (``orchestration.run.interrupt``) is forwarded to the child, which stops
  between two steps as ``master.run`` does (killed after ``GRACE_S`` if it does not): the result is
  ``interrupted``. The child gets SIGKILL from the kernel when the thread that started it dies.
"""
from __future__ import annotations

import mmap
import os
import signal
import socket
import subprocess
import sys
import time
from multiprocessing.connection import Connection
from pathlib import Path
from typing import Sequence

import numpy as np

from orchestration.run import child, interrupt, master
from orchestration.run.child import BASE, CALL, COUNT, PAGE, SAMPLE
from orchestration.run.master import RunObserver, RunResult
from orchestration.run.parameter_check import model_description
from orchestration.run.scenario import Scenario, ScenarioError

ANSWER_S = 30.0  # s without progress before the child is killed
SETUP_S = 60.0  # s at least for loading, instantiating and initializing the FMUs (imports, unpacking)
GRACE_S = 5.0  # s for the child to stop after a forwarded signal
POLL_S = 0.05
ENDING = -1  # the call code once the last sample was recorded: terminating and freeing the FMUs


class _Tail:
    """The samples recorded and not yet sent, in the shared file after the header: (rows, columns)."""

    def __init__(self, fd: int, rows: int, columns: dict[str, list[str]], resize: bool):
        self.slices, lo = {}, 0
        for name, names in columns.items():
            self.slices[name] = slice(lo, lo + len(names))
            lo += len(names)
        size = rows * max(lo, 1) * 8
        if resize:
            os.ftruncate(fd, PAGE + size)
        self.map = mmap.mmap(fd, size, offset=PAGE)
        self.rows = np.frombuffer(self.map, dtype=float).reshape(rows, max(lo, 1))[:, :lo]

    def split(self, block: np.ndarray) -> dict[str, np.ndarray]:
        return {name: block[:, s] for name, s in self.slices.items()}


# ---- the child ----

class _Forward:
    """The child's observer: each sample into the shared tail (one at a time: ``block_size=1`` in the
    child's master), checked to be finite; a full tail sent to the parent."""

    def __init__(self, conn: Connection, fd: int, header: np.ndarray, rows: int, scenario: Scenario):
        self.conn, self.fd, self.header, self.capacity, self.scenario = conn, fd, header, rows, scenario
        self.count = self.base = 0
        self.nonfinite: str | None = None

    def start(self, scenario, columns, parameters) -> None:
        self.columns = columns
        self.tail = _Tail(self.fd, self.capacity, columns, resize=True)
        self.conn.send(("start", columns, parameters))

    def block(self, time, rows) -> None:
        for i in range(len(time)):
            k = self.base + self.count
            row = self.tail.rows[self.count]
            for name, s in self.tail.slices.items():
                row[s] = rows[name][i]
            if not np.isfinite(row).all():
                self.nonfinite = self._which(row, k)
                raise FloatingPointError(self.nonfinite)
            self.count += 1
            self.header[COUNT] = self.count
            if self.count == self.capacity:
                self.flush()
            if k == self.scenario.steps:
                self.header[CALL] = ENDING

    def _which(self, row: np.ndarray, k: int) -> str:
        name, variable, value = next((name, variable, value) for name, s in self.tail.slices.items()
                                     for variable, value in zip(self.columns[name], row[s]) if not np.isfinite(value))
        return (f"{name}.{variable} is {value} at t = {k * self.scenario.step_size:.2f} s (sample {k}): "
                "an output that is not a finite number stops the run")

    def flush(self) -> None:
        if self.count:
            self.conn.send(("block", self.tail.rows[:self.count].copy()))
            self.header[COUNT] = 0  # before BASE: a parent reading the two between them takes nothing twice
            self.base += self.count
            self.header[BASE] = self.base
            self.count = 0

    def finish(self, result) -> None:
        """The master's last call: the child sends the result itself."""


def _child_main() -> None:
    """The child's entry (``child.start``): the socket's and the shared file's fds in argv."""
    sock, fd = child.attach()
    conn = Connection(sock)
    scenario, fmu_paths, block_size = conn.recv()
    header = child.header(fd)
    forward = _Forward(conn, fd, header, block_size, scenario)
    with interrupt.signals_deferred():
        try:
            result = master.run(scenario, fmu_paths, forward, block_size=1, keep_samples=False,
                                clock=child.SharedClock(header, child.calls(scenario.instances)))
        except ScenarioError as exc:
            conn.send(("refused", str(exc)))
        else:
            forward.flush()
            if forward.nonfinite:
                result.error = forward.nonfinite
            conn.send(("result", result))
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(0)  # no finalisation: a foreign FMU's destructors have no say in the outcome any more


# ---- the parent ----

class _Parent:
    """The child's messages made into the observer's calls and the result."""

    def __init__(self, scenario: Scenario, fmu_paths: dict[str, Path], observer, keep_samples: bool, block_size: int,
                 fd: int, header: np.ndarray):
        self.scenario, self.observer, self.keep, self.fd, self.header = scenario, observer, keep_samples, fd, header
        self.fmu_paths, self.block_size = fmu_paths, block_size
        self.blocks: list[np.ndarray] = []
        self.count = 0
        self.tail: _Tail | None = None
        self.columns: dict[str, list[str]] = {}
        self.parameters: dict[str, dict[str, float]] = {}
        self.result: RunResult | None = None
        self.refused: str | None = None
        self.observer_error: str | None = None

    def take(self, message: tuple) -> None:
        kind = message[0]
        if kind == "start":
            self.columns, self.parameters = message[1], message[2]
            self.tail = _Tail(self.fd, self.block_size, self.columns, resize=False)
            self._observe("start", self.scenario, self.columns, self.parameters)
        elif kind == "block":
            self._add(message[1])
        elif kind == "result":
            self.result = message[1]
        else:
            self.refused = message[1]

    def _observe(self, method: str, *args) -> None:
        if self.observer is not None and self.observer_error is None:
            try:
                master._call_observer(getattr(self.observer, method), *args)
            except master._ObserverFailed as exc:
                self.observer_error = str(exc)

    def _add(self, block: np.ndarray) -> None:
        lo, hi = self.count, self.count + len(block)
        if self.keep:
            self.blocks.append(block)
        self.count = hi
        self._observe("block", np.arange(lo, hi, dtype=float) * self.scenario.step_size, self.tail.split(block))

    def recover(self, conn: Connection) -> None:
        """Once the child is dead: what it sent and was not read yet, then the samples it recorded and had not
        sent (in the shared tail)."""
        try:
            while conn.poll(0):
                self.take(conn.recv())
        except (EOFError, ConnectionResetError):
            pass
        if self.tail is not None and self.result is None:
            base, count = int(self.header[BASE]), int(self.header[COUNT])
            if self.count >= base and base + count > self.count:
                self._add(self.tail.rows[self.count - base:count].copy())

    def where(self) -> str:
        k, code = int(self.header[SAMPLE]), int(self.header[CALL])
        at = child.at(k, self.scenario.step_size)
        if k < 0:
            return "during set-up (loading, instantiating or initializing the FMUs)"
        if code == ENDING:
            return f"after the last sample ({at[3:]}), while the FMUs were terminated and freed"
        if code < 1:
            return at
        name, kind = child.calls(self.scenario.instances)[code - 1]
        inst = self.scenario.instances[name]
        path = self.fmu_paths.get(inst.fmu, inst.file)  # a file runs as itself, as master._Session.load takes it
        return child.in_call(name, kind, model_description(path).fmiVersion if path else "2.0", k,
                             self.scenario.step_size)

    def build(self, wall: float, error: str | None, interrupted: bool) -> RunResult:
        got = self.result
        if got is not None:
            error, interrupted = got.error, got.interrupted
        if self.observer_error:
            error = (error + "; " if error else "") + self.observer_error
        common = dict(failed=error is not None, error=error, interrupted=interrupted,
                      logs=got.logs if got else [], parameters=got.parameters if got else self.parameters,
                      fmus=got.fmus if got else {})
        if not self.keep:
            return RunResult(self.scenario, np.empty(0), {}, wall, completed=self.count, **common)
        width = sum(len(c) for c in self.columns.values())
        data = np.concatenate(self.blocks) if self.blocks else np.empty((0, width))
        outputs = {name: {v: part[:, i] for i, v in enumerate(self.columns[name])}
                   for name, part in (self.tail.split(data) if self.tail else {}).items()}
        return RunResult(self.scenario, np.arange(self.count, dtype=float) * self.scenario.step_size, outputs,
                         wall, **common)


def run(
    scenario: Scenario,
    fmu_paths: dict[str, Path],
    observer: RunObserver | Sequence[RunObserver] | None = None,
    block_size: int = 1000,
    keep_samples: bool = True,
    answer_s: float = ANSWER_S,
) -> RunResult:
    """``master.run`` in a child process: a crash, an exit or a hang of an FMU fails this run only, with
    every sample before it and a reason naming the FMI call, the instance and the time. A
    ``ScenarioError`` is raised as ``master.run`` raises it."""
    if block_size < 1:
        raise ScenarioError(f"block_size must be >= 1, got {block_size}")
    if not answer_s > 0:
        raise ScenarioError(f"answer_s must be > 0, got {answer_s}")
    if observer is not None and not hasattr(observer, "block"):
        observer = master._Fanout(observer)
    started = time.perf_counter()
    fd = child.shared_file("sotc-cosim-run")
    ours, theirs = socket.socketpair()
    proc = None
    try:
        header = child.header(fd)
        header[SAMPLE] = -1
        parent = _Parent(scenario, {m: Path(p).resolve() for m, p in fmu_paths.items()}, observer, keep_samples,
                         block_size, fd, header)
        proc = child.start(__name__, "_child_main", (theirs.fileno(), fd))
        theirs.close()
        conn = Connection(ours.detach())
        try:
            try:
                conn.send((scenario, parent.fmu_paths, block_size))
            except OSError:  # the child is gone already: _follow says how it ended
                pass
            error, interrupted = _follow(proc, conn, parent, answer_s)
        finally:
            conn.close()
    finally:
        ours.close()
        theirs.close()
        if proc is not None and proc.poll() is None:
            child.kill(proc)
        os.close(fd)  # the maps go with the objects that hold them
    if parent.refused is not None:
        raise ScenarioError(parent.refused)
    result = parent.build(time.perf_counter() - started, error, interrupted)
    if observer is not None:  # also after it failed, as master.run does
        observer.finish(result)
    return result


def hosted(scenario: Scenario) -> bool:
    """Whether ``scenario`` runs an FMU given as a file (a controller from any tool): such code is hostile
    until shown otherwise, so its runs go into a child process; our built FMUs run in this one."""
    return any(inst.file is not None for inst in scenario.instances.values())


def run_any(scenario: Scenario, fmu_paths: dict[str, Path], observer: RunObserver | Sequence[RunObserver] | None = None,
            block_size: int = 1000, keep_samples: bool = True, answer_s: float = ANSWER_S) -> RunResult:
    """The run every command makes: ``run`` (a child process) where the scenario is ``hosted``, else
    ``master.run`` in this process, at its speed."""
    if hosted(scenario):
        return run(scenario, fmu_paths, observer, block_size, keep_samples, answer_s)
    return master.run(scenario, fmu_paths, observer, block_size, keep_samples)


def _follow(proc: subprocess.Popen, conn: Connection, parent: _Parent, answer_s: float) -> tuple[str | None, bool]:
    """Until the child sent its result or ended; (error, interrupted) when it gave no result."""
    last, since, forwarded = None, time.monotonic(), None
    while True:
        if conn.poll(POLL_S):
            try:
                parent.take(conn.recv())
            except (EOFError, ConnectionResetError):  # the child's end closed: it died
                return _ended(proc, conn, parent)
            if parent.result is not None or parent.refused is not None:
                proc.wait()
                return None, False
            if parent.observer_error is not None:
                child.kill(proc)
                return None, False
            since = time.monotonic()  # the time in the observer is not the child's
        now = time.monotonic()
        if interrupt.requested() and forwarded is None:
            forwarded = now
            os.kill(proc.pid, interrupt.STATE.signum or signal.SIGINT)
        if forwarded is not None and now - forwarded > GRACE_S:
            return _stopped(proc, conn, parent)
        progress = tuple(parent.header)
        limit = answer_s if progress[SAMPLE] >= 0 else max(answer_s, SETUP_S)
        if progress != last:
            last, since = progress, now
        elif now - since > limit:
            where = parent.where()
            child.kill(proc)
            parent.recover(conn)
            return f"no answer in {limit:g} s {where}: the process was killed", False


def _ended(proc: subprocess.Popen, conn: Connection, parent: _Parent) -> tuple[str, bool]:
    code = proc.wait()
    where = parent.where()
    parent.recover(conn)
    if interrupt.requested():
        return f"interrupted by {interrupt.signal_name()} {where}", True
    return f"{child.ending(code)} {where}", False


def _stopped(proc: subprocess.Popen, conn: Connection, parent: _Parent) -> tuple[str, bool]:
    where = parent.where()
    child.kill(proc)
    parent.recover(conn)
    return f"interrupted by {interrupt.signal_name()} {where}: the process did not stop and was killed", True
