"""Compiled cores: wherever Cython, setuptools, a C compiler and the Python headers are found
(ordinary dependencies of the package), building an FMU compiles its hot modules in place with Cython, from
the same ``.py`` files typed by the ``.pxd`` beside each, so every formula still lives once
(``SOTC_COSIM_COMPILE=0`` keeps them Python).

Each extension sits beside its ``.py`` under the bundle's module name. CPython's import system tries
extension modules before sources, and only an extension whose suffix matches the running interpreter
(``importlib.machinery.EXTENSION_SUFFIXES``, e.g. ``.cpython-311-x86_64-linux-gnu.so``): any other
Python or platform imports the ``.py``, so the FMU stays standalone.

The bundle is compiled while it still carries the placeholder stem, and renamed afterwards by the
same-length byte replacement as every other file (``packaging._rename_bundle``). That is safe only
with ``-fvisibility=hidden``: the one exported symbol is then ``PyInit_<module>``, whose name holds no
stem, while a renamed exported symbol would no longer match the ELF hash table and fail to load;
and with ``CYTHON_COMPRESS_STRINGS=0``, else Cython stores the module names compressed. The
fully qualified module name the extension registers is renamed with the rest, so two builds of one FMU
in one process each run their own code (tests/fmu/test_compiled_cores.py). The compiled cores give the
pure-Python outputs bit for bit (same test; ``-ffp-contract=off``; the elementary functions are
``fmu_controller/elementary.py``'s own, libm's only sqrt, which IEEE 754 rounds correctly everywhere).
"""
from __future__ import annotations

import contextlib
import importlib.machinery
import importlib.util
import os
import shutil
import subprocess
import sys
import sysconfig
import tempfile
from pathlib import Path

SWITCH = "SOTC_COSIM_COMPILE"  # "0": never compile the cores; unset or "1": compile them where possible
# the hot path of a step (the elementary functions, first: the others cimport them; controller
# evaluate/learn, the plant's RK4, the reference and its inverse kinematics, the limiters)
HOT = ("fmu_controller/elementary.py", "fmu_controller/sotc.py", "fmu_controller/sotc_kernel.py", "fmu_controller/sotc_math.py",
       "fmu_controller/sotc_zv.py", "fmu_controller/sotc_stack.py", "fmu_controller/saturation.py", "fmu_controller/fixed_linalg.py",
       "fmu_plant/dynamics.py", "fmu_plant/trajectory.py", "fmu_plant/kinematics.py")
# names stay plain bytes (renamed); no fused multiply-add, so the compiled cores round as the .py does
CFLAGS = "-O2 -g0 -fvisibility=hidden -DCYTHON_COMPRESS_STRINGS=0 -ffp-contract=off"
TIME_LIMIT = 900.0  # s for compiling one bundle
_SCRIPT = """import sys
from setuptools import setup
from Cython.Build import cythonize
setup(ext_modules=cythonize(sys.argv[2:], quiet=True, nthreads=2,
                            compiler_directives={"language_level": 3, "annotation_typing": False}),
      script_args=["build_ext", "--inplace", "--parallel", "2", "--build-temp", sys.argv[1], "--build-lib", sys.argv[1]])
"""


class CompileError(RuntimeError):
    pass


def requested() -> bool:
    """Whether builds compile where they can (the default; ``SOTC_COSIM_COMPILE=0`` switches it off)."""
    return os.environ.get(SWITCH, "") != "0"


@contextlib.contextmanager
def switched(on: bool):
    """Builds inside compile the cores (``on``, where possible) or keep them Python."""
    old = os.environ.get(SWITCH)
    os.environ[SWITCH] = "1" if on else "0"
    try:
        yield
    finally:
        if old is None:
            del os.environ[SWITCH]
        else:
            os.environ[SWITCH] = old


def insisted() -> bool:
    """``SOTC_COSIM_COMPILE=1``: compiling was asked for explicitly (say so when it cannot happen)."""
    return os.environ.get(SWITCH, "") == "1"


def unavailable() -> str | None:
    """Why this interpreter cannot compile the cores (None: it can)."""
    if importlib.util.find_spec("Cython") is None or importlib.util.find_spec("setuptools") is None:
        return "Cython and setuptools are not installed (pip install cython setuptools gives compiled cores)"
    if c_compiler() is None:
        return f"no C compiler ({compiler_name()}) on PATH (install one, e.g. apt install gcc, for compiled cores)"
    if not Path(sysconfig.get_paths()["include"], "Python.h").is_file():
        return ("the Python headers (Python.h) are missing (install them, e.g. apt install python3-dev, "
                "for compiled cores)")
    return None


def compiler_name() -> str:
    """The C compiler this Python was built with (what setuptools compiles extensions with)."""
    return (sysconfig.get_config_var("CC") or "cc").split()[0]


def c_compiler() -> str | None:
    """The path of that C compiler (None: not on PATH)."""
    return shutil.which(compiler_name())


def target() -> str:
    """The interpreter and platform the extensions load on (their file suffix)."""
    return f"CPython {sys.version_info.major}.{sys.version_info.minor}, {importlib.machinery.EXTENSION_SUFFIXES[0]}"


def is_extension(name: str) -> bool:
    """Whether an FMU's zip entry is a compiled core."""
    return name.startswith("resources/") and name.endswith((".so", ".pyd"))


def extensions(fmu: Path) -> list[str]:
    """The compiled cores a built FMU carries (zip entry names)."""
    import zipfile

    with zipfile.ZipFile(fmu) as z:
        return [n for n in z.namelist() if is_extension(n)]


def describe(fmu: Path) -> str:
    """What a built FMU runs its cores as: the extensions it carries and their target, or Python only."""
    found = extensions(fmu)
    suffixes = sorted({n.rsplit("/", 1)[-1].split(".", 1)[1] for n in found})
    return (f"{len(found)} core{'s' if len(found) > 1 else ''} compiled (.{', .'.join(suffixes)}), Python elsewhere"
            if found else "Python only")


def declarations(rel: str) -> str:
    """The ``.pxd`` beside a hot module (its path under the package root): the C types Cython compiles it
    with (the module itself is unchanged)."""
    return rel[:-3] + ".pxd"


def compile_bundle(resources: Path, lib: str, pxd: dict[str, str]) -> list[str]:
    """Compile the ``HOT`` modules present under ``resources/lib`` in place (the extension beside its
    ``.py``, no C file left), typed by ``pxd`` (path under ``lib`` -> text, renamed into ``lib``), which
    are staged for the compiler only; return the compiled modules' paths under ``lib``."""
    present = [rel for rel in HOT if (resources / lib / rel).is_file()]
    if not present:
        return []
    staged = [resources / lib / rel for rel in pxd]
    for path, text in zip(staged, pxd.values()):
        path.write_text(text)
    # imported here: setup.py loads this file alone (no package around it) for the wheel's extensions
    from orchestration.fmu_build.child import run_compiler
    from orchestration.scratch import owner_prefix

    with tempfile.TemporaryDirectory(prefix=owner_prefix("sotc_cython_")) as tmp:
        cmd = [sys.executable, "-c", _SCRIPT, tmp, *(f"{lib}/{rel}" for rel in present)]
        try:
            # TMPDIR inside this folder: the compiler's own temporaries (cc*.s) go when it does, even when
            # a signal kills the compiler mid-file
            proc = run_compiler(cmd, resources, {**os.environ, "CFLAGS": CFLAGS, "TMPDIR": tmp}, TIME_LIMIT)
        except subprocess.TimeoutExpired:
            raise CompileError(f"compiling the cores took over {TIME_LIMIT:g} s") from None
    for rel in present:
        (resources / lib / rel).with_suffix(".c").unlink(missing_ok=True)
    for path in staged:
        path.unlink()
    if proc.returncode != 0:
        last = next((ln for ln in reversed(proc.stderr.splitlines()) if ln.strip()), "no message")
        raise CompileError(f"compiling the cores failed: {last.strip()}")
    suffix = importlib.machinery.EXTENSION_SUFFIXES[0]
    missing = [rel for rel in present if not (resources / lib / rel).with_suffix(suffix).is_file()]
    if missing:
        raise CompileError(f"compiling the cores left no extension for {', '.join(missing)}")
    return present
