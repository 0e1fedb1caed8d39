"""Writing one .rrd file so that no failed write can block or be lost (see ``RecordingFile``)."""
from __future__ import annotations

import array
import fcntl
import os
import select
import termios
import threading
import time
import uuid
from pathlib import Path

import rerun as rr

from orchestration.outputs import OutputError, PathLock, temporary_path
from orchestration.recording import live

APPLICATION_ID = "sotc-cosim"
DRAIN_POLL = 0.0002  # s between looks at the pipe while a flush waits for the pump


class RecordingFile:
    """One .rrd being written, so that no failed write can block or be lost: Rerun's file sink writes
    into a pipe, and a thread of ours (``_Pump``) copies the pipe into a temporary file beside
    ``path``, which ``close`` renames into place; an advisory lock on ``path`` keeps a second writer
    out. Rerun's own writer, on a full disk, stops and leaves every later flush (and ``disconnect``)
    waiting for ever; ours records the error (path and errno), drops the rest of the stream, and
    ``flush``/``close`` raise it as ``OutputError`` at once. A live viewer asked for (``recording.live``)
    gets the same calls and blueprint through a stream of its own; its going away changes nothing here."""

    def __init__(self, path: Path, blueprint, lock: PathLock | None = None):
        self.path = Path(path)
        self.lock = lock or PathLock(self.path, "recording").acquire()
        self.failed = False
        try:
            self.pump = _Pump(self.path)
            self.stream = rr.RecordingStream(application_id=APPLICATION_ID, recording_id=str(uuid.uuid4()))
            self.stream.save(f"/dev/fd/{self.pump.write_end}", default_blueprint=blueprint)
            self.stream = live.stream(live.ASKED, self.stream, blueprint, self.path)  # also watched live, if asked
        except BaseException:
            self.lock.release()
            raise

    def flush(self) -> None:
        """Everything sent so far is in the (temporary) file; raise the pump's error, if it had one."""
        self.stream.flush()
        self.pump.drain()
        self._raise_failure()

    def _raise_failure(self) -> None:
        if self.pump.error is not None:
            self.failed = True
            raise self.pump.error

    def close(self) -> None:
        """Finish the file (footer) and rename it into place; after a failure, only stop the stream."""
        try:
            self.stream.disconnect()  # drops the file sink: writes the footer and closes its end of the pipe
            self.pump.finish()
            self._raise_failure()
        finally:
            self.lock.release()


class _Pump:
    """Copies what Rerun writes into the pipe to ``.<name>.<pid>.part`` beside ``path``; renamed to
    ``path`` by ``finish`` when complete. A write error is kept (``error``) and the rest drained."""

    def __init__(self, path: Path):
        self.path, self.tmp = path, temporary_path(path)
        self.error: OutputError | None = None
        self.busy = False  # between reading a piece from the pipe and having written it
        try:
            self.file = open(self.tmp, "wb", buffering=0)
        except OSError as exc:
            raise OutputError.of(path, exc) from None
        self.read_end, self.write_end = os.pipe()
        self.thread = threading.Thread(target=self._run, name=f"rrd-pump {path.name}", daemon=True)
        self.thread.start()

    def _run(self) -> None:
        while True:
            # at any moment the pipe holds data or ``busy`` is set, so ``drain`` cannot return early
            select.select([self.read_end], [], [])
            self.busy = True
            data = os.read(self.read_end, 1 << 20)
            if not data:
                break
            view = memoryview(data)
            while view and self.error is None:
                try:
                    view = view[self.file.write(view):]
                except OSError as exc:
                    self._drop(exc)
            self.busy = False
        os.close(self.read_end)

    def drain(self) -> None:
        """Wait until what is in the pipe now is written (or dropped after an error)."""
        pending = array.array("i", [0])
        while True:
            fcntl.ioctl(self.read_end, termios.FIONREAD, pending)
            if pending[0] == 0 and not self.busy:
                return
            time.sleep(DRAIN_POLL)

    def _drop(self, exc: OSError) -> None:
        self.error = OutputError.of(self.path, exc)
        try:
            self.file.close()
        except OSError:
            pass
        self.tmp.unlink(missing_ok=True)

    def finish(self) -> None:
        """After the stream let go of the pipe: wait for the rest, then close and rename the file."""
        os.close(self.write_end)
        self.thread.join()
        if self.error is not None:
            return
        try:
            self.file.flush()
            os.fsync(self.file.fileno())
            self.file.close()
            os.replace(self.tmp, self.path)
        except OSError as exc:
            self._drop(exc)
