"""``sotc-cosim validate`` on FMUs that hang or cannot be read, and validate itself signalled or killed.

- An FMI 3 FMU whose script is missing: pythonfmu3's binary hangs for ever at instantiation (it throws out
  of the import holding Python's lock); validate waited 10 minutes per child run, 30 for the three, and
  ignored SIGTERM meanwhile. The missing script is a finding now, and such an FMU is never instantiated.
- An FMU whose instantiation hangs for another reason is killed after ``children.INSTANTIATE_LIMIT``.
- A signal stops validate at once (exit 128 + the signal, one line), its child processes killed.
- A SIGKILL left ``sotc_validate_*`` and ``sotc_cores_*`` folders in TMPDIR for ever: validate works in
  one folder named after its process, which the next validate removes once that process is gone; its
  children die with it.
- A file that is not an FMU was shown as ``?`` with ``ok`` for every check that never ran."""
from __future__ import annotations

import signal
import zipfile
from pathlib import Path

import psutil
import pytest

from support.cli import leftovers, one_line, run, signal_when, start

from orchestration.cli import main
from orchestration.fmu_build import shim

MODEL = "ArmPlant"
WAIT_S = 120  # for a process to show or to go: it takes well under a second


def _copy(fmu: Path, dest: Path, change) -> Path:
    """A copy of ``fmu`` with each entry as ``change(stem, name, data)`` gives it ((name, data); None: left
    out), its .pyc files left out (``stem``: the module slavemodule.txt names)."""
    with zipfile.ZipFile(fmu) as z, zipfile.ZipFile(dest, "w", zipfile.ZIP_DEFLATED) as out:
        stem = z.read("resources/slavemodule.txt").decode().strip()
        for item in z.infolist():
            changed = None if item.filename.endswith(".pyc") else change(stem, item.filename, z.read(item))
            if changed is not None:
                out.writestr(changed[0], changed[1])
    return dest


def _without_script(stem: str, name: str, data: bytes):
    return None if name == f"resources/{stem}.py" else (name, data)


def _without_script_or_shim(stem: str, name: str, data: bytes):
    """No script, and pythonfmu3's binary under the model's name, as a build without a C compiler ships it."""
    if name == f"binaries/{shim.platform_folder()}/{MODEL}.so":
        return None
    return _without_script(stem, name.replace(f"{MODEL}{shim.INNER_SUFFIX}.so", f"{MODEL}.so"), data)


def _hanging(stem: str, name: str, data: bytes):
    """The FMU's code sleeps for ever while it is imported."""
    return name, data + b"\nimport time\ntime.sleep(10**6)\n" if name == f"resources/{stem}_lib/fmi_slave/slave.py" \
        else data


@pytest.fixture
def arm3(fmi3_paths) -> Path:
    return fmi3_paths[MODEL]


def _children_seen(proc, seen: list) -> bool:
    """Whether a running validate has a child process that loads an FMU (``python -m
    orchestration.compliance...``); each one found is added to ``seen``."""
    try:
        seen += [p for p in psutil.Process(proc.pid).children(recursive=True)
                 if any(a.startswith("orchestration.compliance.") for a in p.cmdline())]
    except psutil.Error:  # the command or its child ended meanwhile
        pass
    return bool(seen)


def _gone(processes: list) -> bool:
    _, alive = psutil.wait_procs(processes, timeout=WAIT_S)
    return not alive


@pytest.mark.parametrize("binary", ["the shim", "pythonfmu3's binary alone"])
def test_an_fmi3_fmu_whose_script_is_missing_is_a_finding_not_a_hang(binary, shimmed_arm3, tmp_path):
    change = _without_script if binary == "the shim" else _without_script_or_shim
    fmu = _copy(shimmed_arm3, tmp_path / f"{MODEL}.fmu", change)
    proc = run(["validate", str(fmu)], tmp_path)  # a hang fails at support.cli's time limit
    assert proc.returncode == 1, (proc.returncode, proc.stdout, proc.stderr[-2000:])
    assert "resources/slavemodule.txt names the module" in proc.stdout and ".py is missing" in proc.stdout
    assert "[starts, dependencies, cores] not run: the FMU's code cannot be imported" in proc.stdout, proc.stdout
    assert leftovers(tmp_path) == []


def test_an_fmu_whose_instantiation_hangs_is_killed_after_the_limit(arm3, tmp_path, monkeypatch):
    from orchestration.compliance import children
    from orchestration.compliance.validate import validate_fmu_file

    monkeypatch.setattr(children, "INSTANTIATE_LIMIT", 5.0)  # the FMU never returns: any limit shows it
    report = validate_fmu_file(_copy(arm3, tmp_path / f"{MODEL}.fmu", _hanging))
    assert report.problems["dependencies"] == [
        "instantiating the FMU did not return within 5 s: the process was killed"], report.problems
    assert {"starts", "cores"} <= set(report.not_run), report.not_run


@pytest.mark.slow
def test_sigterm_stops_validate_while_an_fmu_hangs(arm3, tmp_path):
    proc = start(["validate", str(_copy(arm3, tmp_path / f"{MODEL}.fmu", _hanging))], tmp_path)
    seen: list[psutil.Process] = []
    code, out, err = signal_when(proc, lambda: _children_seen(proc, seen), signal.SIGTERM, timeout=WAIT_S)
    assert seen, "no child process loaded the FMU"
    assert code == 143, (code, out, err)
    assert one_line(err) == "sotc-cosim: interrupted (SIGTERM): stopped while checking FMUs; no verdict was given"
    assert _gone(seen)
    assert leftovers(tmp_path, folders=True) == []


@pytest.mark.slow
def test_a_validate_killed_with_sigkill_leaves_nothing_the_next_one_does_not_remove(arm3, tmp_path):
    proc = start(["validate", str(_copy(arm3, tmp_path / f"{MODEL}.fmu", _hanging))], tmp_path)
    seen: list[psutil.Process] = []
    code, _, _ = signal_when(proc, lambda: _children_seen(proc, seen), signal.SIGKILL, timeout=WAIT_S)
    assert seen and code == -signal.SIGKILL
    assert _gone(seen), "the child outlived the killed validate"
    assert [p.name for p in (tmp_path / "tmp").iterdir() if p.name.startswith("sotc_validate_")]  # what it left
    not_an_fmu = tmp_path / "notes.txt"
    not_an_fmu.write_text("not an FMU")
    assert run(["validate", str(not_an_fmu)], tmp_path).returncode == 1
    assert leftovers(tmp_path, folders=True) == []


@pytest.mark.parametrize("content", ["text", "a zip without a modelDescription"])
def test_a_file_that_is_not_an_fmu_is_named_and_no_check_it_did_not_run_reads_ok(content, tmp_path, capsys):
    from orchestration.compliance.validate import CHECKS

    path = tmp_path / "passwd"
    if content == "text":
        path.write_text("root:x:0:0:root:/root:/bin/bash\n")
    else:
        with zipfile.ZipFile(path, "w") as z:
            z.writestr("readme.txt", "hello")
    assert main(["validate", str(path)]) == 1
    out = capsys.readouterr().out
    row = next((line.split() for line in out.splitlines() if line.startswith("passwd ")), None)
    assert row is not None and row[-1] == "FAIL", out
    cells = dict(zip(CHECKS, row[1:-1]))
    failed = "archive" if content == "text" else "descriptions"  # where the reading stopped
    assert cells[failed] == "FAIL(1)", out
    assert [c for c in CHECKS[CHECKS.index(failed) + 1:] if cells[c] == "ok"] == [], out  # none of those ran
    assert [line for line in out.splitlines() if line.startswith(f"  passwd [{failed}] ")], out
    assert [line for line in out.splitlines() if line.startswith("  passwd [") and "] not run: " in line], out
