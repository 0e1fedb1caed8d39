"""The private caches stay under their bound (``orchestration.verified``): every source change added a
compiled-cores folder and every FMU content an unpacked one, for good (115 MB for 8 models). Beyond
``SOTC_COSIM_CACHE_LIMIT`` the least recently used entries go, never one a process uses; ``sotc-cosim
cache`` lists and clears them. The order of use is set on the folders' times, not waited for."""
from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

import pytest

from orchestration.cli import main
from orchestration.outputs import private_folder
from orchestration.run.unpacked import unpacked

KIB = 1024
LIMIT = "SOTC_COSIM_CACHE_LIMIT"


@pytest.fixture
def tmp(tmp_path, monkeypatch) -> Path:
    """A TMPDIR of the test's own, where the private caches live."""
    folder = tmp_path / "tmp"
    folder.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(folder))
    monkeypatch.setenv("TMPDIR", str(folder))
    return folder


def _entry(parts: tuple[str, ...], name: str, size: int, used: float) -> Path:
    """A cache entry of ``size`` bytes last used at ``used`` (s since the epoch)."""
    folder = private_folder(*parts) / (name * 64)[:64]
    folder.mkdir()
    (folder / "data").write_bytes(b"x" * size)
    os.utime(folder, (used, used))
    return folder


def _fmu(path: Path, value: int) -> Path:
    with zipfile.ZipFile(path, "w") as z:
        z.writestr("modelDescription.xml", "<fmiModelDescription/>")
        z.writestr("resources/model.py", f"VALUE = {value}\n" + "#" * 100 * KIB)  # 100 KiB unpacked
    return path


def _holding(fmu: Path, tmp: Path) -> subprocess.Popen:
    """Another process that has loaded ``fmu`` from the cache (and keeps it until its stdin closes)."""
    code = ("import sys\nfrom orchestration.run.unpacked import unpacked\n"
            "print(unpacked(sys.argv[1]), flush=True)\nsys.stdin.read()\n")
    proc = subprocess.Popen([sys.executable, "-c", code, str(fmu)], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                            text=True, env={**os.environ, "TMPDIR": str(tmp)})
    assert proc.stdout.readline().strip()  # it holds the folder now
    return proc


def test_a_new_entry_makes_the_least_recently_used_go_but_not_one_in_use(tmp, tmp_path, monkeypatch):
    in_use = _holding(_fmu(tmp_path / "InUse.fmu", 0), tmp)
    try:
        held = next(private_folder("fmus", "unpacked").iterdir())
        os.utime(held, (1000, 1000))  # the least recently used of all, but in use
        old = [_entry(("cores", "compiled"), "a", 100 * KIB, 2000), _entry(("fmus",), "b", 100 * KIB, 3000)]
        recent = _entry(("fmus", "unpacked"), "c", 100 * KIB, 4000)
        monkeypatch.setenv(LIMIT, "350K")  # room for three of the five after the new one
        new = Path(unpacked(_fmu(tmp_path / "New.fmu", 1)))
        assert held.is_dir() and recent.is_dir() and new.is_dir()
        assert not any(p.exists() for p in old)  # the two least recently used that nobody uses
        assert not [p for p in held.parent.parent.rglob(".*.gone.*")]  # nothing left aside
    finally:
        in_use.stdin.close()
        in_use.wait(timeout=60)


def test_cache_lists_and_clears_what_is_not_in_use(tmp, tmp_path, capsys):
    in_use = _holding(_fmu(tmp_path / "InUse.fmu", 0), tmp)
    try:
        _entry(("cores", "compiled"), "a", 300 * KIB, 2000)
        _entry(("fmus",), "b", 100 * KIB, 3000)
        assert main(["cache"]) == 0
        out = capsys.readouterr().out
        assert "compiled cores" in out and "0.3 MiB" in out and "total" in out and "3 entries" in out, out
        assert main(["cache", "clear"]) == 0
        out = capsys.readouterr().out
        assert out.startswith("removed 2 cache entries (0.4 MiB); kept 1 in use"), out
        assert [p.name for p in private_folder("fmus").iterdir()] == ["unpacked"]
    finally:
        in_use.stdin.close()
        in_use.wait(timeout=60)
    assert main(["cache", "clear"]) == 0 and capsys.readouterr().out.startswith("removed 1 cache entry ")
    assert not any(private_folder("fmus", "unpacked").iterdir())


def test_a_limit_that_is_no_size_is_refused_in_one_line(tmp, monkeypatch, capsys):
    monkeypatch.setenv(LIMIT, "lots")
    assert main(["scenarios"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and LIMIT in err[0] and "lots" in err[0]
