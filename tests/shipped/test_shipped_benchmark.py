"""``sotc-cosim benchmark`` as a user runs it (docs/benchmark.md): the installed console script, from a folder
outside the repository, on the example's controller file copied beside the FMU the example's build.py made, at
a small budget; stopped by SIGTERM during its searches, then resumed to the end; the reference it judges against
comes from the installed wheel."""
from __future__ import annotations

import json
import re
import shutil
import signal
from pathlib import Path

from support.example_controller import EXAMPLE, run_build, skip_without_compiler

ARGS = ["benchmark", "pd.toml", "--budget", "4", "--polish", "2", "--seeds", "0", "--points", "1", "--workers", "1"]


def _finished(journal: Path) -> bool:
    """A trial of the TPE phase is complete or pruned in the journal (Optuna's line that sets a trial's state)."""
    return journal.is_file() and re.search(r'"op_code":6,[^\n]*"state":[12],', journal.read_text()) is not None


def test_benchmark_of_the_example_stops_on_sigterm_and_resumes_to_its_report(shipped, shipped_fmu_dir):
    skip_without_compiler()
    work = shipped.workdir("benchmark")
    shutil.copy(EXAMPLE / "pd.toml", work / "pd.toml")
    done = run_build(work, "--out", str(work))
    assert done.returncode == 0, done.stderr
    out = work / "recordings" / "benchmark" / "pd"
    args = [*ARGS, "--fmu-dir", str(shipped_fmu_dir)]
    cut = shipped.interrupt(args, work, ready=lambda: _finished(out / "benchmark.journal"), sig=signal.SIGTERM)
    assert cut.returncode == 128 + signal.SIGTERM and "resume with: sotc-cosim benchmark pd.toml" in cut.stdout, \
        cut.stdout + cut.stderr
    assert not (out / "report.md").exists() and not [p for p in out.iterdir() if ".part" in p.name]
    proc = shipped.cli(*args, cwd=work)
    assert proc.returncode == 0, proc.stderr
    assert "1 searches, 6 trials, " in proc.stdout and ", 0 already in" not in proc.stdout  # resumed, not redone
    report = (out / "report.md").read_text()
    assert "## Paired verdicts" in report and "this controller, seed 0" in report
    assert {"criterion.png", "heldout.png", "benchmark.rrd"} <= {p.name for p in out.iterdir()}
    assert json.loads((out / "benchmark.json").read_text())["seeds_results"]["0"]["search"]["trials"] == 6
    refused = shipped.cli("benchmark", "pd.toml", "--points", "129", cwd=work)
    assert refused.returncode == 2 and len(refused.stderr.strip().splitlines()) == 1, refused.stderr
