"""A damaged compiled core inside an otherwise valid FMU (truncated, empty, or another module's
extension in its place) never reaches ``dlopen``: the FMU checks each extension's SHA-256 before any
core is imported and runs the ``.py`` instead (a truncated ``.so`` crashed the host with SIGBUS,
exit 135). Shown through ``fmpy simulate``, ``sotc-cosim validate`` (one failed check naming the
file) and ``sotc-cosim run`` (the same results as the intact FMU), all in subprocesses."""
from __future__ import annotations

import hashlib
import json
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

from fmi_slave.compiled_check import DIGESTS
from orchestration.fmu_build import compiled
from support.cli import leftovers, run

pytestmark = pytest.mark.slow  # validate and runs in subprocesses

MODEL = "SotcController"
CORE = "fmu_controller/sotc."  # the core whose extension is damaged
FMPY = str(Path(sys.executable).with_name("fmpy"))


def _extensions(fmu: Path) -> list[str]:
    with zipfile.ZipFile(fmu) as z:
        return [n for n in z.namelist() if compiled.is_extension(n)]


def _with(fmu: Path, dest: Path, changes: dict[str, bytes]) -> Path:
    """A copy of ``fmu`` at ``dest`` with the members named in ``changes`` replaced."""
    with zipfile.ZipFile(fmu) as z, zipfile.ZipFile(dest, "w", zipfile.ZIP_DEFLATED) as out:
        for item in z.infolist():
            out.writestr(item, changes.get(item.filename, z.read(item)))
    return dest


def _damaged(fmu: Path, kind: str, dest: Path, core: str = CORE) -> Path:
    with zipfile.ZipFile(fmu) as z:
        names = z.namelist()
        target = next(n for n in names if compiled.is_extension(n) and core in n)
        other = next(n for n in names if compiled.is_extension(n) and n != target)
        data = z.read(target)
        new = {"truncated": data[:len(data) // 2], "empty": b"", "foreign": z.read(other)}[kind]
    return _with(fmu, dest, {target: new})


@pytest.fixture(scope="module")
def sotc_fmu(fmu_paths) -> Path:
    if not compiled.extensions(fmu_paths[MODEL]):
        pytest.skip(f"this host builds no compiled cores ({compiled.unavailable()}): nothing to damage")
    return fmu_paths[MODEL]


KINDS = ("truncated", "empty", "foreign")


@pytest.mark.parametrize("kind", KINDS)
def test_fmpy_simulates_an_fmu_with_a_damaged_core(kind, sotc_fmu, tmp_path):
    fmu = _damaged(sotc_fmu, kind, tmp_path / f"{MODEL}.fmu")
    proc = subprocess.run([FMPY, "simulate", str(fmu), "--stop-time", "0.2", "--output-file", str(tmp_path / "o.csv")],
                          cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, (proc.returncode, proc.stderr[-2000:])  # was 135 (SIGBUS) when truncated
    assert (tmp_path / "o.csv").read_text().count("\n") > 10


@pytest.mark.parametrize("kind", KINDS)
def test_validate_fails_a_damaged_core_in_one_line(kind, sotc_fmu, tmp_path):
    fmu = _damaged(sotc_fmu, kind, tmp_path / f"{MODEL}.fmu")
    proc = run(["validate", str(fmu)], tmp_path, timeout=600)
    assert proc.returncode == 1, (proc.returncode, proc.stdout, proc.stderr)
    cores = [line for line in proc.stdout.splitlines() if "[cores]" in line]
    assert len(cores) == 1 and CORE in cores[0] and "not the one recorded" in cores[0], proc.stdout
    assert "Traceback" not in proc.stdout + proc.stderr


def _stamped(fmu: Path) -> None:
    """The stamp beside ``fmu`` rewritten to its bytes, as a copied folder would bring it: ``run`` then
    runs this FMU instead of building it again."""
    stamp = fmu.with_name(f"{MODEL}.sources.sha256")
    stamp.write_text(f"{stamp.read_text().split()[0]}\n{hashlib.sha256(fmu.read_bytes()).hexdigest()}\n")


def _metrics(stdout: str) -> list[str]:
    """The run's table without its wall-time column."""
    return [line.rsplit(None, 1)[0] for line in stdout.splitlines() if line.startswith("paper")]


def test_run_with_a_damaged_core_gives_the_intact_results(sotc_fmu, fmu_dir, tmp_path):
    args = ["run", "paper", "--stop-time", "2", "--no-recording", "--fmu-dir"]
    intact = run([*args, str(fmu_dir)], tmp_path)
    assert intact.returncode == 0, intact.stderr
    for kind in KINDS:
        folder = tmp_path / kind
        shutil.copytree(fmu_dir, folder)
        _stamped(_damaged(sotc_fmu, kind, folder / f"{MODEL}.fmu"))
        proc = run([*args, str(folder)], tmp_path)
        assert proc.returncode == 0, (kind, proc.returncode, proc.stderr)
        assert "building" not in proc.stderr  # the damaged FMU ran, it was not rebuilt
        assert _metrics(proc.stdout) == _metrics(intact.stdout), kind
    assert leftovers(tmp_path) == []  # no sotc_fmu_*, no sotc_run_*


def _summary(path: Path) -> dict:
    """A run's summary without its wall time: every computed number, to the bit."""
    return {k: v for k, v in json.loads(path.read_text()).items() if k != "wall_time_s"}


def test_any_damaged_core_falls_back_with_the_cores_that_cimport_it(sotc_fmu, fmu_dir, tmp_path):
    """Every extension of the FMU in turn, truncated: the FMU's compiled cores cimport one another, and
    a compiled core whose cimported module ran as .py failed to import ("no attribute '__pyx_capi__'",
    exit 1 for 5 of the SotcController's 7 cores); now they all run as .py, with the intact bits."""
    args = ["run", "paper", "--stop-time", "1", "--no-recording", "--summary"]
    intact = run([*args, str(tmp_path / "intact.json"), "--fmu-dir", str(fmu_dir)], tmp_path)
    assert intact.returncode == 0, intact.stderr
    cores = _extensions(sotc_fmu)
    assert len(cores) > 1 and any("fmu_numerics/elementary." in c for c in cores)  # the one most cores cimport
    for i, core in enumerate(cores):
        folder = tmp_path / f"damaged{i}"
        shutil.copytree(fmu_dir, folder)
        _stamped(_damaged(sotc_fmu, "truncated", folder / f"{MODEL}.fmu", core))
        proc = run([*args, str(tmp_path / f"{i}.json"), "--fmu-dir", str(folder)], tmp_path)
        assert proc.returncode == 0, (core, proc.returncode, proc.stderr)
        assert "building" not in proc.stderr, core
        assert _summary(tmp_path / f"{i}.json") == _summary(tmp_path / "intact.json"), core
        shutil.rmtree(folder)
    assert leftovers(tmp_path) == []


def test_a_damaged_core_without_its_py_is_refused_naming_it(sotc_fmu, fmu_dir, tmp_path):
    """Nothing to fall back to: the FMU refuses at instantiation, and ``run``'s one line says why (it
    said only "[ctor] findClass")."""
    folder = tmp_path / "fmus"
    shutil.copytree(fmu_dir, folder)
    damaged = _damaged(sotc_fmu, "truncated", tmp_path / "d.fmu")
    fmu = folder / f"{MODEL}.fmu"
    with zipfile.ZipFile(damaged) as z, zipfile.ZipFile(fmu, "w", zipfile.ZIP_DEFLATED) as out:
        for item in z.infolist():
            if not item.filename.endswith(CORE + "py"):
                out.writestr(item, z.read(item))
    _stamped(fmu)
    proc = run(["run", "paper", "--stop-time", "1", "--no-recording", "--fmu-dir", str(folder)], tmp_path)
    assert proc.returncode == 1, proc.stderr
    line = next(ln for ln in proc.stderr.splitlines() if "FAILED" in ln)
    assert CORE in line and "no .py to run instead" in line, proc.stderr
    assert leftovers(tmp_path) == []


def _cut_binary(fmu: Path, dest: Path) -> tuple[Path, str]:
    """The FMU with its Linux binary cut to half its length."""
    with zipfile.ZipFile(fmu) as z:
        name = next(n for n in z.namelist() if n.startswith("binaries/linux64/"))
        data = z.read(name)
    return _with(fmu, dest, {name: data[:len(data) // 2]}), name


def _cut_core_with_its_digest(fmu: Path, dest: Path) -> tuple[Path, str]:
    """The FMU with a compiled core cut to half its length, and ``compiled_cores.sha256`` rewritten to
    the cut file's digest (what a careless repair would do): the FMU's own check then loads it."""
    with zipfile.ZipFile(fmu) as z:
        name = next(n for n in z.namelist() if compiled.is_extension(n) and CORE in n)
        cut = z.read(name)[:len(z.read(name)) // 2]
        digests = f"resources/{DIGESTS}"
        rel = name[len("resources/"):]
        lines = [f"{hashlib.sha256(cut).hexdigest()}  {rel}" if line.split(None, 1)[1].strip() == rel else line
                 for line in z.read(digests).decode().splitlines() if line.strip()]
    return _with(fmu, dest, {name: cut, digests: ("\n".join(lines) + "\n").encode()}), name


def test_validate_reports_a_loader_crash_as_a_finding_naming_the_file(sotc_fmu, fmu_paths, tmp_path):
    """validate ended with SIGBUS (exit 135) and printed nothing: the FMU is now instantiated and run
    in a child process, and its crash is a finding naming the truncated file."""
    if not sys.platform.startswith("linux"):
        pytest.skip("the truncated binary is the Linux one")
    cases = [_cut_binary(fmu_paths["ArmPlant"], tmp_path / "ArmPlant.fmu"),
             _cut_core_with_its_digest(sotc_fmu, tmp_path / f"{MODEL}.fmu")]
    for fmu, name in cases:
        proc = run(["validate", str(fmu)], tmp_path, timeout=600)
        assert proc.returncode == 1, (name, proc.returncode, proc.stderr[-2000:])
        crashes = [line for line in proc.stdout.splitlines() if "the loader crashed with SIG" in line]
        assert crashes and all(name in line for line in crashes), proc.stdout
        assert "Traceback" not in proc.stdout + proc.stderr
    assert leftovers(tmp_path) == []  # the crashed children's sotc_fmu_* went with them
