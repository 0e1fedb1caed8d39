"""``sotc-cosim run`` imports only what it uses: the parser of every command is
built at start-up, so no command module may pull its heavy dependencies in at import time."""
from __future__ import annotations

import json
import subprocess
import sys

import pytest

# imported by other commands only (tune, sweep, optimum, bench): never by a recorded run
NOT_FOR_RUN = ("scipy.stats", "optuna", "dask", "distributed", "casadi", "matplotlib")

CHILD = """
import json, sys
from orchestration.cli import main
code = main(sys.argv[1:])
print(json.dumps({"code": code, "modules": sorted(sys.modules)}))
"""


def _modules_after(args: list[str], cwd) -> set[str]:
    proc = subprocess.run([sys.executable, "-c", CHILD, *args], cwd=cwd, capture_output=True, text=True,
                          timeout=240)
    assert proc.returncode == 0, proc.stderr
    report = json.loads(proc.stdout.strip().splitlines()[-1])
    assert report["code"] == 0, proc.stdout
    return set(report["modules"])


@pytest.mark.parametrize("module", NOT_FOR_RUN)
def test_parser_imports_no_heavy_dependency(module, tmp_path):
    loaded = _modules_after(["scenarios"], tmp_path)
    assert module not in loaded


def test_recorded_run_imports_no_heavy_dependency(fmu_dir, tmp_path):
    loaded = _modules_after(["run", "paper", "--stop-time", "0.05", "--fmu-dir", str(fmu_dir),
                             "--recording", str(tmp_path / "run.rrd")], tmp_path)
    assert (tmp_path / "run.rrd").stat().st_size > 0  # the run did record: the checks are about a real recorded run
    assert sorted(m for m in loaded if any(m == n or m.startswith(n + ".") for n in NOT_FOR_RUN)) == []
    assert "rerun" not in loaded  # the writer process imports it, meanwhile this one loads the FMUs


PARSED = """
import sys
from orchestration.cli import build_parser
build_parser().parse_args(["run", "paper"])
heavy = {m.split(".")[0] for m in sys.modules} & {"numpy", "fmpy", "rerun"}
cores = {m for m in sys.modules if m.startswith("fmu_controller.") and m != "fmu_controller.ports"}  # ports: names only
print(" ".join(sorted(heavy | cores)))
"""


def test_the_command_line_is_parsed_before_numpy_loads(tmp_path):
    """``run`` forks its recording writer once the command line is parsed: with numpy, fmpy and the cores
    not imported yet, the writer imports numpy and Rerun while this process imports numpy and fmpy."""
    proc = subprocess.run([sys.executable, "-c", PARSED], cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == ""
