"""Output paths checked before anything runs: a command that cannot write its result refuses at
once, naming the argument, instead of failing (with a traceback) after the work is done."""
from __future__ import annotations

import os
import tempfile
from pathlib import Path

from orchestration.exit_codes import UsageError


class OutputPathError(UsageError):
    """An output path that cannot be written; the message names the argument and why."""


def _probe_folder(folder: Path) -> str | None:
    """Why no file can be created in the existing ``folder``, or None (tries one, then removes it)."""
    try:
        fd, name = tempfile.mkstemp(dir=folder, prefix=".sotc-write-check-")
    except OSError as exc:
        return exc.strerror or type(exc).__name__
    os.close(fd)
    os.unlink(name)
    return None


def check_output_file(path: Path, argument: str) -> Path:
    """``path`` can be created or overwritten as a regular file (missing parent folders may be
    created later: the nearest existing one must be a folder we can write in). Nothing is left behind."""
    path = Path(path)
    if path.is_dir():
        raise OutputPathError(f"{argument} {path}: is a folder; give a file path")
    if path.exists() and not path.is_file():
        raise OutputPathError(f"{argument} {path}: exists and is not a regular file")
    return _check_folder(path.parent, argument, path)


def check_output_folder(path: Path, argument: str) -> Path:
    """``path`` is, or can be created as, a folder we can write files in."""
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise OutputPathError(f"{argument} {path}: exists and is not a folder")
    _check_folder(path, argument, path)
    return path


def _check_folder(folder: Path, argument: str, path: Path) -> Path:
    existing = folder.absolute()
    while not existing.exists():
        existing = existing.parent
    if not existing.is_dir():
        raise OutputPathError(f"{argument} {path}: {existing} is a file, not a folder")
    why = _probe_folder(existing)
    if why:
        raise OutputPathError(f"{argument} {path}: cannot write in {existing} ({why})")
    return path
