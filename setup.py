"""The wheel, with the hot cores compiled where the build can.

Wherever Cython and a C compiler are found at install time, the modules of
``orchestration/fmu_build/compiled.py``'s ``HOT`` list are compiled from the same ``.py`` files, typed
by the ``.pxd`` beside each, with the same flags as the FMUs' cores (no fused multiply-add), so the
in-process studies (the pure loop of tuning, the fair evaluation, the docs' tables) run them as C and
get the bits of the ``.py``. The set is all or nothing (the modules cimport one another, so one of them
as a ``.py`` would break the imports of the others): a failed compile leaves every module Python.
The FMUs cannot load these (their bundles' modules carry another name), so the install also compiles the
FMUs' cores (each once, for every FMU that carries it) into the user's private cache, where the first
``sotc-cosim run`` takes them from (``compile_fmu_cores``).
Each of the package's extensions is compiled once per content too: kept in the same private cache as the
FMUs' (``compiled.cached``, keyed by the module, the ``.pxd`` files it reads, the toolchain and this build's
flags), so building the wheel again from the same sources (a reinstall, the test suite's shipped wheel)
copies them instead, and skips Cython when every one is there.
An editable install (``pip install -e``) and ``SOTC_COSIM_COMPILE=0`` compile nothing, so the ``.py``
being edited is always what runs.
"""
import os
import sys
from pathlib import Path

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

HERE = Path(__file__).resolve().parent
# the project's build modules, importable here: the build environment has only setuptools, wheel and Cython, and
# orchestration.fmu_build needs no more (tests/orchestration/test_wheel_build.py)
sys.path.insert(0, str(HERE))
from orchestration import verified  # noqa: E402
from orchestration.fmu_build import compiled, packaging  # noqa: E402


def cache_folder(rel: str):
    """The private cache folder of the package's extension of the hot module ``rel`` (None: not a hot module, or
    no cache here)."""
    if rel not in compiled.HOT:
        return None
    try:
        pxd = {compiled.declarations(r): (HERE / compiled.declarations(r)).read_text() for r in compiled.HOT}
        return compiled.cached(HERE, "", rel, pxd, ("package", os.environ.get("CFLAGS", ""), compiled.CFLAGS))
    except OSError:  # a file that cannot be read: the cache is only a shortcut
        return None


def _module(ext) -> str:
    return ext.name.replace(".", "/") + ".py"


class OptionalBuildExt(build_ext):
    """Skips the extensions in an editable install; compiles all of them or, where one fails, none."""

    def run(self):
        if getattr(self, "editable_mode", False) or self.inplace:
            self.extensions = []
        self.failed = None
        self.parallel = self.parallel or os.cpu_count() or 1
        super().run()
        if self.failed:  # the ones compiled before it are taken out of the wheel again
            for ext in self.extensions:
                Path(self.get_ext_fullpath(ext.name)).unlink(missing_ok=True)
            print(f"sotc-cosim: the cores stay Python ({self.failed})", file=sys.stderr)
        elif self.extensions:
            compile_fmu_cores()

    def build_extension(self, ext):
        if self.failed:
            return
        try:
            folder = cache_folder(_module(ext))
            if folder is not None and verified.hold(folder) and compiled.take(folder, Path(self.build_lib), _module(ext)):
                return
            if ext.sources[0].endswith(".py"):  # counted as cached, but gone or damaged since: Cython first
                ext.sources = _cythonized([ext])[0].sources
            super().build_extension(ext)
            if folder is not None:
                compiled.keep(folder, Path(self.build_lib), _module(ext))
        except Exception as exc:  # no compiler, no headers: no module is compiled
            self.failed = f"{ext.name}: {exc}"


def compile_fmu_cores() -> None:
    """The cores of every FMU, compiled now into the user's private cache under the name their bundles are
    compiled with (``packaging.compile_ahead``): the first build of any FMU takes them from the cache. Any
    failure leaves them to that build."""
    try:
        packaging.compile_ahead(HERE)
    except Exception as exc:  # noqa: BLE001 - the install goes on; the first run compiles them
        print(f"sotc-cosim: the FMUs' cores are left to the first run ({exc})", file=sys.stderr)


def hot_extensions() -> list:
    if not compiled.requested():
        return []
    try:
        import Cython  # noqa: F401 - the cores are compiled only where it is installed
    except ImportError:
        return []
    flags = compiled.CFLAGS.split()
    modules = [Extension(rel[:-3].replace("/", "."), [rel], extra_compile_args=flags)
               for rel in compiled.HOT]
    # held (not trimmed by another process) until this build ends
    if all(folder is not None and verified.hold(folder) for folder in map(cache_folder, compiled.HOT)):
        return modules  # every one is in the cache: build_extension copies them, nothing to cythonize
    try:
        return _cythonized(modules)
    except Exception as exc:  # noqa: BLE001 - Cython refused a module: every core stays Python
        print(f"sotc-cosim: the cores stay Python ({exc})", file=sys.stderr)
        return []


def _cythonized(modules: list) -> list:
    """The extensions of these modules' C, with the cores' own directives (as the FMUs' compile does:
    compiled._SCRIPT), Cython on every core."""
    from Cython.Build import cythonize

    return cythonize(modules, build_dir="build/cython", quiet=True, nthreads=os.cpu_count() or 1,
                     compiler_directives=compiled.DIRECTIVES)


setup(ext_modules=hot_extensions(), cmdclass={"build_ext": OptionalBuildExt})
