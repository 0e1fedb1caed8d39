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


def lock_path(path: Path, folder: bool = False) -> Path:
    """Where the advisory lock on the output ``path`` lives (``outputs.PathLock``): ``.<name>.lock``
    beside a file, ``.sotc-cosim.lock`` inside a folder."""
    path = Path(path)
    return path / ".sotc-cosim.lock" if folder else path.with_name(f".{path.name}.lock")


def _check_entry(entry: Path, argument: str, path: Path, what: str = "") -> None:
    """An existing ``entry`` (``path`` itself, or ``what`` of it) that is a dangling link, or a file
    that cannot be written, is refused naming ``argument``."""
    if entry.is_symlink() and not entry.exists():
        raise OutputPathError(f"{argument} {path}: {what}is a link to {os.readlink(entry)}, which does not exist; "
                              "remove the link or give another path")
    if entry.is_file() and not os.access(entry, os.W_OK):
        raise OutputPathError(f"{argument} {path}: {what}is read-only; make it writable or give another path")


def _check_lock(path: Path, argument: str, folder: bool) -> None:
    lock = lock_path(path, folder)
    _check_entry(lock, argument, path, f"its lock file {lock} ")
    if lock.exists() and not lock.is_file():
        raise OutputPathError(f"{argument} {path}: its lock file {lock} is not a regular file; remove it")


def check_output_file(path: Path, argument: str, locked: bool = False) -> Path:
    """``path`` can be created or overwritten as a regular file (missing parent folders may be
    created later: the nearest existing one must be a folder we can write in), and so can its lock
    file (``locked``). Nothing is left behind."""
    path = Path(path)
    _check_entry(path, argument, path)
    if path.is_dir():
        raise OutputPathError(f"{argument} {path}: is a folder; give a file path")
    if path.exists() and not path.is_file():
        raise OutputPathError(f"{argument} {path}: exists and is not a regular file")
    _check_folder(path.parent, argument, path)
    if locked:
        _check_lock(path, argument, folder=False)
    return path


def check_output_folder(path: Path, argument: str, locked: bool = False) -> Path:
    """``path`` is, or can be created as, a folder we can write files in (and its lock file, ``locked``)."""
    path = Path(path)
    _check_entry(path, argument, path)
    if path.exists() and not path.is_dir():
        raise OutputPathError(f"{argument} {path}: exists and is not a folder")
    _check_folder(path, argument, path)
    if locked:
        _check_lock(path, argument, folder=True)
    return path


def _check_folder(folder: Path, argument: str, path: Path) -> Path:
    existing = folder.absolute()
    while not existing.exists():
        if existing.is_symlink():  # a folder to be created through a link to nowhere
            _check_entry(existing, argument, path, f"{existing} ")
        existing = existing.parent
    if not existing.is_dir():
        raise OutputPathError(f"{argument} {path}: {existing} is a file, not a folder")
    why = _probe_folder(existing)
    if why:
        raise OutputPathError(f"{argument} {path}: cannot write in {existing} ({why})")
    return path


DEFAULT_FMU_DIR = Path("build") / "fmus"  # where the FMUs are built and found, under the working folder
FMI_VERSIONS = (2, 3)  # ``--fmi``: FMI 2.0 (the default) or FMI 3.0, from the same sources


def fmu_folder(folder: Path, fmi: int, given: bool = False) -> Path:
    """Where the FMUs of an FMI version live: ``folder`` if the user gave it, else the default folder
    (FMI 3 in its ``fmi3`` subfolder, so that the two versions never rebuild each other's FMUs)."""
    return Path(folder) if given or fmi == 2 else Path(folder) / "fmi3"
