"""The processes a test process started and that are still alive: what a test of a child process checks
is gone once the thing that started it has ended."""
from __future__ import annotations

import os
from pathlib import Path


def children() -> set[int]:
    """The live processes whose parent is this one."""
    found = set()
    for status in Path("/proc").glob("[0-9]*/status"):
        try:
            fields = dict(line.split(":\t", 1) for line in status.read_text().splitlines() if ":\t" in line)
        except OSError:
            continue
        if int(fields.get("PPid", "0")) == os.getpid() and not fields.get("State", "").startswith("Z"):
            found.add(int(status.parent.name))
    return found
