"""The benchmark's loop (``foreign_loop``) in a child process that serves many runs: a foreign controller FMU
that crashes, exits, hangs or refuses fails only its own run, and the FMU is still loaded once per child and
reset between runs (issues 48 and 49).

``ForeignHost`` starts one child as ``orchestration.run.isolated`` starts its own (``orchestration.run.child``:
a fresh interpreter, SIGKILL when the parent dies, a header in shared memory that the child's ``ForeignLoop``
keeps at the sample and the FMI call under way). The child loads the FMU and answers each ``run`` with what a
trial needs: ``pure_loop.metrics`` of the run, the samples the actuator cut, the FMU's log records, and the
samples themselves only when asked. A run fails, the host going on with a new child at the next run, when:

- the child died of a signal or exited: ``crashed: SIGSEGV in fmi2DoStep of 'controller' at t = 1.00 s
  (sample 100)``, ``ended with exit code 3 in ...``, as ``isolated`` words it;
- nothing moved for ``answer_s`` seconds (``isolated.SETUP_S`` at least while the FMU is loaded): the child is
  killed, ``no answer in 1 s in fmi2DoStep of ...: the process was killed``;
- the run raised in the child (an FMI error, the arm's ``IntegrationError`` on a torque that is not a finite
  number): its reason as ``master.run`` words it; this child goes on (the next run resets the FMU);
- a signal the command defers (``orchestration.run.interrupt``) came: the child is killed at once (the loop
  does not stop between two steps), ``interrupted by SIGTERM in ...``, and the run is ``interrupted``.
"""
from __future__ import annotations

import inspect
import os
import socket
import subprocess
import time
from dataclasses import dataclass, field
from multiprocessing.connection import Connection
from pathlib import Path

from fmu_plant.paper_setting import TORQUE_LIMIT
from orchestration.run import child, interrupt, master
from orchestration.run.child import CALL, SAMPLE
from orchestration.run.isolated import ANSWER_S, GRACE_S, POLL_S, SETUP_S
from orchestration.run.parameter_check import model_description
from orchestration.study.foreign_loop import NAME, ForeignLoop, ForeignResult
from orchestration.study.pure_loop import metrics, steps

CALLS = child.calls([NAME])
_RUN = inspect.signature(ForeignLoop.run)  # the arguments a run takes, checked here before the child gets them
LOADING = "while the FMU was loaded and instantiated"
SETTING_UP = "during set-up (resetting the FMU, setting its parameters, initializing it)"


@dataclass
class HostedRun:
    """One run through the host: ``failed`` and its ``error``, else ``metrics`` (``pure_loop.metrics``) and
    ``cuts``; ``samples`` where they were asked for; ``logs``: the FMU's log records of the run (as far as the
    child could send them)."""

    failed: bool
    error: str | None = None
    metrics: dict[str, float] = field(default_factory=dict)
    cuts: int = 0
    samples: ForeignResult | None = None
    logs: list[master.LogRecord] = field(default_factory=list)
    interrupted: bool = False


# ---- the child ----

def _child_main() -> None:
    """The child's entry (``child.start``): load the FMU, then answer runs until the parent closes the socket."""
    sock, fd = child.attach()
    conn = Connection(sock)
    fmu_file, ports, bound = conn.recv()
    clock = child.SharedClock(child.header(fd), CALLS)
    try:
        loop = ForeignLoop(fmu_file, ports, bound, clock=clock)
    except Exception as exc:  # an FMU that cannot be loaded or does not have the ports
        conn.send(("refused", f"{type(exc).__name__}: {exc}"))
    else:
        conn.send(("ready",))
        while True:
            try:
                request = conn.recv()
            except (EOFError, OSError):  # the host closed
                break
            conn.send(_answer(loop, *request))
    os._exit(0)  # no finalisation: a foreign FMU's destructors have no say in the outcome


def _answer(loop: ForeignLoop, parameters: dict, arguments: dict, samples: bool, late_from: float) -> tuple:
    try:
        result = loop.run(parameters, samples=samples, **arguments)  # without samples, a trial's records only
    except Exception as exc:  # FMICallException, IntegrationError: this run fails, the loop resets at the next
        k = loop.clock.sample
        return "failed", master._describe_failure(exc, k, arguments["step"], max(k, 0), loop.logs), list(loop.logs)
    return "done", metrics(result, late_from), result.cuts, result if samples else None, list(loop.logs)


# ---- the parent ----

class ForeignHost:
    """The controller FMU ``fmu_file`` under the port map ``ports``, its torques bounded to ``bound``, in a
    child process (module docstring); ``run`` runs it from a point. ``runs`` counts the runs, ``restarts`` the
    children started after one was lost. A load that fails at the start raises ``ValueError``; close the host
    (or use it in a ``with``) to end its child."""

    def __init__(self, fmu_file: Path, ports: dict[str, str] | None = None, bound: float = TORQUE_LIMIT,
                 answer_s: float = ANSWER_S):
        if not answer_s > 0:
            raise ValueError(f"answer_s must be > 0, got {answer_s}")
        self.fmu_file, self.ports, self.bound, self.answer_s = Path(fmu_file).resolve(), ports, bound, answer_s
        self.fmi_version = model_description(self.fmu_file).fmiVersion
        self.runs = self.restarts = 0
        self.proc: subprocess.Popen | None = None
        self.closed, self.loading, self.step = False, False, 0.0
        error = self._start()
        if error is not None:
            raise ValueError(f"{fmu_file}: {error}")

    def _start(self) -> str | None:
        """A new child with the FMU loaded; why not, where it could not load it."""
        self.fd = child.shared_file("sotc-cosim-host")
        self.header = child.header(self.fd)
        self.header[SAMPLE] = -1
        ours, theirs = socket.socketpair()
        try:
            self.proc = child.start(__name__, "_child_main", (theirs.fileno(), self.fd))
        except BaseException:
            os.close(self.fd)
            ours.close()
            raise
        finally:
            theirs.close()
        self.conn = Connection(ours.detach())
        self.loading = True
        answer = self._request((self.fmu_file, self.ports, self.bound), max(self.answer_s, SETUP_S))
        self.loading = False
        if isinstance(answer, str):
            return answer
        if answer[0] == "refused":
            self._drop()
            return answer[1]
        return None

    def run(self, parameters: dict[str, float] | None = None, samples: bool = False, late_from: float = 50.0,
            **loop) -> HostedRun:
        """``ForeignLoop.run(parameters, **loop)`` in the child: its metrics (``pure_loop.metrics`` with
        ``late_from``) and cuts, its samples too if ``samples``; a failed ``HostedRun`` with the reason where
        the FMU crashed, exited, hung or refused. An argument ``ForeignLoop.run`` does not take, or a stop time
        that is no multiple of the step, raises here."""
        if self.closed:
            raise ValueError(f"{self.fmu_file}: the host was closed")
        arguments = _RUN.bind(None, parameters, **loop)
        arguments.apply_defaults()
        arguments = {k: v for k, v in arguments.arguments.items() if k not in ("self", "parameters", "samples")}
        steps(arguments["stop_time"], arguments["step"])
        self.runs += 1
        if self.proc is None:
            self.restarts += 1
            error = self._start()
            if error is not None:
                return HostedRun(True, error)
        self.step = arguments["step"]
        self.header[SAMPLE] = -1  # before the request: the child writes the header once it has it
        answer = self._request((parameters or {}, arguments, samples, late_from), self.answer_s)
        if isinstance(answer, str):
            return HostedRun(True, answer, interrupted=answer.startswith("interrupted by "))
        if answer[0] == "failed":
            return HostedRun(True, answer[1], logs=answer[2])
        return HostedRun(False, None, *answer[1:])

    def _request(self, message: tuple, limit: float) -> tuple | str:
        """The child's answer to ``message``, or why there is none (the child is gone then)."""
        try:
            self.conn.send(message)
        except OSError:  # the child is gone already: _follow says how it ended
            pass
        return self._follow(limit)

    def _follow(self, limit: float) -> tuple | str:
        last, since = None, time.monotonic()
        while True:
            if self.conn.poll(POLL_S):
                try:
                    return self.conn.recv()
                except (EOFError, ConnectionResetError):  # the child's end closed: it died
                    code = self.proc.wait()
                    where = self._where()
                    self._drop()
                    return f"{child.ending(code)} {where}"
            now, progress = time.monotonic(), tuple(self.header)
            if interrupt.requested():
                where = self._where()
                self._drop()
                return f"interrupted by {interrupt.signal_name()} {where}: the process was killed"
            if progress != last:
                last, since = progress, now
            elif now - since > limit:
                where = self._where()
                self._drop()
                return f"no answer in {limit:g} s {where}: the process was killed"

    def _where(self) -> str:
        k, code = int(self.header[SAMPLE]), int(self.header[CALL])
        if k < 0:
            return LOADING if self.loading else SETTING_UP
        if code < 1:
            return child.at(k, self.step)
        name, kind = CALLS[code - 1]
        return child.in_call(name, kind, self.fmi_version, k, self.step)

    def _drop(self) -> None:
        """The child killed (its process group) and reaped, its socket and shared file closed."""
        child.kill(self.proc)
        self.conn.close()
        os.close(self.fd)  # the header's map goes with the array that holds it
        self.proc = None

    def close(self) -> None:
        """The child told to end (its socket closed), and killed if it has not ended within ``GRACE_S``."""
        self.closed = True
        if self.proc is not None:
            self.conn.close()
            try:
                self.proc.wait(GRACE_S)
            except subprocess.TimeoutExpired:
                pass
            child.kill(self.proc)
            os.close(self.fd)
            self.proc = None

    def __enter__(self) -> "ForeignHost":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

