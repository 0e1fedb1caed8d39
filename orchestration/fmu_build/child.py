"""The build's child processes and signals: a build stops with the command that started it.

- The command (``run_child``) waits for its build child while polling, relays the child's progress
  lines as they come, and forwards SIGINT, SIGTERM and SIGHUP to it: sent to the command's PID alone
  (a batch system, ``kill PID``), the build stops within a second instead of after every FMU is built.
  It then raises ``BuildInterrupted``; the CLI says the build was stopped and exits 128 + the signal.
- The child (``stop_on_signals``) turns those signals into ``Stopped``, a ``BaseException``, so every
  ``with`` block unwinds: the Cython compile (its own process group) is killed, the ``sotc_stage_`` and
  ``sotc_cython_`` folders are removed, no FMU is half-written (``outputs.atomic_file``).
- ``die_with_parent``: if the command is killed with SIGKILL, the kernel sends its child SIGTERM
  (Linux's parent-death signal; elsewhere a thread watches the parent), so no build outlives the
  command to write FMUs into the folder later. The compile processes get the same signal from theirs.
- Folders are named after their owner process (``orchestration.scratch``): a later build removes
  those a killed build left behind.
"""
from __future__ import annotations

import ctypes
import os
import signal
import subprocess
import sys
import threading
import time
from contextlib import contextmanager
from typing import Callable, Iterator

SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)
_PR_SET_PDEATHSIG = 1
GRACE_S = 10.0  # a child that has not stopped this long after the signal is killed
POLL_S = 0.05


class Stopped(BaseException):
    """Raised in the build child by one of ``SIGNALS`` (a BaseException: nothing catches it on the way)."""

    def __init__(self, signum: int):
        super().__init__(f"stopped by {signal.Signals(signum).name}")
        self.signum = signum


# the C library this process runs on (it provides prctl), looked up once: a preexec_fn must not start programs
_LIBC = ctypes.CDLL(None, use_errno=True) if sys.platform.startswith("linux") else None


def parent_death_signal() -> bool:
    """Linux: SIGTERM to this process when its parent dies; False elsewhere. Safe in a ``preexec_fn``."""
    return _LIBC is not None and _LIBC.prctl(_PR_SET_PDEATHSIG, signal.SIGTERM, 0, 0, 0) == 0


def die_with_parent(parent: int) -> None:
    """Have SIGTERM sent to this process when its parent ``parent`` (a pid) dies, also if it died
    before this call (where the kernel cannot: a thread watching the parent)."""
    if parent_death_signal():
        if os.getppid() != parent:
            os.kill(os.getpid(), signal.SIGTERM)
        return

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(0.2)
        os.kill(os.getpid(), signal.SIGTERM)

    threading.Thread(target=watch, daemon=True, name="sotc-parent-watch").start()


def _raise_stopped(signum, frame) -> None:
    for s in SIGNALS:  # once: a second signal (the process group's and the forwarded one) must not
        signal.signal(s, signal.SIG_IGN)  # interrupt the clean-up the first one starts
    raise Stopped(signum)


@contextmanager
def stop_on_signals() -> Iterator[None]:
    """In the build child: ``SIGNALS`` raise ``Stopped`` (main thread only)."""
    previous = {s: signal.signal(s, _raise_stopped) for s in SIGNALS}
    try:
        yield
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)


def run_compiler(cmd: list[str], cwd, env: dict[str, str], timeout: float) -> subprocess.CompletedProcess:
    """Run the compile command in its own process group, which is killed whole (the C compilers it
    started included) when the build stops, fails or runs out of time."""
    proc = subprocess.Popen(cmd, cwd=cwd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True, preexec_fn=parent_death_signal)
    try:
        out, err = proc.communicate(timeout=timeout)
    except BaseException:
        try:
            os.killpg(proc.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
        proc.communicate()
        raise
    return subprocess.CompletedProcess(cmd, proc.returncode, out, err)


class BuildError(RuntimeError):
    """FMUs that cannot be built as asked (an unknown model, an unusable folder, a failed build): one line."""


class BuildInterrupted(Exception):
    """The command got ``signum`` while its build child ran; the child was stopped and cleaned up."""

    def __init__(self, signum: int):
        super().__init__(f"stopped by {signal.Signals(signum).name} while building FMUs")
        self.signum = signum


def pump(stream, sink: Callable[[str], None]) -> None:
    """Hand each line of ``stream`` (without its newline) to ``sink`` until it ends (a reader thread)."""
    for line in stream:
        sink(line.rstrip("\n"))


def run_child(cmd: list[str], cwd, on_line: Callable[[str], None]) -> tuple[int, list[str]]:
    """Run the build child; hand each line of its stdout to ``on_line`` as it comes; return its exit
    code and stderr lines. A signal of ``SIGNALS`` to this process is forwarded to the child, which
    is awaited (killed after ``GRACE_S``), and ``BuildInterrupted`` is raised; the handler in force
    before (the CLI's deferral) still sees the signal."""
    if threading.current_thread() is not threading.main_thread():  # no handlers there: wait plainly
        proc = subprocess.run(cmd, cwd=cwd, capture_output=True, text=True)
        for line in proc.stdout.splitlines():
            on_line(line)
        return proc.returncode, proc.stderr.splitlines()
    seen: list[int] = []
    previous: dict[int, object] = {}

    def forward(signum, frame) -> None:
        seen.append(signum)
        if callable(previous.get(signum)):
            previous[signum](signum, frame)

    proc = subprocess.Popen(cmd, cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    errors: list[str] = []
    readers = [threading.Thread(target=pump, args=(proc.stdout, on_line), daemon=True),
               threading.Thread(target=pump, args=(proc.stderr, errors.append), daemon=True)]
    for reader in readers:
        reader.start()
    try:
        previous.update({s: signal.signal(s, forward) for s in SIGNALS})
        _wait(proc, seen)
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)
        if proc.poll() is None:  # an exception here (KeyboardInterrupt outside the CLI): the child cleans up
            proc.terminate()
            try:
                proc.wait(timeout=GRACE_S)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
        for reader in readers:
            reader.join(timeout=5)
    if seen:
        raise BuildInterrupted(seen[0])
    return proc.returncode, errors


def _wait(proc: subprocess.Popen, seen: list[int]) -> None:
    forwarded = 0
    stop_by = None
    while proc.poll() is None:
        if len(seen) > forwarded:
            proc.send_signal(seen[forwarded])
            forwarded = len(seen)
            stop_by = stop_by or time.monotonic() + GRACE_S
        if stop_by is not None and time.monotonic() > stop_by:
            proc.kill()
        time.sleep(POLL_S)
