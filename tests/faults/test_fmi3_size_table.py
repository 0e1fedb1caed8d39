"""What the FMI 3 FMU's binary (the shim, ``orchestration/fmu_build/fmi3_shim.c``) reads at instantiation,
planted or damaged in an extracted FMU: instantiation fails with a logged message naming the file and
what is wrong with it, before pythonfmu3's binary is called, and never hangs.

- The size table ``resources/fmi3_sizes.txt``: a size of ``-1`` was read as SIZE_MAX (a get with nValues 0
  then passed), sizes could overflow their sum, an empty table or one cut short by a NUL byte was taken
  whole, a FIFO in its place blocked the host for ever. Signs, sizes above 1,000,000, a value reference
  twice, a type FMI 3 does not have, an empty file, a NUL byte and anything but a regular file are refused.
- The script ``resources/slavemodule.txt`` names: pythonfmu3's binary hangs for ever without it.
- A resourcePath too long for the paths of its files was reported as a damaged size table.

Each instantiation runs in a child process (``support.fmi_child``) under a time limit: a hang fails the test."""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
from fmpy import extract, read_model_description
from fmpy.fmi3 import FMU3Slave

from support import child_env

from orchestration.fmu_build import shim

MODEL = "ArmPlant"
ERROR = 3  # fmi3Error
LIMIT = 120  # s for one instantiation in the child: it takes about one


@pytest.fixture
def folder(shimmed_arm3, tmp_path) -> Path:
    """The FMI 3 arm with its shim, extracted."""
    return Path(extract(str(shimmed_arm3), unzipdir=str(tmp_path / "fmu")))


def _instantiated(folder: Path, tmp_path: Path) -> dict:
    """The child's answer to instantiating the FMU extracted in ``folder``: {"ok": ..., "messages": ...}."""
    (tmp_path / "tmp").mkdir(exist_ok=True)
    proc = subprocess.run([sys.executable, "-m", "support.fmi_child", str(folder)], cwd=tmp_path, capture_output=True,
                          text=True, timeout=LIMIT, env={**child_env(), "TMPDIR": str(tmp_path / "tmp")})
    answer = next((json.loads(line) for line in proc.stdout.splitlines() if line.startswith("{")), None)
    assert proc.returncode == 0 and answer is not None, (proc.returncode, proc.stderr[-2000:])
    return answer


def _with_size(table: Path, name: str, size: str) -> None:
    """The line of ``name`` in the table with ``size`` in place of its size."""
    lines = table.read_text().splitlines(keepends=True)
    table.write_text("".join(" ".join([ln.split()[0], size, *ln.split(" ")[2:]]) if ln.split()[-1] == name else ln
                             for ln in lines))


def _twice(table: Path) -> None:
    lines = table.read_text().splitlines(keepends=True)
    table.write_text("".join(lines + [lines[1]]))


def _replaced(table: Path, old: str, new: str) -> None:
    table.write_text(table.read_text().replace(old, new, 1))


def _nul(table: Path) -> None:
    lines = table.read_text().splitlines(keepends=True)
    table.write_text("".join(lines[:3]) + "\0" + "".join(lines[3:]))  # the first three lines parse alone


def _fifo(table: Path) -> None:
    table.unlink()
    os.mkfifo(table)


def _device(table: Path) -> None:
    table.unlink()
    table.symlink_to("/dev/zero")


TABLES = {  # damage -> (how, what the message says)
    "a negative size": (lambda t: _with_size(t, "tau", "-1"), "is not a number from 1 to 1000000"),
    "a signed size": (lambda t: _with_size(t, "tau", "+2"), "is not a number from 1 to 1000000"),
    "a size beyond 64 bits": (lambda t: _with_size(t, "tau", str(2**64)), "is not a number from 1 to 1000000"),
    "sizes that overflow their sum": (lambda t: (_with_size(t, "tau", str(2**63)), _with_size(t, "phi", str(2**63))),
                                      "is not a number from 1 to 1000000"),
    "a value reference twice": (_twice, "comes twice"),
    "a type FMI 3 does not have": (lambda t: _replaced(t, " Float64 ", " Float99 "), "has no FMI 3 type"),
    "an empty table": (lambda t: t.write_text(""), "is empty"),
    "a table cut by a NUL byte": (_nul, "holds a NUL byte"),
    "a FIFO": (_fifo, "is not a regular file"),
    "a link to a device": (_device, "is a symbolic link"),
}


@pytest.mark.parametrize("damage", TABLES)
def test_a_hostile_size_table_fails_instantiation_naming_it(damage, folder, tmp_path):
    how, said = TABLES[damage]
    how(folder / "resources" / shim.SIZES_FILE)
    answer = _instantiated(folder, tmp_path)
    assert not answer["ok"]
    errors = [text for status, text in answer["messages"] if status == ERROR]
    assert [t for t in errors if shim.SIZES_FILE in t and said in t], errors


@pytest.mark.parametrize("missing", ["the script", "slavemodule.txt"])
def test_an_fmu_whose_script_is_missing_fails_instantiation_instead_of_hanging(missing, folder, tmp_path):
    resources = folder / "resources"
    script = resources / f"{(resources / 'slavemodule.txt').read_text().strip()}.py"
    (script if missing == "the script" else resources / "slavemodule.txt").unlink()
    answer = _instantiated(folder, tmp_path)
    assert not answer["ok"]
    named = script.name if missing == "the script" else "slavemodule.txt"
    assert [t for s, t in answer["messages"] if s == ERROR and named in t and "cannot be imported" in t], answer


def test_a_resource_path_too_long_for_its_files_is_reported_as_too_long(folder):
    md = read_model_description(str(folder))
    fmu = FMU3Slave(guid=md.guid, unzipDirectory=str(folder), modelIdentifier=MODEL, instanceName="long")
    fmu.unzipDirectory = "/" + "d" * 4090  # instantiate passes <unzipDirectory>/resources/
    messages: list[tuple[int, str]] = []
    with pytest.raises(Exception, match="instantiate"):
        fmu.instantiate(loggingOn=True, logMessage=lambda env, status, category, text: messages.append(
            (int(status), (text or b"").decode(errors="replace"))))
    length = len(os.path.join(fmu.unzipDirectory, "resources") + os.path.sep)
    assert [t for s, t in messages if s == ERROR and f"resourcePath is too long: {length} characters" in t], messages
