"""Folders of a private cache, each with a manifest of its files' SHA-256, checked before their code runs.

Used for the FMUs unpacked once per content (``run.unpacked``) and the compiled cores reused across
builds (``fmu_build.compiled``). A folder is made once: filled in a temporary folder beside its place,
its manifest written, and renamed into place, so a reader never sees half of one; two processes making
the same folder at once both end with one whole copy. A folder that differs from its manifest (a file
changed, truncated, planted or missing) is never used: it is moved aside and removed.
"""
from __future__ import annotations

import hashlib
import os
import shutil
import tempfile
from pathlib import Path
from typing import Callable

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


def discard(target: Path) -> None:
    """Remove a damaged folder: moved aside first (a process still reading it keeps its files)."""
    if not target.exists():
        return
    aside = Path(tempfile.mkdtemp(prefix=f".{target.name}.bad.", dir=target.parent))
    try:
        target.rename(aside / "old")
    except FileNotFoundError:  # another process moved it first
        pass
    shutil.rmtree(aside, ignore_errors=True)
