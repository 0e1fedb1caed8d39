"""Folders of a private cache, each with a manifest of its files' SHA-256, checked before their code runs;
the caches bounded: beyond a limit the least recently used folders go, never one in use.

Used for the FMUs unpacked once per content (``run.unpacked``) and the compiled cores reused across
builds (``fmu_build.compiled``). A folder is made once: filled in a temporary folder beside its place,
its manifest written, and renamed into place, so a reader never sees half of one; two processes making
the same folder at once both end with one whole copy. A folder that differs from its manifest (a file
changed, truncated, planted or missing) is never used: it is moved aside and removed.

The bound: every source change added a compiled-cores folder and every FMU content an unpacked one, for
good (115 MB for 8 models). The caches, under ``outputs.private_root()``:

- ``cores/compiled/<key>``: one compiled core, of the FMUs' bundles or of the wheel (``fmu_build.compiled``, setup.py);
- ``fmus/unpacked/<digest>``: an FMU unpacked once per content (``run.unpacked``);
- ``fmus/<digest>``: an FMU file sent to a sweep's workers (``sweep.runner``).

An entry is a folder named by a SHA-256. A process that uses one holds a shared ``flock`` on the folder
itself from its first use until the process ends (``hold``; the kernel releases it when the process dies,
killed or not), and sets the folder's time of last change then: that is its last use. After an entry is
made, ``trim`` removes the least recently used entries while the caches hold more than the limit
(``SOTC_COSIM_CACHE_LIMIT``: bytes, or with a K, M or G suffix of 1024s; default 1G; 0 keeps only what is
in use): each under an exclusive lock it does not wait for, so an entry in use is skipped, and moved
aside before it is removed, so a process that opens it at that moment finds it gone and makes it again.
``sotc-cosim cache`` lists them and clears them.
"""
from __future__ import annotations

import fcntl
import hashlib
import os
import re
import shutil
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from orchestration.exit_codes import UsageError
from orchestration.outputs import private_root

MANIFEST = ".sotc-manifest.sha256"  # beside the folder's own files; not one of them


def sha256(path: Path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def _files(folder: Path) -> list[str]:
    """Every file under ``folder`` but the manifest, as paths relative to it."""
    found = []
    for parent, _, names in os.walk(folder):
        found += [os.path.relpath(os.path.join(parent, n), folder) for n in names]
    return sorted(f for f in found if f != MANIFEST)


def manifest_text(folder: Path) -> str:
    return "".join(f"{sha256(folder / rel)}  {rel}\n" for rel in _files(folder))


def recorded(folder: Path) -> dict[str, str] | None:
    """The manifest of ``folder`` (relative path -> SHA-256); None when it is missing or unreadable."""
    try:
        lines = (Path(folder) / MANIFEST).read_text(encoding="utf-8").splitlines()
        return {rel: digest for digest, _, rel in (line.partition("  ") for line in lines)}
    except (OSError, UnicodeDecodeError):
        return None


def intact(folder: Path) -> bool:
    """The folder holds exactly the files of its manifest, each with its recorded digest."""
    try:
        return (Path(folder) / MANIFEST).read_text(encoding="utf-8") == manifest_text(Path(folder))
    except (OSError, UnicodeDecodeError):
        return False


def place(target: Path, fill: Callable[[Path], None]) -> None:
    """Make ``target``: ``fill`` writes its files into a temporary folder beside it, which gets its
    manifest and is renamed into place (a concurrent process's identical folder already there is kept)."""
    staging = Path(tempfile.mkdtemp(prefix=f".{target.name}.", dir=target.parent))
    try:
        fill(staging)
        (staging / MANIFEST).write_text(manifest_text(staging), encoding="utf-8")
        try:
            staging.rename(target)
        except OSError:
            if not intact(target):  # not a concurrent process's identical folder: a real failure
                raise
    finally:
        shutil.rmtree(staging, ignore_errors=True)


def _moved_and_removed(target: Path, why: str) -> bool:
    """Remove ``target``, moved aside first (a process still reading it keeps its files); False if another
    process moved it first."""
    aside = Path(tempfile.mkdtemp(prefix=f".{target.name}.{why}.", dir=target.parent))
    try:
        target.rename(aside / "old")
        return True
    except FileNotFoundError:
        return False
    finally:
        shutil.rmtree(aside, ignore_errors=True)


def discard(target: Path) -> None:
    """Remove a damaged folder."""
    if target.exists():
        _moved_and_removed(target, "bad")


# --- the bound ---------------------------------------------------------------------------------------

CORES = ("cores", "compiled")  # under the private root: the compiled cores
UNPACKED = ("fmus", "unpacked")  # the unpacked FMUs
SENT = ("fmus",)  # the FMU files of sweep points
KINDS = {"compiled cores": CORES, "unpacked FMUs": UNPACKED, "FMUs of sweep points": SENT}
LIMIT_VARIABLE = "SOTC_COSIM_CACHE_LIMIT"
DEFAULT_LIMIT = "1G"
ATTEMPTS = 3  # to make and hold an entry that another process's trim may remove in between
_UNITS = {"": 1, "K": 2**10, "M": 2**20, "G": 2**30}
_ENTRY = re.compile(r"[0-9a-f]{64}")  # an entry's name: a SHA-256

_held: dict[str, int] = {}  # entry folder -> the descriptor of this process's shared lock on it


@dataclass(frozen=True)
class Entry:
    kind: str
    path: Path
    size: int  # bytes of its files
    used: float  # its last use (the folder's time of last change), s since the epoch


def limit() -> int:
    """The caches' limit in bytes (``SOTC_COSIM_CACHE_LIMIT``)."""
    text = os.environ.get(LIMIT_VARIABLE, DEFAULT_LIMIT).strip()
    match = re.fullmatch(r"(\d+(?:\.\d+)?)\s*([KMG]?)B?", text.upper())
    if match is None:
        raise UsageError(f"{LIMIT_VARIABLE}={text!r}: not a size; give bytes or a number with K, M or G "
                         f"(default {DEFAULT_LIMIT})")
    return int(float(match[1]) * _UNITS[match[2]])


def _same(fd: int, path: Path) -> bool:
    """Whether ``fd`` is still the folder at ``path`` (not moved aside, nothing else there since)."""
    try:
        here, held = os.stat(path, follow_symlinks=False), os.fstat(fd)
    except OSError:
        return False
    return (here.st_dev, here.st_ino) == (held.st_dev, held.st_ino)


def _open(path: Path) -> int | None:
    try:
        return os.open(path, os.O_RDONLY | os.O_DIRECTORY | os.O_NOFOLLOW)
    except OSError:
        return None


def hold(entry: Path) -> bool:
    """Mark ``entry`` used now and in use by this process until it ends; False if it is not there (make
    it, then hold it)."""
    key = str(entry)
    fd = _held.pop(key, None)
    if fd is not None and not _same(fd, entry):
        os.close(fd)
        fd = None
    if fd is None:
        fd = _open(entry)
        if fd is None:
            return False
        fcntl.flock(fd, fcntl.LOCK_SH)  # waits only while a trim moves the entry aside
        if not _same(fd, entry):
            os.close(fd)
            return False
    os.utime(fd)
    _held[key] = fd
    return True


def release(entry: Path) -> None:
    """This process no longer uses ``entry`` (a damaged one it is about to set aside)."""
    fd = _held.pop(str(entry), None)
    if fd is not None:
        os.close(fd)


def _size(folder: Path) -> int:
    total = 0
    for parent, _, names in os.walk(folder):
        for name in names:
            try:
                total += os.lstat(os.path.join(parent, name)).st_size
            except OSError:
                pass
    return total


def entries(root: Path | None = None) -> list[Entry]:
    """Every entry of the caches under ``root`` (default: this user's private root)."""
    root = private_root() if root is None else root
    found = []
    for kind, parts in KINDS.items():
        try:
            children = list(root.joinpath(*parts).iterdir())
        except OSError:
            continue
        for child in children:
            try:
                st = os.stat(child, follow_symlinks=False)
            except OSError:
                continue
            if _ENTRY.fullmatch(child.name) and child.is_dir() and not child.is_symlink():
                found.append(Entry(kind, child, _size(child), st.st_mtime))
    return found


def remove(entry: Path) -> bool:
    """Remove ``entry`` unless a process uses it (True: removed)."""
    fd = _open(entry)
    if fd is None:
        return False
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)  # BlockingIOError: in use
        return _same(fd, entry) and _moved_and_removed(entry, "gone")
    except OSError:
        return False
    finally:
        os.close(fd)


def clear() -> tuple[list[Entry], list[Entry]]:
    """Remove every entry not in use: (removed, kept because in use)."""
    removed, kept = [], []
    for entry in entries():
        (removed if remove(entry.path) else kept).append(entry)
    return removed, kept


def trim(bound: int | None = None) -> list[Entry]:
    """Remove the least recently used entries not in use while the caches hold more than ``bound``
    (default: ``limit()``); the entries removed."""
    bound = limit() if bound is None else bound
    found = entries()
    total = sum(e.size for e in found)
    removed = []
    for entry in sorted(found, key=lambda e: e.used):
        if total <= bound:
            break
        if remove(entry.path):
            total -= entry.size
            removed.append(entry)
    return removed
