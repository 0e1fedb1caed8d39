"""Temporary folders named after the process that owns them, so that a later command can remove
the ones whose owner is gone (killed with SIGKILL, or by a power cut: nothing of it could clean up).

A name holds ``<host>-<pid>-<unique>``; only folders of this host whose process no longer exists
are removed (a sweep's scratch is also used by workers on other machines of a remote cluster, where
that pid means nothing).
"""
from __future__ import annotations

import os
import shutil
import socket
import tempfile
import time
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator


def _host() -> str:
    return socket.gethostname().replace("-", "_") or "host"


def scratch_name(prefix: str = "") -> str:
    """A new folder name owned by this process: ``<prefix><host>-<pid>-<ns>``."""
    return f"{prefix}{_host()}-{os.getpid()}-{time.time_ns()}"


def owner_prefix(prefix: str) -> str:
    """What ``tempfile.mkdtemp(prefix=...)`` gets so that the folder names this process as its owner."""
    return f"{prefix}{_host()}-{os.getpid()}-"


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's process: alive
        return True
    return True


def owner_gone(name: str, prefix: str = "") -> bool:
    """Whether the folder ``name`` (made by ``scratch_name`` or ``owner_prefix``) belongs to a
    process of this host that no longer runs."""
    if not name.startswith(prefix):
        return False
    parts = name[len(prefix):].split("-")
    if len(parts) < 3 or parts[0] != _host() or not parts[1].isdigit():
        return False
    return int(parts[1]) != os.getpid() and not _alive(int(parts[1]))


def remove_stale(folder: Path, prefix: str = "") -> list[Path]:
    """Remove the folders under ``folder`` named ``<prefix>...`` whose owner process is gone."""
    removed = []
    try:
        entries = list(Path(folder).iterdir())
    except OSError:
        return removed
    for entry in entries:
        if entry.is_dir() and not entry.is_symlink() and owner_gone(entry.name, prefix):
            shutil.rmtree(entry, ignore_errors=True)
            removed.append(entry)
    return removed


@contextmanager
def owned_tempdir(prefix: str) -> Iterator[Path]:
    """A folder ``$TMPDIR/<prefix><host>-<pid>-...`` that is ``tempfile``'s default folder while active, so
    that every temporary file of the code inside, and of the libraries it calls, goes there; removed after.
    First the folders of that prefix whose owner process is gone (a SIGKILL) are removed."""
    root = Path(tempfile.gettempdir())
    remove_stale(root, prefix)
    folder = Path(tempfile.mkdtemp(prefix=owner_prefix(prefix), dir=root))
    previous, tempfile.tempdir = tempfile.tempdir, str(folder)
    try:
        yield folder
    finally:
        tempfile.tempdir = previous
        shutil.rmtree(folder, ignore_errors=True)
