"""setup.py's build of the wheel's cores is all or nothing, as the runtime needs (the cores cimport one
another): where one extension fails to compile, the ones compiled before it leave the build too."""
from __future__ import annotations

import runpy
import sys
from pathlib import Path

import pytest
import setuptools
from setuptools import Distribution, Extension

from orchestration.fmu_build import compiled
from support import REPO


@pytest.fixture
def build_ext_class(monkeypatch):
    """setup.py's build_ext command, without running its setup()."""
    taken = {}
    monkeypatch.setattr(setuptools, "setup", lambda **kw: taken.update(kw))
    monkeypatch.setenv(compiled.SWITCH, "0")  # no hot extensions are cythonized for this
    monkeypatch.setattr(sys, "argv", ["setup.py"])
    monkeypatch.setattr(sys, "path", list(sys.path))  # setup.py puts its folder first: not for the other tests
    runpy.run_path(str(REPO / "setup.py"), run_name="setup")
    return taken["cmdclass"]["build_ext"]


def _build(cls, tmp_path: Path, sources: dict[str, str], monkeypatch):
    tmp_path.mkdir()
    for name, text in sources.items():
        (tmp_path / f"{name}.c").write_text(text)
    monkeypatch.chdir(tmp_path)
    dist = Distribution({"name": "t", "ext_modules": [Extension(n, [f"{n}.c"]) for n in sources]})
    cmd = cls(dist)
    cmd.build_lib, cmd.build_temp = str(tmp_path / "lib"), str(tmp_path / "tmp")
    cmd.ensure_finalized()
    cmd.run()
    return sorted(p.name.split(".")[0] for p in (tmp_path / "lib").glob("*.so"))


GOOD = '#include <Python.h>\nstatic struct PyModuleDef m = {PyModuleDef_HEAD_INIT, "a_good", 0, -1, 0};\n' \
       'PyMODINIT_FUNC PyInit_a_good(void) { return PyModule_Create(&m); }\n'


def test_one_failed_extension_leaves_every_module_python(build_ext_class, tmp_path, monkeypatch, capsys):
    reason = compiled.unavailable()
    if reason:
        pytest.skip(f"cannot compile: {reason}")
    ahead = []  # the FMUs' cores, compiled ahead after a complete build only
    monkeypatch.setitem(build_ext_class.run.__globals__, "compile_fmu_cores", lambda: ahead.append("compiled"))
    assert _build(build_ext_class, tmp_path / "ok", {"a_good": GOOD}, monkeypatch) == ["a_good"]
    assert ahead == ["compiled"]
    assert _build(build_ext_class, tmp_path / "bad", {"a_good": GOOD, "b_bad": "this is not C;\n"}, monkeypatch) == []
    assert "the cores stay Python (b_bad" in capsys.readouterr().err
    assert ahead == ["compiled"]


def test_a_wheel_built_again_takes_its_extensions_from_the_cache(build_ext_class, tmp_path, monkeypatch):
    """setup.py keeps each extension it compiles in the private cache (``cache_folder``: its key) and takes it from
    there the next time: the second build's C source no longer compiles, and the module is still there, the
    same bytes."""
    reason = compiled.unavailable()
    if reason:
        pytest.skip(f"cannot compile: {reason}")
    monkeypatch.setitem(build_ext_class.run.__globals__, "compile_fmu_cores", lambda: None)
    (tmp_path / "caches").mkdir()
    monkeypatch.setitem(build_ext_class.run.__globals__, "cache_folder", lambda rel: tmp_path / "caches" / rel)
    assert _build(build_ext_class, tmp_path / "first", {"a_good": GOOD}, monkeypatch) == ["a_good"]
    assert _build(build_ext_class, tmp_path / "again", {"a_good": "this is not C;\n"}, monkeypatch) == ["a_good"]
    (first,), (again,) = ((tmp_path / b / "lib").glob("a_good.*") for b in ("first", "again"))
    assert again.read_bytes() == first.read_bytes()


def test_a_module_counted_as_cached_but_gone_is_cythonized_with_the_cores_directives(build_ext_class, tmp_path,
                                                                                      monkeypatch):
    """Every module was in the cache when setup.py looked (so nothing was cythonized), but one is damaged by the
    time it is built: it goes through setup.py's own Cython step (the cores' directives), not setuptools' default
    handling of a ``.py`` source."""
    reason = compiled.unavailable()
    if reason:
        pytest.skip(f"cannot compile: {reason}")
    glob = build_ext_class.run.__globals__
    monkeypatch.setitem(glob, "compile_fmu_cores", lambda: None)
    (tmp_path / "cache" / "a_good.py").mkdir(parents=True)  # there, but without a manifest: not taken
    monkeypatch.setitem(glob, "cache_folder", lambda rel: tmp_path / "cache" / rel)
    asked = []

    def cythonized(modules):
        asked.extend(m.sources for m in modules)
        (tmp_path / "b" / "a_good.c").write_text(GOOD)
        return [Extension(m.name, ["a_good.c"]) for m in modules]

    monkeypatch.setitem(glob, "_cythonized", cythonized)
    (tmp_path / "b").mkdir()
    monkeypatch.chdir(tmp_path / "b")
    cmd = build_ext_class(Distribution({"name": "t", "ext_modules": [Extension("a_good", ["a_good.py"])]}))
    cmd.build_lib, cmd.build_temp = str(tmp_path / "b" / "lib"), str(tmp_path / "b" / "tmp")
    cmd.ensure_finalized()
    cmd.run()
    assert cmd.failed is None and asked == [["a_good.py"]]
    assert [p.name.split(".")[0] for p in (tmp_path / "b" / "lib").glob("*.so")] == ["a_good"]


def test_the_install_compiles_the_fmu_cores_with_the_standard_library_alone():
    """pip builds the wheel where only [build-system]'s setuptools, wheel and Cython are installed: what setup.py
    imports of the project (the FMU cores' compile, packaging.compile_ahead, and the core cache) must import
    nothing else, numpy included. Run with ``-I -S``
    (no site-packages), so a third-party import fails here as it would there."""
    import subprocess

    code = ("import sys; sys.path.insert(0, sys.argv[1]); from orchestration import verified; "
            "from orchestration.fmu_build import compiled, packaging; "
            "print(sorted(m for m in sys.modules if m.split('.')[0] in ('numpy', 'jsonschema', 'Cython')))")
    out = subprocess.run([sys.executable, "-I", "-S", "-c", code, str(REPO)], capture_output=True, text=True,
                         timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "[]"
