"""``sotc-cosim benchmark`` as a user runs it (docs/benchmark.md): the installed console script, from a folder
outside the repository, on the example's controller file copied beside the FMU the example's build.py made, at
the smallest budget; the reference it judges against comes from the installed wheel."""
from __future__ import annotations

import shutil

from support.example_controller import EXAMPLE, run_build, skip_without_compiler


def test_benchmark_of_the_example_writes_its_report_from_the_installed_wheel(shipped, shipped_fmu_dir):
    skip_without_compiler()
    work = shipped.workdir("benchmark")
    shutil.copy(EXAMPLE / "pd.toml", work / "pd.toml")
    done = run_build(work, "--out", str(work))
    assert done.returncode == 0, done.stderr
    proc = shipped.cli("benchmark", "pd.toml", "--budget", "2", "--polish", "0", "--seeds", "0", "--points", "1",
                       "--workers", "1", "--fmu-dir", str(shipped_fmu_dir), cwd=work)
    assert proc.returncode == 0, proc.stderr
    out = work / "recordings" / "benchmark" / "pd"
    report = (out / "report.md").read_text()
    assert "## Paired verdicts" in report and "this controller, seed 0" in report
    assert {"criterion.png", "heldout.png", "benchmark.rrd"} <= {p.name for p in out.iterdir()}
    refused = shipped.cli("benchmark", "pd.toml", "--points", "129", cwd=work)
    assert refused.returncode == 2 and len(refused.stderr.strip().splitlines()) == 1, refused.stderr
