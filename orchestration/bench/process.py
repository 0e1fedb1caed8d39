"""Whole processes (``sotc-cosim bench``), each started in a fresh interpreter, the parent's wall time
(interpreter start-up and imports count):

* ``sotc-cosim run paper`` (FMUs, recording, summary) against what a user would write instead,
  ``benchmarks/plain_numpy.py`` (numpy only, no project code; a source checkout's), alternated
  ``repeats`` times;
* start-up: ``sotc-cosim run paper --stop-time 0.01`` with its recording, ``STARTUP_RUNS`` times per repeat."""
from __future__ import annotations

import compileall
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from orchestration.fmu_build.build import PACKAGE_ROOT
from orchestration.threads import user_environment

PLAIN_NUMPY = PACKAGE_ROOT / "benchmarks" / "plain_numpy.py"
RUN = "from orchestration.cli import console; console()"  # what the installed script runs
PACKAGES = ("fmi_slave", "fmi3_slave", "fmu_numerics", "fmu_plant", "fmu_controller", "orchestration")  # pyproject's packages
STARTUP_STOP_TIME = "0.01"  # one step: what is measured is start-up, loading and the recording's set-up
STARTUP_RUNS = 3  # start-ups per repeat: half a second each, and one busy moment moves a median of three


def _timed(argv: list[str], cwd: Path) -> float:
    """Wall seconds of one process, started with the user's environment (each chooses its own BLAS threads)."""
    env = user_environment()
    t0 = time.perf_counter()
    proc = subprocess.run(argv, cwd=cwd, capture_output=True, text=True, env=env)
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        raise RuntimeError(f"{' '.join(argv[:3])} failed: {proc.stderr.strip()[-500:]}")
    return wall


def _run(fmu_dir: Path, tmp: str, *extra: str) -> list[str]:
    return [sys.executable, "-c", RUN, "run", "paper", *extra, "--fmu-dir", str(fmu_dir), "--recording",
            str(Path(tmp) / "run.rrd")]


def _bytecode() -> None:
    """The packages' ``.pyc`` files, as an installed command has them (pip compiles them at install): in a
    source checkout, and with PYTHONDONTWRITEBYTECODE set, every fresh interpreter would otherwise compile
    the project's modules again, a cost no installed user pays. Up-to-date files are left as they are."""
    for name in PACKAGES:
        if (PACKAGE_ROOT / name).is_dir():
            compileall.compile_dir(PACKAGE_ROOT / name, quiet=2)


def _stats(walls: list[float]) -> dict:
    return {"median": statistics.median(walls), "min": min(walls), "max": max(walls), "runs": len(walls)}


def process_walls(fmu_dir: Path, repeats: int) -> dict:
    """Median (min, max) wall seconds of the run and of the plain numpy script, their ratio, and the
    start-up (a one-step recorded run); without the script (an installed package) only the start-up."""
    walls: dict[str, list[float]] = {"run": [], "script": [], "startup": []}
    _bytecode()
    with tempfile.TemporaryDirectory(prefix="sotc_bench_proc_") as tmp:
        for _ in range(repeats):
            walls["startup"] += [_timed(_run(fmu_dir, tmp, "--stop-time", STARTUP_STOP_TIME), Path(tmp))
                                 for _ in range(STARTUP_RUNS)]
            if PLAIN_NUMPY.is_file():
                walls["run"].append(_timed(_run(fmu_dir, tmp), Path(tmp)))
                walls["script"].append(_timed([sys.executable, str(PLAIN_NUMPY)], Path(tmp)))
    out = {k: _stats(v) for k, v in walls.items() if v}
    if "script" in out:
        out["ratio"] = out["run"]["median"] / out["script"]["median"]
    return out
