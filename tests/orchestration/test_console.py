"""The installed ``sotc-cosim`` script (``orchestration.cli.console``): after ``run`` it leaves without
finalizing the interpreter, so everything it prints must already be out, through a pipe as well,
and its exit status must be ``main``'s."""
from __future__ import annotations

import subprocess
import sys

from orchestration.threads import USER_CHOICES
from support.cli import SCRIPT, TIME_LIMIT, env_for, leftovers


def _piped(args: list[str], cwd) -> subprocess.CompletedProcess:
    return subprocess.run([SCRIPT, *args], cwd=cwd, capture_output=True, text=True, env=env_for(cwd),
                          timeout=TIME_LIMIT)


def test_a_run_prints_its_whole_table_through_a_pipe_and_exits_with_mains_status(fmu_dir, tmp_path):
    proc = _piped(["run", "paper", "paper-ct", "--stop-time", "0.05", "--no-recording", "--fmu-dir", str(fmu_dir)],
                  tmp_path)
    assert proc.returncode == 0, proc.stderr
    rows = [line.split()[0] for line in proc.stdout.splitlines()[2:] if line.strip()]
    assert rows == ["paper", "paper-ct"] and proc.stdout.endswith("\n"), proc.stdout
    assert leftovers(tmp_path) == []


def test_a_run_refused_exits_2_in_one_line_and_a_recorded_one_leaves_its_file(fmu_dir, tmp_path):
    proc = _piped(["run", "nosuch", "--fmu-dir", str(fmu_dir)], tmp_path)
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1, proc.stderr
    proc = _piped(["run", "paper", "--stop-time", "0.05", "--recording", "r.rrd", "--fmu-dir", str(fmu_dir)], tmp_path)
    assert proc.returncode == 0 and (tmp_path / "r.rrd").stat().st_size > 0, proc.stderr
    assert sorted(p.name for p in tmp_path.glob(".*")) == [] and leftovers(tmp_path) == []


_BLAS_PROBE = (
    "import os, sys\n"
    "import orchestration.cli as cli\n"
    "from orchestration.threads import user_environment\n"
    "def probe(argv):\n"
    "    before = 'numpy' in sys.modules\n"
    "    import numpy\n"
    "    threads = len(os.listdir('/proc/self/task'))\n"
    "    print(os.environ.get('OPENBLAS_NUM_THREADS'), before, threads, user_environment().get('OPENBLAS_NUM_THREADS'))\n"
    "    return 0\n"
    "cli.main = probe\n"
    "sys.argv = ['sotc-cosim', 'list']\n"
    "cli.console()\n"
)


def _probe(env: dict[str, str], tmp_path) -> list[str]:
    proc = subprocess.run([sys.executable, "-c", _BLAS_PROBE], cwd=tmp_path, capture_output=True, text=True,
                          env=env, timeout=TIME_LIMIT)
    assert proc.returncode == 0, proc.stderr
    return proc.stdout.split()


def test_the_script_gives_numpys_blas_one_thread_unless_the_user_chose(tmp_path):
    env = {k: v for k, v in env_for(tmp_path).items() if k not in USER_CHOICES}
    # set before numpy loaded; OpenBLAS started no thread of its own; the bench's children get the user's
    assert _probe(env, tmp_path) == ["1", "False", "1", "None"]
    out = _probe({**env, "OPENBLAS_NUM_THREADS": "2"}, tmp_path)  # the user's choice stands, and is passed on
    assert [out[0], out[1], out[3]] == ["2", "False", "2"], out
    out = _probe({**env, "OMP_NUM_THREADS": "2"}, tmp_path)  # another variable OpenBLAS reads: the user's too
    assert [out[0], out[1], out[3]] == ["None", "False", "None"], out
