"""The child processes of ``validate``: the dependency experiment (``dependencies``) and the two runs
of the ``cores`` check (``core_paths``) each load and run the FMU in a fresh interpreter, so that an FMU
that crashes or hangs the process loading it is a finding, not the end of validate.

- The child prints ``READY`` once instantiating the FMU returned. One that has not said so within
  ``INSTANTIATE_LIMIT`` is killed: pythonfmu3 0.3.4's binary hangs for ever, holding Python's lock,
  when it cannot import the FMU's script, and validate waited ``TIME_LIMIT`` (10 minutes) per run for
  it. ``TIME_LIMIT`` bounds the whole run.
- A signal the command defers (``orchestration.run.interrupt``: Ctrl-C, SIGTERM, SIGHUP) is looked at
  while the child runs: the child's process group is killed at once and ``Stopped`` raised; the CLI
  then exits 128 + the signal (validate went on waiting for the child, up to 10 minutes per run).
- The child gets SIGTERM when validate dies (the parent-death signal of ``fmu_build.child``), and runs
  in a TMPDIR of its own under validate's scratch folder (``scratch.owned_tempdir``), so a crashed
  child's files go with it, and those of a validate killed with SIGKILL go with the next validate.
"""
from __future__ import annotations

import os
import signal
import struct
import subprocess
import sys
import tempfile
import threading
import time
import zipfile
from pathlib import Path

from orchestration.fmu_build.child import parent_death_signal, pump
from orchestration.run import interrupt

READY = "sotc-cosim: instantiation returned"  # the child's line once instantiating the FMU is over
INSTANTIATE_LIMIT = 30.0  # s from the child's start until it has said READY
TIME_LIMIT = 600.0  # s for one child run
POLL_S = 0.05


class ChildFailed(Exception):
    """The child gave no result: its message is the finding (a crash, a hang, an error); ``hung``: its
    instantiation did not return within ``INSTANTIATE_LIMIT``."""

    def __init__(self, finding: str, hung: bool = False):
        super().__init__(finding)
        self.hung = hung


class Stopped(interrupt.NothingRan):
    """A signal came while FMUs were checked (any child killed): validate gives no verdict."""


def check() -> None:
    """Raise ``Stopped`` if the command got a signal (call between checks)."""
    if interrupt.requested():
        raise Stopped("stopped while checking FMUs; no verdict was given")


def open_instance(fmu: Path, instance_name: str):
    """In the child: ``fmi3_direct.open_instance``, then ``READY`` said, whether it gave an instance or raised
    (a refused instantiation is a finding of the child's own)."""
    from orchestration.run.fmi3_direct import open_instance

    try:
        return open_instance(fmu, instance_name)
    finally:
        print(READY, flush=True)


def run(module: str, fmu: Path) -> list[str]:
    """The lines the child ``python -m MODULE FMU`` printed after ``READY``; ``ChildFailed`` naming why
    there are none; ``Stopped`` after a deferred signal."""
    with tempfile.TemporaryDirectory(prefix="sotc_child_") as tmp:
        cmd = [sys.executable, "-I", "-m", module, str(Path(fmu).resolve())]
        proc = subprocess.Popen(cmd, cwd=tmp, env={**os.environ, "TMPDIR": tmp}, stdout=subprocess.PIPE,
                                stderr=subprocess.PIPE, text=True, start_new_session=True,
                                preexec_fn=parent_death_signal)
        out: list[str] = []
        err: list[str] = []
        readers = [threading.Thread(target=pump, args=(proc.stdout, out.append), daemon=True),
                   threading.Thread(target=pump, args=(proc.stderr, err.append), daemon=True)]
        for reader in readers:
            reader.start()
        try:
            _wait(proc, out)
        finally:
            if proc.poll() is None:
                _kill(proc)
            for reader in readers:
                reader.join(timeout=5)
    if proc.returncode < 0:
        raise ChildFailed(crash_finding(fmu, proc.returncode))
    if proc.returncode != 0 or READY not in out:
        why = next((line.strip() for line in reversed(err) if line.strip()), f"exit {proc.returncode}")
        raise ChildFailed(f"the process that loaded and ran the FMU failed: {why}")
    return out[out.index(READY) + 1:]


def _kill(proc: subprocess.Popen) -> None:
    """The child's whole process group, then the child reaped."""
    try:
        os.killpg(proc.pid, signal.SIGKILL)
    except ProcessLookupError:  # ended in the meantime
        pass
    proc.wait()


def _wait(proc: subprocess.Popen, out: list[str]) -> None:
    """Until the child ends; raises ``Stopped`` or ``ChildFailed`` (the caller kills the child)."""
    started = time.monotonic()
    while True:
        try:
            proc.wait(timeout=POLL_S)
            return
        except subprocess.TimeoutExpired:
            pass
        check()
        elapsed = time.monotonic() - started
        if elapsed > INSTANTIATE_LIMIT and READY not in out:
            raise ChildFailed(f"instantiating the FMU did not return within {INSTANTIATE_LIMIT:g} s: the process "
                              "was killed", hung=True)
        if elapsed > TIME_LIMIT:
            raise ChildFailed(f"loading and running the FMU took over {TIME_LIMIT:g} s: the process was killed")


def _cut_short(path: Path) -> list[str]:
    """The shared libraries in the FMU (its binaries, its compiled cores) that end before their own ELF
    header says they do: truncated files, which the loader maps and then crashes on (SIGBUS)."""
    found = []
    with zipfile.ZipFile(path) as z:
        for info in z.infolist():
            with z.open(info) as f:
                head = f.read(64)
            if head[:4] != b"\x7fELF":
                continue
            wide = head[4:5] == b"\x02"
            order = "<" if head[5:6] == b"\x01" else ">"
            if len(head) < (64 if wide else 52):
                found.append(f"{info.filename} ({info.file_size} bytes, shorter than its ELF header)")
                continue
            offset = struct.unpack(order + ("Q" if wide else "I"), head[0x28:0x30] if wide else head[0x20:0x24])[0]
            size, count = struct.unpack(order + "HH", head[0x3A:0x3E] if wide else head[0x2E:0x32])
            if offset + size * count > info.file_size:
                found.append(f"{info.filename} ({info.file_size:,} bytes; its ELF header says at least "
                             f"{offset + size * count:,}: truncated)")
    return found


def crash_finding(path: Path, returncode: int) -> str:
    """What a child process that died of a signal while it loaded and ran the FMU at ``path`` found."""
    name = signal.Signals(-returncode).name if -returncode in signal.valid_signals() else f"signal {-returncode}"
    cut = _cut_short(path)
    if cut:
        return f"{'; '.join(cut)}: the loader crashed with {name}"
    return f"the FMU crashed the process that loaded and ran it with {name}"
