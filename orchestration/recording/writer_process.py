"""The recordings of ``sotc-cosim run`` written by a child process, so that importing Rerun (most of
a short run's start-up) overlaps with the parent loading the FMUs and simulating.

``WriterProcess`` forks at once (the parent has imported the command line's light modules only, neither
numpy nor Rerun, so both processes import numpy side by side; a process that has imported Rerun already,
whose Rerun may have started threads, writes its recordings itself); the child imports ``recording.writer`` and then serves ``RunRecorder`` calls
sent over a pipe. ``ChildRecorder`` is the parent's ``RunObserver``: each call is pickled to the child. Opening
the file and ``start`` are not waited for (the FMUs load meanwhile); every block, ``finish`` and
closing wait for all answers so far, so a block is in the file before the run goes on, as with an
in-process ``RunRecorder``, and the child's errors come back as they were raised (a full disk is the
same ``OutputError``; an error while opening, with the first block). The parent holds the lock.

Signals: the child ignores SIGINT, SIGTERM and SIGHUP (a terminal's Ctrl-C reaches both): the parent
stops between two steps, finishes the recording through the child and then closes the pipe; the child
exits when the pipe closes, also when the parent died without closing it (the open recording is then
finalised with a "run aborted" event). A child that dies ends the run with one ``OutputError`` line
naming how it ended, and its temporary file is removed; it never leaves the parent waiting.
"""
from __future__ import annotations

import dataclasses
import errno
import os
import signal
import sys
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


def _serve(conn) -> None:
    """The child: one ``RunRecorder`` at a time, driven by the parent's (operation, arguments)."""
    from orchestration.recording.writer import RunRecorder  # the import this process exists for

    recorder = None
    try:
        while True:
            op, args = conn.recv()
            try:
                if op == "open":
                    recorder = RunRecorder(*args)
                    recorder.lock = PathLock(recorder.path, "recording")  # the parent holds it: never acquired here
                elif op == "close":
                    recorder.close(None if args[0] is None else _Described(args[0]))
                else:
                    getattr(recorder, op)(*args)
                answer = ("ok", None)
            except Exception as exc:  # sent back as it was raised
                answer = ("error", exc)
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
        conn.send(("error", RuntimeError(f"{type(answer[1]).__name__}: {answer[1]}")))


class WriterGone(Exception):
    """The writer process ended (the message says how)."""


class WriterProcess:
    """The child that writes recordings (see the module docstring). ``close`` ends it and waits."""

    def __init__(self):
        sys.stdout.flush()
        sys.stderr.flush()
        self.conn, child_end = Pipe()
        self.pid = os.fork()
        if self.pid == 0:  # the child never returns into the command's code
            code = 0
            try:
                for s in SIGNALS:
                    signal.signal(s, signal.SIG_IGN)
                self.conn.close()
                _serve(child_end)
            except BaseException:
                code = 1
            finally:
                os._exit(code)
        child_end.close()
        self.unanswered = 0  # calls sent whose answer was not read yet
        self.ended: str | None = None  # how the child ended, once it did

    def call(self, op: str, *args, wait: bool = True):
        """Run ``op`` on the child's recorder. ``wait``: until the child has answered every call so
        far, raising the first exception it sent back; else the answer is collected by the next call
        that waits. ``WriterGone`` if the child is not there."""
        if self.ended is not None:
            raise WriterGone(self.ended)
        try:
            self.conn.send((op, args))
            self.unanswered += 1
            first = None
            while wait and self.unanswered:
                kind, payload = self.conn.recv()
                self.unanswered -= 1
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

    def _call(self, op: str, *args, wait: bool = True) -> None:
        try:
            self.writer.call(op, *args, wait=wait)
        except OutputError as exc:
            self.output_error = self.output_error or exc
            raise
        except WriterGone as exc:
            temporary_path(self.path, self.writer.pid).unlink(missing_ok=True)
            self.output_error = OutputError(self.path, errno.EPIPE,
                                            f"the recording's writer (process {self.writer.pid}) {exc}")
            raise self.output_error from None

    def start(self, scenario, columns, parameters=None) -> None:
        self._call("start", scenario, columns, parameters, wait=False)  # answered with the first block

    def block(self, time, rows) -> None:
        self._call("block", time, rows)

    def finish(self, result) -> None:
        if self.output_error is None:  # after a failed write, or the writer's end: nothing more to write
            self._call("finish", _plain(result))

    def __enter__(self) -> "ChildRecorder":
        self.lock = PathLock(self.path, "recording").acquire()
        try:  # not waited for: the child may still be importing Rerun while the FMUs load
            self._call("open", self.path, self.every, wait=False)
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
