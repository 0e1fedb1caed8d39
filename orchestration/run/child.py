"""The child process that runs foreign code, as ``isolated`` (one scenario's run) and
``orchestration.study.foreign_host`` (many runs of one loaded FMU) start, watch and end it: a fresh
interpreter (fork and exec: the parent may hold threads) that gets SIGKILL from the kernel when the thread
that started it dies, a shared memory file (``memfd``, no file on disk) whose header says where the child is
(``master._Clock`` written through), and the words for how it ended."""
from __future__ import annotations

import ctypes
import mmap
import os
import signal
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from orchestration.run import master

PAGE = mmap.PAGESIZE  # the header's page; what a child shares besides (isolated: samples) follows it
SAMPLE, CALL, BASE, COUNT = range(4)  # the header: int64 each
KINDS = {"get": ("fmi2GetReal", "fmi3GetFloat64"), "set": ("fmi2SetReal", "fmi3SetFloat64"),
         "step": ("fmi2DoStep", "fmi3DoStep")}
_PR_SET_PDEATHSIG = 1


def start(module: str, entry: str, fds: tuple[int, ...]) -> subprocess.Popen:
    """``module.entry()`` in a fresh interpreter, in a session of its own, handed the file descriptors ``fds``:
    this package from where the parent has it (also when the parent found it in its working folder, which -P
    keeps off the child's path); argv = the package's folder, the parent's pid, ``fds`` (``attach`` reads it)."""
    program = (f"import sys; sys.path[:0] = [] if sys.argv[1] in sys.path else [sys.argv[1]]; "
               f"from {module} import {entry}; {entry}()")
    return subprocess.Popen([sys.executable, "-P", "-c", program, str(Path(__file__).resolve().parents[2]),
                             str(os.getpid()), *(str(fd) for fd in fds)],
                            pass_fds=fds, stdin=subprocess.DEVNULL, start_new_session=True)


def attach() -> list[int]:
    """In the child, first: SIGKILL when the parent dies (Linux), an exit if it died already; the fds given."""
    parent = int(sys.argv[2])
    if sys.platform.startswith("linux"):
        ctypes.CDLL(None).prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
    if os.getppid() != parent:  # the parent died before the line above
        os._exit(1)
    return [int(a) for a in sys.argv[3:]]


def shared_file(name: str) -> int:
    """A file of one page for the header, in memory (``memfd``) or, where there is none, already unlinked."""
    if hasattr(os, "memfd_create"):
        fd = os.memfd_create(name)
    else:
        with tempfile.TemporaryFile() as f:
            fd = os.dup(f.fileno())
    os.ftruncate(fd, PAGE)
    return fd


def header(fd: int) -> np.ndarray:
    return np.frombuffer(mmap.mmap(fd, PAGE), dtype=np.int64, count=4)


class SharedClock(master._Clock):
    """The master's clock, written through to the shared header; ``calls``: (instance, kind) of each call
    code from 1 on (``calls``)."""

    def __init__(self, header: np.ndarray, calls: list[tuple[str, str]]):
        self.header, self.calls = header, calls
        self.codes = {call: code for code, call in enumerate(self.calls, 1)}

    @property
    def sample(self) -> int:
        return int(self.header[SAMPLE])

    @sample.setter
    def sample(self, k: int) -> None:
        self.header[SAMPLE] = k

    @property
    def call(self) -> tuple[str, str]:
        code = int(self.header[CALL])
        return self.calls[code - 1] if code >= 1 else ("", "")

    @call.setter
    def call(self, value: tuple[str, str]) -> None:
        self.header[CALL] = self.codes[value]

    def marks(self, calls) -> tuple:
        """``master._Clock.marks``: the header's own memory (a memoryview: a mark is one item written, a third of
        an array's), the call codes."""
        return memoryview(self.header), SAMPLE, CALL, tuple(self.codes[c] for c in calls)


def calls(instances) -> list[tuple[str, str]]:
    """(instance, kind) for each call code from 1 on."""
    return [(name, kind) for name in instances for kind in KINDS]


def call_name(kind: str, fmi_version: str) -> str:
    """The FMI function of a call's kind: ``fmi2DoStep`` or, for an FMI 3.0 FMU, ``fmi3DoStep``."""
    return KINDS[kind][fmi_version.startswith("3")]


def in_call(name: str, kind: str, fmi_version: str, k: int, step: float) -> str:
    """Where a child was: ``in fmi2DoStep of 'controller' at t = 1.00 s (sample 100)``."""
    return f"in {call_name(kind, fmi_version)} of '{name}' {at(k, step)}"


def at(k: int, step: float) -> str:
    return f"at t = {k * step:.2f} s (sample {k})"


def kill(proc: subprocess.Popen) -> None:
    """The child's process group, then the child reaped."""
    try:
        os.killpg(proc.pid, signal.SIGKILL)
    except ProcessLookupError:
        pass
    proc.wait()


def ending(code: int) -> str:
    """How a child that ended with ``code`` (``Popen.returncode``) ended: ``crashed: SIGSEGV``, ``ended with
    exit code 3``."""
    if code < 0:
        name = signal.Signals(-code).name if -code in signal.valid_signals() else f"signal {-code}"
        return f"crashed: {name}"
    return f"ended with exit code {code}"
