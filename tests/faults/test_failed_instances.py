"""An FMU that cannot be instantiated (its binary missing, its Python failing at import) leaves nothing
behind: ``FmuInstance`` and ``FmuInstance3`` (``fmi_direct``, ``fmi3_direct``; what ``validate``,
``cross-check`` and ``interop`` instantiate through) remove the ``$TMPDIR/sotc_fmu_*`` folder they
extracted into (one was left per FMU that ``validate`` could not instantiate). In a child process:
a failing pythonfmu binary must not take the test process with it."""
from __future__ import annotations

import os
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

MODEL = "ArmPlant"
OPEN = """import sys
from pathlib import Path
from orchestration.run.fmi3_direct import open_instance
try:
    open_instance(Path(sys.argv[1])).free()
except Exception as exc:
    print("refused:", type(exc).__name__, exc)
else:
    print("instantiated")
"""


def _broken(fmu: Path, how: str, dest: Path) -> Path:
    with zipfile.ZipFile(fmu) as z, zipfile.ZipFile(dest, "w", zipfile.ZIP_DEFLATED) as out:
        for item in z.infolist():
            if how == "no binary" and item.filename.startswith("binaries/"):
                continue
            data = z.read(item)
            if how == "script fails" and item.filename.startswith("resources/sotc_") and item.filename.endswith(".py"):
                data = b"raise ImportError('planted by the test')\n" + data
            out.writestr(item, data)
    return dest


# FMI 3, "script fails": its first line raises before the script's import guard, and pythonfmu3's binary
# crashes the host (SIGSEGV): not a case here (test_import_failures.py has the failures the guard covers)
@pytest.mark.parametrize("fmi, how", [(2, "no binary"), (2, "script fails"), (3, "no binary")])
def test_an_fmu_that_cannot_be_instantiated_leaves_no_folder(how, fmi, request, tmp_path):
    paths = request.getfixturevalue("fmu_paths" if fmi == 2 else "fmi3_paths")
    fmu = _broken(paths[MODEL], how, tmp_path / f"{MODEL}.fmu")
    tmp = tmp_path / "tmp"
    tmp.mkdir()
    proc = subprocess.run([sys.executable, "-c", OPEN, str(fmu)], capture_output=True, text=True, timeout=120,
                          env={**os.environ, "TMPDIR": str(tmp)})
    assert proc.stdout.startswith("refused:"), (proc.returncode, proc.stdout, proc.stderr[-2000:])
    assert sorted(p.name for p in tmp.iterdir()) == []  # no sotc_fmu_*
