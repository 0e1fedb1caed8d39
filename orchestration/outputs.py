"""Writing results so that a failure loses nothing and a reader never sees half a file.

- ``atomic_write``: the content goes to a temporary file in the target folder, which is renamed into
  place once complete; on any error the temporary file is removed and the target is as it was.
- ``OutputError``: an output that could not be written (full disk, file-size limit, read-only or
  vanished folder, ...), naming the path and the errno; the CLI prints it on one line, exit 1.
- ``private_folder``: a folder under the temporary directory that only this user can reach (0700,
  checked), for caches and scratch space whose content is then run or trusted.
- ``PathLock``: an advisory lock (``fcntl.flock``) on an output path, so that two commands never
  write one recording or one sweep folder at once; the second gets a ``UsageError`` (exit 2).
"""
from __future__ import annotations

import errno
import fcntl
import os
import stat
import tempfile
from contextlib import contextmanager
from pathlib import Path
from typing import IO, Iterator

from orchestration.exit_codes import UsageError
from orchestration.paths import lock_path, temporary_path

class OutputError(Exception):
    """An output that could not be written: ``path`` and the ``errno`` of the failure."""

    def __init__(self, path: Path | str, err: int, detail: str = ""):
        self.path, self.errno, self.detail = Path(path), err, detail
        why = os.strerror(err) + (f": {detail}" if detail else "")
        super().__init__(f"cannot write {self.path}: [Errno {err}] {why}")

    def __reduce__(self):  # pickled as it was made (a recording's writer process sends it back)
        return type(self), (self.path, self.errno, self.detail)

    @classmethod
    def of(cls, path: Path | str, exc: OSError) -> "OutputError":
        return cls(path, exc.errno or errno.EIO, "" if exc.errno else str(exc))


@contextmanager
def atomic_file(path: Path | str, mode: str = "w") -> Iterator[IO]:
    """Open a temporary file beside ``path``; renamed to ``path`` when the block ends without error,
    removed otherwise. An OSError becomes ``OutputError`` naming ``path``."""
    path = Path(path)
    tmp = temporary_path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with open(tmp, mode, **({} if "b" in mode else {"encoding": "utf-8"})) as f:
            yield f
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except OSError as exc:
        tmp.unlink(missing_ok=True)
        raise OutputError.of(path, exc) from None
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def atomic_write(path: Path | str, content: str | bytes) -> Path:
    with atomic_file(path, "wb" if isinstance(content, bytes) else "w") as f:
        f.write(content)
    return Path(path)


def save_figure(fig, path: Path, dpi: int) -> Path:
    """A matplotlib figure written to a temporary PNG beside ``path`` and renamed into place, then closed."""
    import matplotlib.pyplot as plt

    tmp = path.with_name(f".{path.name}.part.png")
    fig.savefig(tmp, dpi=dpi)
    plt.close(fig)
    tmp.replace(path)
    return path


class PathLock:
    """An advisory lock on ``path`` held through ``.<name>.lock`` beside a file, or ``.sotc-cosim.lock``
    inside a folder (``folder=True``)."""

    def __init__(self, path: Path | str, what: str, folder: bool = False):
        path = Path(path)
        self.path, self.what = path, what
        self.file = lock_path(path, folder)
        self.fd: int | None = None

    def acquire(self) -> "PathLock":
        try:
            self.file.parent.mkdir(parents=True, exist_ok=True)
            fd = os.open(self.file, os.O_CREAT | os.O_RDWR | os.O_NOFOLLOW, 0o600)  # never a planted link's target
        except (IsADirectoryError, NotADirectoryError) as exc:
            raise UsageError(f"{self.what} {self.path}: its lock file {self.file} cannot be a file "
                             f"({exc.strerror}); remove what is there") from None
        except OSError as exc:
            if exc.errno == errno.ELOOP:
                raise UsageError(f"{self.what} {self.path}: its lock file {self.file} is a link; remove it") from None
            raise OutputError.of(self.file, exc) from None
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            os.close(fd)
            raise UsageError(f"{self.what} {self.path}: another sotc-cosim is writing it now "
                             f"(lock {self.file}); wait for it or choose another path") from None
        self.fd = fd
        return self

    def release(self) -> None:
        if self.fd is None:
            return
        try:
            self.file.unlink(missing_ok=True)
        except OSError:
            pass  # a read-only folder since: the lock file stays, the lock itself goes with the fd
        os.close(self.fd)
        self.fd = None

    def __enter__(self) -> "PathLock":
        return self.acquire()

    def __exit__(self, *exc) -> None:
        self.release()


def private_root(tmpdir: Path | str | None = None) -> Path:
    """Where this user's private folders live: ``<tmpdir>/sotc-cosim-<uid>`` (default: ``$TMPDIR``)."""
    return Path(tmpdir or tempfile.gettempdir()) / f"sotc-cosim-{os.getuid()}"


def private_folder(*parts: str) -> Path:
    """``private_root()/<parts>``, created 0700; refused (``OutputError``, EPERM) if the per-user root
    belongs to someone else or others can write or enter it."""
    root = private_root()
    try:
        root.mkdir(mode=0o700, exist_ok=True)
        st = os.lstat(root)
        if not stat.S_ISDIR(st.st_mode) or st.st_uid != os.getuid() or st.st_mode & 0o077:
            raise OutputError(root, errno.EPERM, "not a private folder of this user (owner, or 0700 mode): "
                                                 "remove it or set TMPDIR elsewhere")
        folder = root.joinpath(*parts)
        folder.mkdir(mode=0o700, parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputError.of(root, exc) from None
    return folder
