"""Whole processes, side by side (``sotc-cosim bench``): ``sotc-cosim run paper`` (FMUs, recording,
summary) against the same experiment as a plain script, a fresh interpreter running the in-process loop
over the cores (numpy arrays, no FMI, no recording). Each is started ``repeats`` times, alternated; the
wall time is the parent's, so interpreter start-up and imports count for both."""
from __future__ import annotations

import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

SCRIPT = (
    "from fmu_controller.sotc import SotcCore\n"
    "from orchestration.study.pure_loop import simulate\n"
    "from orchestration.run.metrics import tracking_metrics\n"
    "res = simulate(SotcCore(), stop_time=100.0)\n"
    "print(tracking_metrics(res.t, res.error, res.tau, 4.0)['mse'])\n"
)
RUN = "from orchestration.cli import main; raise SystemExit(main())"


def _timed(argv: list[str], cwd: Path) -> float:
    t0 = time.perf_counter()
    proc = subprocess.run(argv, cwd=cwd, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        raise RuntimeError(f"{' '.join(argv[:3])} failed: {proc.stderr.strip()[-500:]}")
    return wall


def process_walls(fmu_dir: Path, repeats: int) -> dict:
    """Median (min, max) wall seconds of both processes and their ratio."""
    walls: dict[str, list[float]] = {"run": [], "script": []}
    with tempfile.TemporaryDirectory(prefix="sotc_bench_proc_") as tmp:
        run = [sys.executable, "-c", RUN, "run", "paper", "--fmu-dir", str(fmu_dir), "--recording",
               str(Path(tmp) / "run.rrd")]
        for _ in range(repeats):
            walls["run"].append(_timed(run, Path(tmp)))
            walls["script"].append(_timed([sys.executable, "-c", SCRIPT], Path(tmp)))
    med = {k: statistics.median(v) for k, v in walls.items()}
    return {k: {"median": med[k], "min": min(v), "max": max(v)} for k, v in walls.items()} | {
        "ratio": med["run"] / med["script"]}
