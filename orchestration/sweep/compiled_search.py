"""A tuning search on the compiled cores: the pure loop of ``orchestration.study.optimize.run_search``
with the hot modules (``orchestration.fmu_build.compiled.HOT``) compiled by Cython, about twice as fast
for the SOTC, the same numbers bit for bit (the compiled cores round as the ``.py`` does).

The cores are compiled once per source digest into a private cache folder (a copy of ``fmu_plant`` and
``fmu_controller``, the extensions beside their ``.py``), on the machine that runs the search (a Dask
worker), and the search runs in a child interpreter started in that folder, so its packages come
before the installed ones. Where the cores cannot be compiled (``SOTC_COSIM_COMPILE=0``, no Cython or
C compiler) the search runs on the ``.py`` cores in the worker itself. The child dies with its worker
(Ctrl-C kills the local workers); the trial it was running is repeated at the next run.
"""
from __future__ import annotations

import ctypes
import hashlib
import importlib.machinery
import os
import shutil
import signal
import subprocess
import sys
import tempfile
from pathlib import Path

import fmu_controller
import fmu_plant
from orchestration.fmu_build import compiled
from orchestration.outputs import private_folder
from orchestration.study import optimize

PACKAGES = (Path(fmu_plant.__file__).parent, Path(fmu_controller.__file__).parent)
READY = "compiled.ok"  # written last into a finished cache entry, holding its digest


def _digest() -> str:
    h = hashlib.sha256(f"{compiled.target()} {compiled.CFLAGS} {compiled.HOT}".encode())
    for package in PACKAGES:
        for path in sorted(package.glob("*.p*")):
            if path.suffix in (".py", ".pxd"):
                h.update(f"{package.name}/{path.name}".encode() + path.read_bytes())
    return h.hexdigest()[:20]


def compiled_cores() -> Path | None:
    """The cache folder holding the compiled packages (built now if missing), or None where the cores
    cannot be compiled."""
    if not compiled.requested() or compiled.unavailable():
        return None
    digest = _digest()
    folder = private_folder("compiled-cores") / digest
    if (folder / READY).is_file() and (folder / READY).read_text() == digest:
        return folder
    staging = Path(tempfile.mkdtemp(prefix=f".{digest}-", dir=folder.parent))
    try:
        for package in PACKAGES:
            shutil.copytree(package, staging / package.name, ignore=shutil.ignore_patterns("__pycache__", "*.so"))
        compiled.compile_bundle(staging, ".", {})
        (staging / READY).write_text(digest)
        try:
            staging.rename(folder)  # another worker may have finished first: its copy is the same
        except OSError:
            pass
    finally:
        shutil.rmtree(staging, ignore_errors=True)
    suffix = importlib.machinery.EXTENSION_SUFFIXES[0]
    if not (folder / READY).is_file() or not (folder / "fmu_controller" / f"sotc{suffix}").is_file():
        raise compiled.CompileError(f"the compiled cores in {folder} are incomplete")
    return folder


def _die_with_parent() -> None:
    try:
        ctypes.CDLL(None).prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG (Linux)
    except (OSError, AttributeError):
        pass


def run_search(journal: Path, fmu: str, handling: int, seed: int, budget: int) -> int:
    """``optimize.run_search`` on the compiled cores where they can be built (see the module docstring)."""
    folder = compiled_cores()
    if folder is None:
        return optimize.run_search(journal, fmu, handling, seed, budget)
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONSAFEPATH")}
    proc = subprocess.run([sys.executable, "-m", "orchestration.study.optimize", str(journal), fmu, str(handling),
                           str(seed), str(budget)], cwd=folder, env=env, capture_output=True, text=True,
                          preexec_fn=_die_with_parent if sys.platform.startswith("linux") else None)
    last = next((ln for ln in reversed(proc.stderr.splitlines()) if ln.strip()), "no message")
    if proc.returncode == 2:
        raise optimize.JournalError(last)
    if proc.returncode != 0:
        raise RuntimeError(f"the search {optimize.study_name(fmu, handling, seed)} stopped: {last}")
    return int(proc.stdout.split()[-1])
