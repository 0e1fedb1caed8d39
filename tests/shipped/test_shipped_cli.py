"""Every command of the README, run as a user runs it: the installed console script, in a fresh
process, from a folder outside the repository (``tests/shipped.py``). Several different FMUs run
one after another in one process here, as they do for every user of reproduce, compare and sweep."""
from __future__ import annotations

import csv
import json
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

from orchestration.fmu_build.build import FMU_SOURCES
from support import REPO

pytestmark = pytest.mark.slow  # the installed wheel in a fresh virtualenv: minutes

RERUN = str(Path(sys.executable).with_name("rerun"))
CONTROLLER_SCENARIOS = ("paper", "paper-otc", "paper-ct", "paper-lqr")


def _ok(proc: subprocess.CompletedProcess) -> None:
    assert proc.returncode == 0, f"exit {proc.returncode}\n{proc.stdout}\n{proc.stderr}"
    assert "Traceback" not in proc.stderr, proc.stderr


def _verify(*paths: Path) -> None:
    proc = subprocess.run([RERUN, "rrd", "verify", *map(str, paths)], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stdout + proc.stderr


def test_the_source_tree_is_not_importable_where_the_commands_run(shipped):
    proc = shipped.python_code("import orchestration, fmu_plant; print(orchestration.__file__); print(fmu_plant.__file__)",
                               cwd=shipped.workdir("where"))
    _ok(proc)
    for line in proc.stdout.split():
        assert str(shipped.src) not in line and "site-packages" in line, line
        assert Path(line).resolve().is_relative_to(shipped.root / "venv"), line


def test_reproduce_runs_every_controller_of_the_paper(shipped):
    """Builds its FMUs on demand in the working folder, like a first-time user: all controllers run in one
    process, and every run and limit handling is printed."""
    from orchestration.study.reproduce import REPRODUCE_SCENARIOS

    work = shipped.workdir("reproduce")
    proc = shipped.cli("reproduce", "--stop-time", "2", cwd=work)
    _ok(proc)
    for name in REPRODUCE_SCENARIOS:
        assert f"\n{name} " in proc.stdout, name
    for handling in ("radial", "joint", "accel", "none"):
        assert handling in proc.stdout
    assert (work / "recordings" / "table1.md").is_file()
    with open(work / "recordings" / "table1.csv", newline="") as f:
        rows = [r for r in csv.DictReader(f) if r["source"] == "this run"]
    assert {r["controller"] for r in rows} >= {"SotcController", "OtcController", "CtController", "LqrController"}
    assert rows and all(r["status"] == "ok" for r in rows), rows
    _verify(work / "recordings" / "reproduce.rrd")


def test_compare_overlays_all_four_controllers(shipped, shipped_fmu_dir):
    work = shipped.workdir("compare")
    proc = shipped.cli("compare", *CONTROLLER_SCENARIOS, "--stop-time", "2", "--fmu-dir", str(shipped_fmu_dir), cwd=work)
    _ok(proc)
    for name in CONTROLLER_SCENARIOS:
        assert any(line.startswith(f"{name} ") and " ok " in line for line in proc.stdout.splitlines()), proc.stdout
    _verify(work / "recordings" / "compare.rrd")


def test_one_run_of_several_scenarios(shipped, shipped_fmu_dir):
    work = shipped.workdir("run")
    order = ("paper-ct", "paper-otc", "paper-lqr", "paper", "paper-ct")  # the first controller again, last
    proc = shipped.cli("run", *order, "--stop-time", "2", "--no-recording", "--fmu-dir", str(shipped_fmu_dir), cwd=work)
    _ok(proc)
    rows = [line.split() for line in proc.stdout.splitlines() if line.split()[:1] and line.split()[0] in order]
    assert [r[0] for r in rows] == list(order) and all(r[2] == "ok" for r in rows), proc.stdout


def test_validate_passes_every_fmu(shipped, shipped_fmu_dir):
    """The FMUs as the installed build makes them (reproduce's test builds them from the command itself)."""
    work = shipped.workdir("validate")
    proc = shipped.cli("validate", "--fmu-dir", str(shipped_fmu_dir), cwd=work)
    _ok(proc)
    assert "all FMUs pass" in proc.stdout
    verdicts = {line.split()[0]: line.split()[-1] for line in proc.stdout.splitlines() if line.endswith(("pass", "FAIL"))}
    assert {m: v for m, v in verdicts.items() if m != "all"} == dict.fromkeys(FMU_SOURCES, "pass"), proc.stdout


def test_cross_check_writes_every_fmu(shipped, shipped_fmu_dir):
    work = shipped.workdir("cross-check")
    proc = shipped.cli("cross-check", "--out", "xc", "--stop-time", "1", "--fmu-dir", str(shipped_fmu_dir), cwd=work)
    _ok(proc)
    folders = [Path(work, line) for line in proc.stdout.split()]
    assert len(folders) == len(FMU_SOURCES)
    for folder in folders:
        assert (folder / f"{folder.name}.fmu").is_file() and (folder / f"{folder.name}_ref.csv").is_file()


CONTROLLER_SWEEP = """
name = "one-worker"
scenario = "paper-perturbed"
stop_time = 1.0
[[axis]]
name = "controller"
values = ["OtcController", "CtController", "LqrController", "SotcController"]
[[axis]]
name = "noise.std_phi"
values = [0.0, 0.001]
"""


def test_a_sweep_over_controllers_reuses_one_worker_process(shipped, shipped_fmu_dir):
    """Every controller (and the perturbation FMUs) one after another in one Dask worker process."""
    work = shipped.workdir("sweep")
    (work / "controllers.toml").write_text(CONTROLLER_SWEEP)
    proc = shipped.cli("sweep", "controllers.toml", "--workers", "1", "--fmu-dir", str(shipped_fmu_dir), cwd=work)
    _ok(proc)
    rows = [json.loads(line) for line in (work / "recordings" / "one-worker" / "points.jsonl").read_text().splitlines()]
    assert sorted(r["settings"]["controller"] for r in rows) == sorted(["OtcController", "CtController", "LqrController",
                                                                        "SotcController"] * 2)
    assert all(r["status"] == "ok" for r in rows), [r["reason"] for r in rows]
    assert len({r["worker"] for r in rows}) == 1  # one worker process ran every controller
    assert "8 of 8 points stored" in proc.stdout


def _grown(path: Path, size: int):
    """True once the recording being written (``.<name>.<pid>.part`` until it is closed) has > size bytes."""
    def ready() -> bool:
        files = [path, *path.parent.glob(f".{path.name}.*.part")]
        return any(f.is_file() and f.stat().st_size > size for f in files)
    return ready


@pytest.mark.parametrize("after_bytes", [1, 2_000_000])
def test_sigint_on_a_recorded_run_stops_cleanly(shipped, shipped_fmu_dir, after_bytes):
    """SIGINT once the recording has its first block (or several): exit 130, no crash, every instance
    freed, the recording finalised and readable."""
    work = shipped.workdir(f"sigint-run-{after_bytes}")
    rrd = work / "recordings" / "paper.rrd"
    proc = shipped.interrupt(["run", "paper", "--stop-time", "1000", "--fmu-dir", str(shipped_fmu_dir)], work,
                             _grown(rrd, after_bytes))
    assert proc.returncode == 130, f"exit {proc.returncode}\n{proc.stdout}\n{proc.stderr}"
    assert "Traceback" not in proc.stderr and "interrupted" in proc.stderr
    assert any(line.startswith("paper ") and "interrupted" in line for line in proc.stdout.splitlines()), proc.stdout
    _verify(rrd)


def test_sigint_on_a_batch_keeps_finished_runs_and_starts_no_more(shipped, shipped_fmu_dir):
    work = shipped.workdir("sigint-batch")
    second = work / "recordings" / "paper-lqr.rrd"
    proc = shipped.interrupt(["run", "paper-ct", "paper-lqr", "paper", "--stop-time", "300",
                              "--fmu-dir", str(shipped_fmu_dir)], work, _grown(second, 1))
    assert proc.returncode == 130, f"exit {proc.returncode}\n{proc.stdout}\n{proc.stderr}"
    assert "Traceback" not in proc.stderr
    status = {line.split()[0]: line.split()[2] for line in proc.stdout.splitlines()
              if line.split()[:1] and line.split()[0] in ("paper-ct", "paper-lqr", "paper")}
    assert status == {"paper-ct": "ok", "paper-lqr": "interrupted"}, proc.stdout
    assert not (work / "recordings" / "paper.rrd").exists()
    _verify(work / "recordings" / "paper-ct.rrd", second)


def test_bench_measures_and_writes_json(shipped, shipped_fmu_dir):
    """The speed benchmark as a user runs it (shortened), as docs/performance.md says: a new JSON and the change
    since the stored measurement; --update-docs needs a source checkout."""
    work = shipped.workdir("bench")
    common = ("--repeats", "1", "--long", "none", "--stop-time", "1", "--fmu-dir", str(shipped_fmu_dir))
    stored = REPO / "docs" / "performance.json"
    proc = shipped.cli("bench", *common, "--json", "b.json", "--compare", str(stored), cwd=work)
    _ok(proc)
    data = json.loads((work / "b.json").read_text())["speed"]
    compiled = {"cosim_recorded_compiled"} if not data["compiled"].startswith("not measured") else set()
    assert set(data["runs"]) == {"floor", "cosim", "cosim_recorded"} | compiled and "vs floor" in proc.stdout
    assert f"Compiled cores: {data['compiled']}" in proc.stdout  # measured where this host can compile, else why not
    change = proc.stdout[proc.stdout.index("change since"):].splitlines()
    assert change[0] == f"change since {json.loads(stored.read_text())['date']}:" and len(change) > 2, proc.stdout
    proc = shipped.cli("bench", *common, "--update-docs", cwd=work)
    assert proc.returncode == 2 and "source checkout" in proc.stderr and "Traceback" not in proc.stderr


def test_a_long_run_streams_and_records_every_nth_sample(shipped, shipped_fmu_dir):
    work = shipped.workdir("record-every")
    proc = shipped.cli("run", "paper", "--stop-time", "20", "--record-every", "10", "--summary", "s.json",
                       "--fmu-dir", str(shipped_fmu_dir), cwd=work)
    _ok(proc)
    assert json.loads((work / "s.json").read_text())["samples"] == 2001
    _verify(work / "recordings" / "paper.rrd")


def test_the_installed_build_compiles_the_cores_with_their_declarations(shipped, shipped_fmu_dir):
    """The wheel carries the .pxd files (without them Cython would compile untyped cores, silently
    slower), and the installed `sotc-cosim build` compiles where this host can, as the suite's own."""
    from orchestration.fmu_build import compiled

    code = ("import json, pathlib, fmu_controller, fmu_numerics, fmu_plant; from orchestration.fmu_build import compiled\n"
            "roots = {'fmu_controller': fmu_controller, 'fmu_numerics': fmu_numerics, 'fmu_plant': fmu_plant}\n"
            "print(json.dumps([r for r in compiled.HOT if (pathlib.Path(roots[r.split('/')[0]].__file__).parent\n"
            "      / compiled.declarations(r).split('/', 1)[1]).is_file()]))")
    proc = shipped.python_code(code, cwd=shipped.workdir("pxd"))
    _ok(proc)
    assert {"fmu_numerics/elementary.py", "fmu_plant/dynamics.py", "fmu_controller/sotc.py", "fmu_controller/sotc_zv.py"} <= set(json.loads(proc.stdout))
    described = compiled.describe(shipped_fmu_dir / "SotcController.fmu")
    if compiled.unavailable() is None:
        with zipfile.ZipFile(shipped_fmu_dir / "SotcController.fmu") as z:  # every hot module it bundles
            hot = [r for r in compiled.HOT if any(n.endswith(f"_lib/{r}") for n in z.namelist())]
        assert len(hot) > 1 and described.startswith(f"{len(hot)} cores compiled"), described
    else:
        assert described == "Python only"
