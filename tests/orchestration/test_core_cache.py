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

LIB = f"{packaging.PLACEHOLDER}_lib"
MODULE = "fmu_numerics/elementary.py"
HOT = compiled.HOT  # the real list, for the tests that stage real bundles


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
    assert compiled.build_cores(bundle(tmp_path / "a"), LIB, PXD) == ([MODULE], 0)
    assert compiled.build_cores(bundle(tmp_path / "b"), LIB, PXD) == ([MODULE], 1)
    assert cores_made([MODULE] * 3, 3) == "3 cores from the cache"
    assert cores_made([MODULE] * 3, 0) == "3 cores compiled"
    assert cores_made([MODULE] * 3, 2) == "3 cores: 2 from the cache, 1 compiled"
    assert cores_made([MODULE], 1) == "1 core from the cache"
    assert cores_made([], 0) == "Python"


@pytest.mark.parametrize("model", ["ArmPlant", "SotcController"])
def test_cores_compiled_ahead_are_the_ones_every_build_takes(compiler, tmp_path, monkeypatch, model):
    """What ``pip install .`` compiles (setup.py: ``packaging.compile_ahead``) is what each FMU's build looks for:
    the plant's bundle and the controller's alike find every core they carry in the cache."""
    monkeypatch.setattr(compiled, "HOT", HOT)
    monkeypatch.setattr(compiled, "unavailable", lambda: None)
    monkeypatch.setenv(compiled.SWITCH, "1")
    packaging.compile_ahead(build.PACKAGE_ROOT)
    assert compiler.calls == 1
    source = build.FMU_SOURCES[model]
    packages = {pkg: build.PACKAGE_ROOT / pkg for pkg in source.packages}
    stem = packaging.placeholder(model)
    resources = tmp_path / "resources"
    packaging.stage(model, build.PACKAGE_ROOT / source.script, packages, stem, resources)
    lib = f"{stem}_lib"
    cores, reused = compiled.build_cores(resources, lib, packaging._declarations(packages, resources / lib))
    assert cores and reused == len(cores)
    assert compiler.calls == 1


def test_a_core_two_bundles_carry_is_compiled_once(compiler, tmp_path, monkeypatch):
    """The plant's bundle compiles the numerics; the controller's, built next, compiles only what it adds."""
    monkeypatch.setattr(compiled, "HOT", HOT)
    built = {}
    for model in ("ArmPlant", "SotcController"):
        source = build.FMU_SOURCES[model]
        packages = {pkg: build.PACKAGE_ROOT / pkg for pkg in source.packages}
        resources = tmp_path / model / "resources"
        stem = packaging.placeholder(model)
        packaging.stage(model, build.PACKAGE_ROOT / source.script, packages, stem, resources)
        lib = f"{stem}_lib"
        built[model] = compiled.build_cores(resources, lib, packaging._declarations(packages, resources / lib))
    plant, controller = built["ArmPlant"], built["SotcController"]
    assert plant[1] == 0 and "fmu_numerics/elementary.py" in plant[0]
    assert "fmu_numerics/elementary.py" in controller[0]
    assert controller[1] == len(set(plant[0]) & set(controller[0])) > 0
    assert compiler.calls == 2


def test_every_model_is_staged_under_one_placeholder_as_long_as_its_stem():
    for model in build.FMU_SOURCES:
        assert packaging.placeholder(model) == packaging.PLACEHOLDER
        assert len(packaging.bundle_stem(model, "f" * 64)) == len(packaging.PLACEHOLDER) == packaging.STEM_LENGTH
    long_name = "M" * 40  # a name too long for STEM_LENGTH keeps 12 digits, and a placeholder of its length
    assert packaging.bundle_stem(long_name, "f" * 64) == f"sotc_{long_name}_{'f' * 12}"
    assert len(packaging.placeholder(long_name)) == len(packaging.bundle_stem(long_name, "0" * 64))


@pytest.mark.parametrize("change", ["source", "declarations", "name", "compiler"])
def test_what_the_extension_is_made_from_is_in_its_key(compiler, tmp_path, monkeypatch, change):
    compiled.compile_bundle(bundle(tmp_path / "a"), LIB, PXD)
    source, pxd, lib = "def cos(x):\n    return x\n", dict(PXD), LIB
    if change == "source":
        source = "def cos(x):\n    return -x\n"
    elif change == "declarations":
        pxd = {"fmu_numerics/elementary.pxd": "cpdef double cos(double x) noexcept\n"}
    elif change == "name":  # another placeholder: its module names are in the extension
        lib = f"{packaging.placeholder('M' * 40)}_lib"
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
    cache = compiled.cached(first, LIB, MODULE, PXD)
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
    cache = compiled.cached(first, LIB, MODULE, PXD)
    root = next(p for p in cache.parents if p.name == f"sotc-cosim-{os.getuid()}")
    assert stat.S_IMODE(os.stat(root).st_mode) & 0o077 == 0


def test_a_failed_compile_stores_nothing(compiler, tmp_path, monkeypatch):
    def fails(*args):
        raise compiled.CompileError("compiling the cores failed: no")

    monkeypatch.setattr(compiled, "_compile", fails)
    first = bundle(tmp_path / "a")
    with pytest.raises(compiled.CompileError):
        compiled.compile_bundle(first, LIB, PXD)
    assert not compiled.cached(first, LIB, MODULE, PXD).exists()


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


def test_a_modules_key_takes_the_declarations_it_cimports_and_no_other():
    """A change in a ``.pxd`` the module cimports (through another) compiles it again; a change in an
    unrelated one does not."""
    lib = LIB
    pxd = {"fmu_controller/sotc.pxd": f"from {lib}.fmu_controller.sotc_math cimport solve\n",
           "fmu_controller/sotc_math.pxd": f"from {lib}.fmu_numerics.elementary cimport tanh\n",
           "fmu_numerics/elementary.pxd": "cpdef double tanh(double x)\n",
           "fmu_plant/dynamics.pxd": "cpdef double mass(double x)\n"}
    assert compiled._declared_for("fmu_controller/sotc.py", lib, pxd) == [
        "fmu_controller/sotc.pxd", "fmu_controller/sotc_math.pxd", "fmu_numerics/elementary.pxd"]
    assert compiled._declared_for("fmu_plant/dynamics.py", lib, pxd) == ["fmu_plant/dynamics.pxd"]


def test_every_cimport_form_puts_the_declarations_it_reads_in_the_key():
    """``from package cimport module`` and relative cimports read a ``.pxd`` too: a change in it must change the key."""
    lib = LIB
    pxd = {"fmu_controller/sotc.pxd": f"from {lib}.fmu_numerics cimport elementary\n",
           "fmu_controller/sotc_zv.pxd": "from .saturation cimport clip\n",
           "fmu_controller/saturation.pxd": "from ..fmu_numerics.fixed_linalg cimport dot\n",
           "fmu_numerics/elementary.pxd": "cpdef double tanh(double x)\n",
           "fmu_numerics/fixed_linalg.pxd": "cpdef double dot(double x)\n"}
    assert compiled._declared_for("fmu_controller/sotc.py", lib, pxd) == [
        "fmu_controller/sotc.pxd", "fmu_numerics/elementary.pxd", "fmu_numerics/fixed_linalg.pxd"]
    assert compiled._declared_for("fmu_controller/sotc_zv.py", lib, pxd) == [
        "fmu_controller/saturation.pxd", "fmu_controller/sotc_zv.pxd", "fmu_numerics/fixed_linalg.pxd"]
