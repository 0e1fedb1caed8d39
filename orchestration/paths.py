"""Output paths checked before anything runs: a command that cannot write its result refuses at
once, naming the argument, instead of failing (with a traceback) after the work is done.

A file output must be in an existing folder (a mistyped folder was created without a word), unless it
goes under ``recordings/``, the default place of every output, which is made as needed. A name too long for the file
system (with the temporary and lock files made beside it) is refused at once (it failed after the run,
exit 1). An existing file is replaced only if it is of the output's own kind (``OutputKind``: an SSP
archive, a ``.rrd``, a summary JSON ...), else only with ``--force`` (``export-ssp --out`` turned any file
into a zip)."""
from __future__ import annotations

import json
import os
import tempfile
import zipfile
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from orchestration.exit_codes import UsageError

OUTPUTS = Path("recordings")  # the default place of every output, under the working folder (made as needed)
PID_MAX = 2**22  # the largest process id Linux gives (/proc/sys/kernel/pid_max at most): in temporary names


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


def temporary_path(path: Path, pid: int | None = None) -> Path:
    """A hidden file beside ``path`` that only this process (or process ``pid``) writes."""
    return path.with_name(f".{path.name}.{os.getpid() if pid is None else pid}.part")


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


@dataclass(frozen=True)
class OutputKind:
    """What an output file holds, to tell a file sotc-cosim would write there (replaced) from any other
    (kept, unless ``--force``): ``name`` says what it is ("an SSP archive"), ``holds`` looks at a file."""
    name: str
    holds: Callable[[Path], bool]


def _readable(holds: Callable[[Path], bool]) -> Callable[[Path], bool]:
    def guarded(path: Path) -> bool:
        try:
            return holds(path)
        except (OSError, ValueError, zipfile.BadZipFile):
            return False
    return guarded


def json_kind(name: str, keys: tuple[str, ...]) -> OutputKind:
    """A JSON object with these keys."""
    def holds(path: Path) -> bool:
        data = json.loads(path.read_bytes())
        return isinstance(data, dict) and all(k in data for k in keys)
    return OutputKind(name, _readable(holds))


def zip_kind(name: str, member: str) -> OutputKind:
    """A zip archive holding ``member``."""
    def holds(path: Path) -> bool:
        with zipfile.ZipFile(path) as z:
            return member in z.namelist()
    return OutputKind(name, _readable(holds))


def magic_kind(name: str, magic: bytes) -> OutputKind:
    """A file that starts with ``magic``."""
    def holds(path: Path) -> bool:
        with open(path, "rb") as f:
            return f.read(len(magic)) == magic
    return OutputKind(name, _readable(holds))


def check_output_file(path: Path, argument: str, locked: bool = False, kind: OutputKind | None = None,
                      force: bool = False, within: Path | None = None) -> Path:
    """``path`` can be created or overwritten as a regular file, and so can its lock file (``locked``).
    Its folder must exist, unless it is under ``OUTPUTS`` or under ``within``, an output folder the
    command makes itself (both made as needed: the nearest existing folder must be one we can write in); its name, with the temporary and lock names made from
    it, must fit the file system; an existing file that is not empty must be of its ``kind``, unless
    ``force``. Nothing is left behind."""
    path = Path(path)
    _check_name(path, argument)  # first: a name too long fails every look at the path with ENAMETOOLONG
    _check_entry(path, argument, path)
    if path.is_dir():
        raise OutputPathError(f"{argument} {path}: is a folder; give a file path")
    if path.exists() and not path.is_file():
        raise OutputPathError(f"{argument} {path}: exists and is not a regular file")
    if not _under(path, OUTPUTS, within) and not path.parent.is_dir() and not path.parent.is_symlink():
        raise OutputPathError(f"{argument} {path}: the folder {path.parent} does not exist; create it first "
                              "(a file output's folder is not made for it)")
    _check_folder(path.parent, argument, path)
    if kind is not None and not force and path.is_file() and path.stat().st_size and not kind.holds(path):
        raise OutputPathError(f"{argument} {path}: exists and is not {kind.name}; give another path, or --force "
                              "to replace it")
    if locked:
        _check_lock(path, argument, folder=False)
    return path


def _under(path: Path, *folders: Path | None) -> bool:
    return any(Path(os.path.abspath(path)).is_relative_to(os.path.abspath(f)) for f in folders if f is not None)


def _check_name(path: Path, argument: str) -> None:
    """The names of ``path``, of the folders still to be made for it and of the temporary and lock files
    beside it fit the file system of its nearest existing folder."""
    existing = path.parent.absolute()
    while not os.path.exists(existing):  # False for a name too long, as for a missing one
        existing = existing.parent
    extra = max(len(temporary_path(path, PID_MAX).name), len(lock_path(path).name)) - len(path.name)
    name_max = os.pathconf(existing, "PC_NAME_MAX")
    for part in path.absolute().relative_to(existing).parts[:-1]:  # folders still to be made
        if len(part) > name_max:
            raise OutputPathError(f"{argument} {path}: a folder name of {len(part)} characters is too long "
                                  f"(at most {name_max} here)")
    if len(path.name) + extra > name_max:
        raise OutputPathError(f"{argument} {path}: a file name of {len(path.name)} characters is too long (at most "
                              f"{name_max - extra} here: its temporary file's name adds {extra})")
    path_max = os.pathconf(existing, "PC_PATH_MAX")
    if len(str(path.absolute())) + extra >= path_max:
        raise OutputPathError(f"{argument} {path}: a path of {len(str(path.absolute()))} characters is too long "
                              f"(at most {path_max - 1 - extra} here)")


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


def _check_folder(folder: Path, argument: str, path: Path) -> None:
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


DEFAULT_FMU_DIR = Path("build") / "fmus"  # where the FMUs are built and found, under the working folder
FMI_VERSIONS = (2, 3)  # ``--fmi``: FMI 2.0 (the default) or FMI 3.0, from the same sources


def fmu_folder(folder: Path, fmi: int, given: bool = False) -> Path:
    """Where the FMUs of an FMI version live: ``folder`` if the user gave it, else the default folder
    (FMI 3 in its ``fmi3`` subfolder, so that the two versions never rebuild each other's FMUs)."""
    return Path(folder) if given or fmi == 2 else Path(folder) / "fmi3"
