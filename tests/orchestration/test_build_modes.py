"""``run --fmu-dir DIR`` keeps the FMUs the user built in the other mode: a
``SOTC_COSIM_COMPILE=0`` build is not replaced by a compiled one at the next run, and the run says
which mode it runs them in."""
from __future__ import annotations

import os
import subprocess
import sys

import pytest

from orchestration.fmu_build import compiled
from orchestration.fmu_build.build import compiles, file_digest

CHILD = "import sys; from orchestration.cli import main; sys.exit(main(sys.argv[1:]))"


@pytest.mark.skipif(not compiles(), reason="builds here keep the cores Python: there is no other mode to keep")
def test_python_build_is_kept_by_a_default_run(python_fmu_paths, tmp_path):
    folder = next(iter(python_fmu_paths.values())).parent
    before = {m: file_digest(p) for m, p in python_fmu_paths.items()}
    env = {k: v for k, v in os.environ.items() if k != compiled.SWITCH}
    proc = subprocess.run([sys.executable, "-c", CHILD, "run", "paper", "--stop-time", "0.05", "--no-recording",
                           "--fmu-dir", str(folder)], cwd=tmp_path, env=env, capture_output=True, text=True,
                          timeout=240)
    assert proc.returncode == 0, proc.stderr
    assert "kept as built (cores Python" in proc.stderr
    assert "building" not in proc.stderr
    assert {m: file_digest(p) for m, p in python_fmu_paths.items()} == before
