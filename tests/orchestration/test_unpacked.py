"""The private cache of unpacked FMUs: made once per content, checked at every load, made again when
anything in it differs from what was unpacked."""
from __future__ import annotations

import os
import stat
import tempfile
import zipfile
from pathlib import Path

import pytest

from orchestration.run.unpacked import unpacked
from orchestration.verified import MANIFEST


@pytest.fixture
def fmu(tmp_path, monkeypatch) -> Path:
    """A small archive laid out like an FMU, and a TMPDIR of its own (where the cache lives)."""
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path / "tmp"))
    (tmp_path / "tmp").mkdir()
    path = tmp_path / "Model.fmu"
    with zipfile.ZipFile(path, "w") as z:
        z.writestr("modelDescription.xml", "<fmiModelDescription/>")
        z.writestr("resources/model.py", "VALUE = 1\n")
        z.writestr("resources/lib/core.py", "def f():\n    return 2\n")
    return path


def test_unpacked_once_then_reused(fmu):
    first = Path(unpacked(fmu))
    assert (first / "resources" / "model.py").read_text() == "VALUE = 1\n"
    made = (first / MANIFEST).stat().st_mtime_ns
    assert Path(unpacked(fmu)) == first
    assert (first / MANIFEST).stat().st_mtime_ns == made  # not unpacked again


def test_cache_is_private(fmu):
    folder = Path(unpacked(fmu))
    root = next(p for p in folder.parents if p.name == f"sotc-cosim-{os.getuid()}")  # the user's own root
    assert stat.S_IMODE(os.stat(root).st_mode) & 0o077 == 0


@pytest.mark.parametrize("damage", ["changed", "truncated", "planted", "removed"])
def test_a_damaged_folder_is_unpacked_again(fmu, damage):
    folder = Path(unpacked(fmu))
    module = folder / "resources" / "lib" / "core.py"
    if damage == "changed":
        module.write_text("def f():\n    return 3\n")
    elif damage == "truncated":
        module.write_bytes(module.read_bytes()[:5])
    elif damage == "planted":
        (folder / "resources" / "lib" / "extra.py").write_text("raise SystemExit\n")
    else:
        module.unlink()
    again = Path(unpacked(fmu))
    assert again == folder
    assert module.read_text() == "def f():\n    return 2\n"
    assert not (folder / "resources" / "lib" / "extra.py").exists()
    assert not [p for p in folder.parent.iterdir() if p.name.startswith(".")]  # nothing left aside


def test_another_content_gets_its_own_folder(fmu, tmp_path):
    other = tmp_path / "Other.fmu"
    with zipfile.ZipFile(other, "w") as z:
        z.writestr("resources/model.py", "VALUE = 2\n")
    assert unpacked(other) != unpacked(fmu)
