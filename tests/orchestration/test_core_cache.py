"""Compiled cores kept in the private cache: one compile per content, checked as they are copied,
compiled again when anything they were made from, or the cache itself, differs."""
from __future__ import annotations

import contextlib
import os
import stat
import tempfile
import threading
from pathlib import Path

import pytest

from orchestration.fmu_build import build, compiled, packaging
from orchestration.fmu_build.build import cores_made
from orchestration.verified import MANIFEST

LIB = "sotc_Model_000000000000_lib"
MODULE = "fmu_numerics/elementary.py"


class FakeCompiler:
    """Stands in for Cython and the C compiler: writes each extension from its module's text, and counts."""

    def __init__(self):
        self.calls = 0

    def __call__(self, resources: Path, lib: str, present: list[str], pxd: dict[str, str]) -> None:
        self.calls += 1
        for rel in present:  # as Cython: a module's qualified name comes from the packages above it
            assert all((resources / lib / p / "__init__.py").is_file() for p in Path(rel).parents), rel
        for rel in present:
            text = (resources / lib / rel).read_bytes()
            (resources / lib / compiled._extension(rel)).write_bytes(b"ELF " + text + repr(sorted(pxd)).encode())


@pytest.fixture
def compiler(tmp_path, monkeypatch) -> FakeCompiler:
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path / "tmp"))  # the cache lives under TMPDIR
    (tmp_path / "tmp").mkdir()
    fake = FakeCompiler()
    monkeypatch.setattr(compiled, "_compile", fake)
    monkeypatch.setattr(compiled, "HOT", (MODULE,))
    return fake


def bundle(root: Path, source: str = "def cos(x):\n    return x\n") -> Path:
    module = root / "resources" / LIB / MODULE
    module.parent.mkdir(parents=True)
    module.write_text(source)
    for package in (module.parent, module.parent.parent):
        (package / "__init__.py").touch()
    return root / "resources"


PXD = {"fmu_numerics/elementary.pxd": "cpdef double cos(double x)\n"}


def extension(resources: Path) -> bytes:
    return (resources / LIB / compiled._extension(MODULE)).read_bytes()


def test_a_bundle_compiles_once_then_comes_from_the_cache(compiler, tmp_path):
    first = bundle(tmp_path / "a")
    assert compiled.compile_bundle(first, LIB, PXD) == [MODULE]
    second = bundle(tmp_path / "b")
    assert compiled.compile_bundle(second, LIB, PXD) == [MODULE]
    assert compiler.calls == 1
    assert extension(second) == extension(first)
    assert not (second / LIB / "fmu_numerics/elementary.pxd").exists()  # nothing staged for a compiler


def test_a_build_says_whether_its_cores_came_from_the_cache(compiler, tmp_path):
    assert compiled.build_cores(bundle(tmp_path / "a"), LIB, PXD) == ([MODULE], False)
    assert compiled.build_cores(bundle(tmp_path / "b"), LIB, PXD) == ([MODULE], True)
    assert cores_made([MODULE] * 3, True) == "3 cores from the cache"
    assert cores_made([MODULE] * 3, False) == "3 cores compiled"
    assert cores_made([], False) == "Python"


def test_cores_compiled_ahead_are_the_ones_the_build_takes(compiler, tmp_path, monkeypatch):
    """What ``pip install .`` compiles (setup.py: ``build.compile_ahead``) is what the FMU's build looks for."""
    monkeypatch.setattr(build, "compiles", lambda: True)
    build.compile_ahead(["ArmPlant"])
    assert compiler.calls == 1
    source = build.FMU_SOURCES["ArmPlant"]
    packages = {pkg: build.PACKAGE_ROOT / pkg for pkg in source.packages}
    stem = packaging.bundle_stem("ArmPlant", packaging.PLACEHOLDER_DIGEST)
    resources = tmp_path / "resources"
    packaging.stage("ArmPlant", build.PACKAGE_ROOT / source.script, packages, stem, resources)
    lib = f"{stem}_lib"
    assert compiled.build_cores(resources, lib, packaging._declarations(packages, resources / lib)) == ([MODULE], True)
    assert compiler.calls == 1


@pytest.mark.parametrize("change", ["source", "declarations", "name", "compiler"])
def test_what_the_extension_is_made_from_is_in_its_key(compiler, tmp_path, monkeypatch, change):
    compiled.compile_bundle(bundle(tmp_path / "a"), LIB, PXD)
    source, pxd, lib = "def cos(x):\n    return x\n", dict(PXD), LIB
    if change == "source":
        source = "def cos(x):\n    return -x\n"
    elif change == "declarations":
        pxd = {"fmu_numerics/elementary.pxd": "cpdef double cos(double x) noexcept\n"}
    elif change == "name":  # another model's placeholder: its module names are in the extension
        lib = "sotc_Other_000000000000_lib"
    else:
        monkeypatch.setenv("CC", "clang")
    resources = tmp_path / "b" / "resources"
    (resources / lib / MODULE).parent.mkdir(parents=True)
    (resources / lib / MODULE).write_text(source)
    for package in (resources / lib, (resources / lib / MODULE).parent):
        (package / "__init__.py").touch()
    compiled.compile_bundle(resources, lib, pxd)
    assert compiler.calls == 2


@pytest.mark.parametrize("damage", ["changed", "truncated", "removed", "manifest"])
def test_a_damaged_cache_is_never_copied_and_is_made_again(compiler, tmp_path, damage):
    first = bundle(tmp_path / "a")
    compiled.compile_bundle(first, LIB, PXD)
    good = extension(first)
    cache = compiled.cached(first, LIB, [MODULE], PXD)
    stored = cache / compiled._extension(MODULE)
    if damage == "changed":
        stored.write_bytes(b"ELF planted code")
    elif damage == "truncated":
        stored.write_bytes(good[:3])
    elif damage == "removed":
        stored.unlink()
    else:
        (cache / MANIFEST).write_text("0" * 64 + f"  {compiled._extension(MODULE)}\n")
    second = bundle(tmp_path / "b")
    compiled.compile_bundle(second, LIB, PXD)
    assert compiler.calls == 2
    assert extension(second) == good
    assert stored.read_bytes() == good  # the cache holds the new compile, whole
    aside = [p for p in cache.parent.iterdir() if p.name.startswith(".") and p.name != compiled.LOCK_FILE]
    assert aside == []  # the damaged folder went, nothing is left beside it


def test_the_cache_is_private(compiler, tmp_path):
    first = bundle(tmp_path / "a")
    compiled.compile_bundle(first, LIB, PXD)
    cache = compiled.cached(first, LIB, [MODULE], PXD)
    root = next(p for p in cache.parents if p.name == f"sotc-cosim-{os.getuid()}")
    assert stat.S_IMODE(os.stat(root).st_mode) & 0o077 == 0


def test_a_failed_compile_stores_nothing(compiler, tmp_path, monkeypatch):
    def fails(*args):
        raise compiled.CompileError("compiling the cores failed: no")

    monkeypatch.setattr(compiled, "_compile", fails)
    first = bundle(tmp_path / "a")
    with pytest.raises(compiled.CompileError):
        compiled.compile_bundle(first, LIB, PXD)
    assert not compiled.cached(first, LIB, [MODULE], PXD).exists()


def test_builds_at_once_compile_a_bundle_once(compiler, tmp_path, monkeypatch):
    """Two builds of the same bundle at the same moment (two test workers, two users' commands): the second
    waits for the first's compile and copies it. The compile goes on only once both builds have come to the
    cache's lock, so the second is waiting while the first compiles."""
    slow, arrived, both = FakeCompiler(), [], threading.Event()
    one_compiler = compiled._one_compiler

    @contextlib.contextmanager
    def counted(folder):
        arrived.append(folder)  # list.append is atomic
        if len(arrived) == 2:
            both.set()
        with one_compiler(folder):
            yield

    def compile_when_both_arrived(*args):
        assert both.wait(timeout=60), "the second build never came to the cache's lock"
        slow(*args)

    monkeypatch.setattr(compiled, "_one_compiler", counted)
    monkeypatch.setattr(compiled, "_compile", compile_when_both_arrived)
    bundles = [bundle(tmp_path / name) for name in ("a", "b")]
    threads = [threading.Thread(target=compiled.compile_bundle, args=(b, LIB, PXD)) for b in bundles]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(timeout=60)
    assert slow.calls == 1
    assert extension(bundles[0]) == extension(bundles[1])


def test_without_a_version_to_key_on_the_cores_are_compiled_every_time(compiler, tmp_path, monkeypatch):
    """Cython or setuptools found without package metadata (on PYTHONPATH): no key, no cache, no error."""
    from importlib import metadata

    def unnamed():
        raise metadata.PackageNotFoundError("Cython")

    monkeypatch.setattr(compiled, "_toolchain", unnamed)
    for name in ("a", "b"):
        assert compiled.compile_bundle(bundle(tmp_path / name), LIB, PXD) == [MODULE]
    assert compiler.calls == 2
