"""FMUs unpacked once per content, into this user's private cache, and verified at every load.

A run used to extract every FMU into a fresh temporary folder and remove it again at the end: on
this machine's file system, more time than loading the FMUs. ``unpacked`` keeps one folder per FMU
content instead:

- the key is the SHA-256 of the ``.fmu`` file, the folder ``private_folder("fmus", "unpacked")/<digest>``
  (under the user's 0700 root);
- the folder is made once (``orchestration.verified``: a manifest of the SHA-256 of every file, the
  whole folder renamed into place); the FMU's modules come with checked-hash ``.pyc`` files, so Python
  writes nothing there when it imports them;
- at every load, before any of its code runs, every file is checked against the manifest (the same
  files, the same digests); a folder that differs (damaged, truncated, a file planted or missing) is
  removed and unpacked again;
- the folder is held (``orchestration.verified``) while this process lives: the cache's bound never
  removes it under a running FMU; a new folder may make the cache remove its least recently used ones.
"""
from __future__ import annotations

from pathlib import Path

from fmpy import extract

from orchestration import verified
from orchestration.outputs import private_folder


def unpacked(fmu_file: Path | str) -> str:
    """The folder holding ``fmu_file`` unpacked, checked against its manifest (made first if needed)."""
    fmu_file = Path(fmu_file)
    target = private_folder(*verified.UNPACKED) / verified.sha256(fmu_file)
    made = False
    for _ in range(verified.ATTEMPTS):
        if verified.hold(target) and verified.intact(target):
            break
        verified.release(target)
        verified.discard(target)
        verified.place(target, lambda staging: extract(str(fmu_file), unzipdir=str(staging)))
        made = True
    if made:
        verified.trim()
    return str(target)
