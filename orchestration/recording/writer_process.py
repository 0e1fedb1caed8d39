"""The recordings of ``sotc-cosim run`` written by a child process, so that importing Rerun (most of
a short run's start-up) overlaps with the parent loading the FMUs and simulating.

``WriterProcess`` forks at once (the parent has imported the command line's light modules only, neither
numpy nor Rerun, so both processes import numpy side by side; a process that has imported Rerun already,
whose Rerun may have started threads, writes its recordings itself); the child imports ``recording.writer`` and then serves ``RunRecorder`` calls
sent over a pipe. ``ChildRecorder`` is the parent's ``RunObserver``: each call is sent to the child (a block's
samples through shared memory, ``SharedBlocks``). Opening the file and ``start`` are not waited for (the
FMUs load meanwhile). A block is handed over and the run goes on while the child writes it; right after
the next block is handed over, the child's answer to this one is read, so the child is one block behind
at most. ``finish`` and closing wait for every answer. The child's errors come back as they were raised
(a full disk is the same ``OutputError``, with the next block or the end of the run; an error while
opening or starting, with the first block); once its recorder failed, the child answers every later
call but closing with that same failure without attempting it. Each answer carries the child's own
(elapsed) time for that call (``WriterProcess.seconds``). The parent holds the lock.

Signals: the child ignores SIGINT, SIGTERM and SIGHUP (a terminal's Ctrl-C reaches both): the parent
stops between two steps, finishes the recording through the child and then closes the pipe; the child
exits when the pipe closes, also when the parent died without closing it (the open recording is then
finalised with a "run aborted" event). A child that dies ends the run with one ``OutputError`` line
naming how it ended, and its temporary file is removed; it never leaves the parent waiting.
"""
from __future__ import annotations

import contextlib
import dataclasses
import errno
import mmap
import os
import signal
import sys
import time
from multiprocessing.connection import Pipe
from pathlib import Path
from types import SimpleNamespace

from orchestration.outputs import OutputError, PathLock, temporary_path
from orchestration.run.interrupt import SIGNALS

class _Described:
    """An error of the parent as the child's ``RunRecorder.close`` reports it (its repr)."""

    def __init__(self, text: str):
        self.text = text

    def __repr__(self) -> str:
        return self.text


class SharedBlocks:
    """Blocks of samples handed to the child through memory both processes share (an anonymous mapping
    made before the fork: no file, gone with the processes) instead of pickled through the pipe, which
    cost over a microsecond a step. Two halves: the parent copies a block into one while the child may
    still be writing the block before it from the other (``ChildRecorder.block`` keeps one block unanswered
    at most, so the half written over has been answered for)."""

    HALF = 16 << 20  # bytes; a block larger than this (more samples or columns than MAX_BLOCK of paper) is pickled

    def __init__(self):
        self.memory = mmap.mmap(-1, 2 * self.HALF)  # MAP_SHARED: the forked child sees the same pages
        self.next = 0  # the half the next block goes to

    def put(self, rows: dict) -> list | None:
        """Copy ``rows`` (name -> array) into the next half; their layout, or None if they do not fit."""
        import numpy as np  # the parent has imported it long before its first block

        if sum(r.nbytes for r in rows.values()) > self.HALF:
            return None
        offset, layout = self.next * self.HALF, []
        self.next ^= 1
        for name, r in rows.items():
            np.ndarray(r.shape, r.dtype, self.memory, offset)[...] = r
            layout.append((name, offset, r.shape, r.dtype.str))
            offset += r.nbytes
        return layout

    def rows(self, layout: list) -> dict:
        """The child's views of a block ``put`` laid out (valid until its answer is sent)."""
        import numpy as np

        return {name: np.ndarray(shape, dtype, self.memory, offset) for name, offset, shape, dtype in layout}


def _serve(conn, shared: SharedBlocks) -> None:
    """The child: one ``RunRecorder`` at a time, driven by the parent's (operation, arguments)."""
    from orchestration.recording.writer import RunRecorder  # the import this process exists for

    recorder, failed = None, None  # failed: the recorder's first failure, the answer to every later call
    clock = time.perf_counter
    try:
        while True:
            op, args = conn.recv()
            began = clock()
            try:
                if op == "open":
                    recorder, failed = RunRecorder(*args), None
                    recorder.lock = PathLock(recorder.path, "recording")  # the parent holds it: never acquired here
                elif op == "close":
                    recorder.close(None if args[0] is None else _Described(args[0]))
                elif failed is not None:  # not attempted on a recorder that failed (its stream may be gone)
                    raise failed
                elif op == "shared_block":
                    recorder.block(args[0], shared.rows(args[1]))
                else:
                    getattr(recorder, op)(*args)
                answer = ("ok", None, clock() - began)
            except Exception as exc:  # sent back as it was raised
                answer = ("error", exc, clock() - began)
                if op != "close":
                    failed = failed or exc
            _answer(conn, answer)
    except (EOFError, OSError):  # the parent is gone (the pipe closed or broke): finish what it left open
        if recorder is not None:
            recorder.close(_Described("the command ended before the run did"))


def _answer(conn, answer: tuple) -> None:
    try:
        conn.send(answer)
    except OSError:
        raise
    except Exception:  # an exception that does not pickle: its type and message
        conn.send(("error", RuntimeError(f"{type(answer[1]).__name__}: {answer[1]}"), answer[2]))


class WriterGone(Exception):
    """The writer process ended (the message says how)."""


class WriterProcess:
    """The child that writes recordings (see the module docstring). ``close`` ends it and waits."""

    def __init__(self):
        sys.stdout.flush()
        sys.stderr.flush()
        self.conn, child_end = Pipe()
        self.shared = SharedBlocks()
        self.pid = os.fork()
        if self.pid == 0:  # the child never returns into the command's code
            code = 0
            try:
                for s in SIGNALS:
                    signal.signal(s, signal.SIG_IGN)
                self.conn.close()
                _serve(child_end, self.shared)
            except BaseException:
                code = 1
            finally:
                os._exit(code)
        child_end.close()
        self.sent: list[str] = []  # the operations sent whose answer was not read yet, oldest first
        self.seconds: dict[str, float] = {}  # per operation, the child's own time in the answers read
        self.ended: str | None = None  # how the child ended, once it did

    def call(self, op: str, *args, keep: int | None = 0):
        """Run ``op`` on the child's recorder, then read answers until at most ``keep`` are unread
        (None: read none now; the next call that reads collects them), raising the first exception
        the child sent back. ``WriterGone`` if the child is not there."""
        if self.ended is not None:
            raise WriterGone(self.ended)
        try:
            self.conn.send((op, args))
            self.sent.append(op)
            first = None
            while keep is not None and len(self.sent) > keep:
                kind, payload, spent = self.conn.recv()
                done = self.sent.pop(0)
                self.seconds[done] = self.seconds.get(done, 0.0) + spent
                first = first or (payload if kind == "error" else None)
        except (EOFError, OSError):
            raise WriterGone(self.died()) from None
        if first is not None:
            raise first

    def died(self) -> str:
        """How the child ended (reaped here), once its pipe broke."""
        if self.ended is None:
            self.conn.close()
            _, status = os.waitpid(self.pid, 0)
            self.ended = (f"was killed by {signal.Signals(os.WTERMSIG(status)).name}" if os.WIFSIGNALED(status)
                          else f"exited with {os.WEXITSTATUS(status)}")
        return self.ended

    def close(self) -> None:
        if self.ended is None:
            self.conn.close()  # the child sees the end of the pipe and exits
            os.waitpid(self.pid, 0)
            self.ended = "had ended"


@contextlib.contextmanager
def forked_writer():
    """A ``WriterProcess`` for the recordings of the block, closed after it; None where this process has
    imported Rerun already (a caller's process, whose Rerun may have started threads: not forked, the
    recordings are written in process)."""
    if "rerun" in sys.modules:
        yield None
        return
    writer = WriterProcess()
    try:
        yield writer
    finally:
        writer.close()


def recorder_for(path: Path, every: int, writer: WriterProcess | None):
    """The run's recorder of ``path``: written by ``writer`` (a ``ChildRecorder``), or in this process
    (a ``RunRecorder``, which imports Rerun) when there is none."""
    if writer is not None:
        return ChildRecorder(writer, path, every)
    from orchestration.recording.writer import RunRecorder

    return RunRecorder(path, every=every)


def _plain(result) -> SimpleNamespace:
    """A ``RunResult`` and its log records as plain namespaces: unpickling the master's classes would
    import the master, and fmpy with it, in the writer process."""
    values = {f.name: getattr(result, f.name) for f in dataclasses.fields(result)}
    values["logs"] = [SimpleNamespace(**vars(r)) for r in result.logs]
    return SimpleNamespace(**values, samples=result.samples)


class ChildRecorder:
    """``RunRecorder``'s interface (a ``RunObserver`` and context manager), written by ``writer``."""

    def __init__(self, writer: WriterProcess, path: Path, every: int = 1):
        self.writer, self.path, self.every = writer, Path(path), every
        self.lock: PathLock | None = None
        self.output_error: OutputError | None = None
        self.raised = False  # a call raised the child's failure already

    def _call(self, op: str, *args, keep: int | None = 0) -> None:
        try:
            self.writer.call(op, *args, keep=keep)
        except WriterGone as exc:
            temporary_path(self.path, self.writer.pid).unlink(missing_ok=True)
            self.output_error = OutputError(self.path, errno.EPIPE,
                                            f"the recording's writer (process {self.writer.pid}) {exc}")
            raise self.output_error from None
        except Exception as exc:
            if self.raised and op == "close":
                return  # the failure raised already, answered again for a later block (RunRecorder.close's rule)
            self.raised = True
            if isinstance(exc, OutputError):
                self.output_error = self.output_error or exc
            raise

    def start(self, scenario, columns, parameters=None) -> None:
        self._call("start", scenario, columns, parameters, keep=None)  # answered with the first block

    def block(self, time, rows) -> None:
        # written while the run goes on (the module docstring), which keeps one block unanswered at most
        # the half written over holds the block before the previous one, answered for by now
        assert sum(op.endswith("block") for op in self.writer.sent) <= 1, "a shared half still unanswered"
        layout = self.writer.shared.put(rows) if self.writer.ended is None else None
        if layout is None:
            self._call("block", time, rows, keep=1)
        else:
            self._call("shared_block", time, layout, keep=1)

    def finish(self, result) -> None:
        if self.output_error is None:  # after a failed write, or the writer's end: nothing more to write
            self._call("finish", _plain(result))

    def __enter__(self) -> "ChildRecorder":
        self.lock = PathLock(self.path, "recording").acquire()
        try:  # not waited for: the child may still be importing Rerun while the FMUs load
            self._call("open", self.path, self.every, keep=None)
        except BaseException:
            self.lock.release()
            raise
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        try:
            if self.writer.ended is None:  # the child finalises the file (its error comes back here)
                self._call("close", None if exc is None else repr(exc))
        finally:
            self.lock.release()
