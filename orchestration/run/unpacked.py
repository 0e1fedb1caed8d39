"""FMUs unpacked once per content, into this user's private cache, and verified at every load.

A run used to extract every FMU into a fresh temporary folder and remove it again at the end: on
this machine's file system, more time than loading the FMUs. ``unpacked`` keeps one folder per FMU
content instead:

- the key is the SHA-256 of the ``.fmu`` file, the folder ``private_folder("fmus", "unpacked")/<digest>``
  (under the user's 0700 root);
- the folder is made once: extracted into a temporary folder beside it, a manifest of the SHA-256 of
  every file written, and renamed into place, so a reader never sees half an FMU (the FMU's modules
  come with checked-hash ``.pyc`` files: Python writes nothing there when it imports them);
- at every load, before any of its code runs, every file is checked against the manifest (the same
  files, the same digests); a folder that differs (damaged, truncated, a file planted or missing) is
  removed and unpacked again.
"""
from __future__ import annotations

import hashlib
import os
import shutil
import tempfile
from pathlib import Path

from fmpy import extract

from orchestration.outputs import private_folder

MANIFEST = ".sotc-manifest.sha256"  # beside the FMU's own folders; not a file of the FMU


def _sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _files(folder: Path) -> list[str]:
    """Every file under ``folder`` but the manifest, as paths relative to it."""
    found = []
    for parent, _, names in os.walk(folder):
        found += [os.path.relpath(os.path.join(parent, n), folder) for n in names]
    return sorted(f for f in found if f != MANIFEST)


def _manifest(folder: Path) -> str:
    return "".join(f"{_sha256(folder / rel)}  {rel}\n" for rel in _files(folder))


def _intact(folder: Path) -> bool:
    """The folder holds exactly the files of its manifest, each with its recorded digest."""
    try:
        recorded = (folder / MANIFEST).read_text(encoding="utf-8")
        return recorded == _manifest(folder)
    except (OSError, UnicodeDecodeError):
        return False


def _unpack(fmu_file: Path, target: Path) -> None:
    """Extract into a temporary folder beside ``target``, then rename it into place."""
    staging = Path(tempfile.mkdtemp(prefix=f".{target.name}.", dir=target.parent))
    try:
        extract(str(fmu_file), unzipdir=str(staging))
        (staging / MANIFEST).write_text(_manifest(staging), encoding="utf-8")
        try:
            staging.rename(target)
        except OSError:
            if not _intact(target):  # not a concurrent process's identical folder: a real failure
                raise
    finally:
        shutil.rmtree(staging, ignore_errors=True)


def unpacked(fmu_file: Path | str) -> str:
    """The folder holding ``fmu_file`` unpacked, checked against its manifest (made first if needed)."""
    fmu_file = Path(fmu_file)
    target = private_folder("fmus", "unpacked") / _sha256(fmu_file)
    if target.is_dir() and _intact(target):
        return str(target)
    if target.exists():  # damaged: moved aside (a process still reading it keeps its files), removed
        aside = Path(tempfile.mkdtemp(prefix=f".{target.name}.bad.", dir=target.parent))
        try:
            target.rename(aside / "old")
        except FileNotFoundError:  # another process moved it first
            pass
        shutil.rmtree(aside, ignore_errors=True)
    _unpack(fmu_file, target)
    return str(target)
