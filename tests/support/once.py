"""Session fixtures made once for all pytest-xdist workers of a run.

Each worker has its own session, so a session fixture would otherwise build the FMUs or install the wheel
once per worker. ``made_once`` hands every worker the same folder (in the run's shared temporary folder)
under a lock: the first worker to get there fills it, the others wait for it and find it filled.
"""
from __future__ import annotations

import contextlib
import fcntl
import os
import shutil
from pathlib import Path
from typing import Iterator

DONE = ".made"  # written into the folder once it is filled


@contextlib.contextmanager
def made_once(tmp_path_factory, name: str) -> Iterator[tuple[Path, bool]]:
    """Yield (the shared folder ``name``, whether it still has to be filled), holding the lock; the
    folder counts as filled when the body returns without an error."""
    base = tmp_path_factory.getbasetemp()
    root = base.parent if os.environ.get("PYTEST_XDIST_WORKER") else base
    folder = root / name
    with open(root / f"{name}.lock", "a") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        try:
            fill = not (folder / DONE).exists()
            if fill:  # empty, also after a worker failed halfway through filling it
                shutil.rmtree(folder, ignore_errors=True)
            folder.mkdir(exist_ok=True)
            yield folder, fill
            (folder / DONE).touch()
        finally:
            fcntl.flock(lock, fcntl.LOCK_UN)
