"""An FMU whose Python fails while the host's binary imports it: instantiation fails with a logged message
naming the exception, and the host goes on. pythonfmu3 0.3.4's binary (FMI 3) prints the exception with
``PyErr_Print``, which ends the process on ``SystemExit`` (exit 3 for ``SystemExit(3)``), and then goes on
with the module it did not get (SIGSEGV on an ImportError, e.g. a host without numpy). The FMI 3 script
now imports the FMU's code under a guard (``orchestration/fmu_build/fmi3.py``). pythonfmu 0.7's binary
(FMI 2) refused both already; the same test keeps it so. In a child process (``support.fmi_child``)."""
from __future__ import annotations

import json
import re
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

from support import child_env

MODEL = "ArmPlant"
MODULE = "fmi_slave/slave.py"  # a bundled module never compiled: the planted statement runs when it is imported
PLANTED = {  # what fails -> (how the FMU's files change, what the logged message names)
    "SystemExit in its code": (lambda name, data: data + b"\nraise SystemExit(3)\n" if name.endswith(MODULE) else data,
                               "SystemExit"),
    "ImportError in its code": (lambda name, data: data + b"\nraise ImportError('planted')\n" if name.endswith(MODULE)
                                else data, "planted"),
    "a host without the numpy it needs": (lambda name, data: re.sub(rb"'numpy>=[^']*'", b"'numpy>=999'", data)
                                          if name.count("/") == 1 and name.endswith(".py") else data, "'numpy'"),
}


def _planted(fmu: Path, what: str, dest: Path) -> Path:
    """A copy of ``fmu`` with ``PLANTED[what]`` applied to its Python files (their .pyc left out)."""
    change = PLANTED[what][0]
    with zipfile.ZipFile(fmu) as z, zipfile.ZipFile(dest, "w", zipfile.ZIP_DEFLATED) as out:
        for item in z.infolist():
            if not item.filename.endswith(".pyc"):
                out.writestr(item, change(item.filename, z.read(item)))
    return dest


@pytest.mark.parametrize("what", PLANTED)
@pytest.mark.parametrize("fmi", [2, 3])
def test_an_fmu_whose_code_fails_at_import_fails_instantiation_and_the_host_goes_on(fmi, what, request, tmp_path):
    paths = request.getfixturevalue("fmu_paths" if fmi == 2 else "fmi3_paths")
    fmu = _planted(paths[MODEL], what, tmp_path / f"{MODEL}.fmu")
    (tmp_path / "tmp").mkdir()
    proc = subprocess.run([sys.executable, "-m", "support.fmi_child", str(fmu)], cwd=tmp_path, capture_output=True,
                          text=True, timeout=120, env={**child_env(), "TMPDIR": str(tmp_path / "tmp")})
    assert proc.returncode == 0 and proc.stdout.startswith("{"), (proc.returncode, proc.stderr[-2000:])  # it went on
    answer = json.loads(proc.stdout.splitlines()[0])
    assert not answer["ok"]
    assert [text for _, text in answer["messages"] if PLANTED[what][1] in text], answer["messages"]
