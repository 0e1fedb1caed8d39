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
``fmu_numerics/elementary.py``'s own, libm's only sqrt, which IEEE 754 rounds correctly everywhere).

Each extension is compiled once per content, whichever bundle carries it: every bundle is compiled under
one placeholder stem (``packaging.placeholder``), so a module stages the same text in every FMU. The
extensions are kept in the user's private cache (``private_folder(*verified.CORES)/<key>``, a folder per
module with a manifest of its SHA-256: ``orchestration.verified``, bounded with the other caches), keyed by
the SHA-256 of the module and of the ``.pxd`` files it reads (its own and those they cimport; the
placeholder's name in them), the compile script and flags, Python's build configuration, Cython's and
setuptools' versions, the C compiler's path and ``--version``, and the environment variables setuptools
reads. A later build of any bundle that carries the module (another FMU, another folder, FMI 3, a change
elsewhere in the sources) copies it, checked against the manifest as it is copied; a cache folder that
differs is removed and the module compiled again. Builds running at once take turns on the cache (a lock
file in it), so a module is compiled once for all. ``pip install .`` fills the cache with every hot module
(setup.py: ``packaging.compile_ahead``, written as the builds stage them), so no FMU's first build compiles
anything; the build says how many of an FMU's cores came from the cache.
"""
from __future__ import annotations

import contextlib
import functools
import hashlib
import importlib.machinery
import importlib.util
import os
import re
import shutil
import subprocess
import sys
import sysconfig
import tempfile
from pathlib import Path

SWITCH = "SOTC_COSIM_COMPILE"  # "0": never compile the cores; unset or "1": compile them where possible
CORE_PACKAGES = ("fmu_numerics", "fmu_plant", "fmu_controller")  # where the hot modules live
_CIMPORT = re.compile(r"^\s*(?:from\s+([\w.]+)\s+cimport|cimport\s+([\w.]+))", re.M)


def cimports(pxd_text: str) -> set[str]:
    """The dotted modules a ``.pxd`` cimports (``from a.b cimport f`` and ``cimport a.b``)."""
    return {a or b for a, b in _CIMPORT.findall(pxd_text)}


def _hot_modules(root: Path) -> tuple[str, ...]:
    """The hot path of a step: every core module with a ``.pxd`` beside it (the elementary functions,
    controller evaluate/learn, the plant's RK4, the reference and its inverse kinematics, the limiters),
    each after the modules its ``.pxd`` cimports, so the order is the one the declarations give."""
    pxds = {f"{p.parent.name}/{p.stem}.py": p for package in CORE_PACKAGES for p in sorted((root / package).glob("*.pxd"))}
    order: list[str] = []

    def visit(rel: str, path: tuple[str, ...] = ()) -> None:
        if rel in path:
            raise ValueError(f"the .pxd files cimport one another in a cycle: {' -> '.join(path + (rel,))}")
        if rel not in order:
            for dotted in sorted(cimports(pxds[rel].read_text())):
                if (needed := dotted.replace(".", "/") + ".py") in pxds:
                    visit(needed, path + (rel,))
            order.append(rel)

    for rel in pxds:
        visit(rel)
    return tuple(order)


HOT = _hot_modules(Path(__file__).resolve().parents[2])
# names stay plain bytes (renamed); no fused multiply-add, so the compiled cores round as the .py does; -O1:
# the cores run as fast as at -O2 (a 100 s pure-loop run, docs/performance.md) for 43 % less compile time
CFLAGS = "-O1 -g0 -fvisibility=hidden -DCYTHON_COMPRESS_STRINGS=0 -ffp-contract=off"
TIME_LIMIT = 900.0  # s for one compile (the cores a bundle lacks in the cache)
LOCK_FILE = ".compile.lock"  # in the cache folder: one FMU build's compile at a time across processes (a build
# compiles one bundle after the other anyway)
# Cython's directives for every build of the cores (setup.py's too); each module adds its own on its first line
DIRECTIVES = {"language_level": 3, "annotation_typing": False}
_SCRIPT = f"""import sys
from setuptools import setup
from Cython.Build import cythonize
setup(ext_modules=cythonize(sys.argv[2:], quiet=True, nthreads=2, compiler_directives={DIRECTIVES!r}),
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
    are staged for the compiler only; return the compiled modules' paths under ``lib``. Extensions made
    from the same inputs before are taken from the private cache instead (``cached``)."""
    return build_cores(resources, lib, pxd)[0]


def build_cores(resources: Path, lib: str, pxd: dict[str, str]) -> tuple[list[str], int]:
    """``compile_bundle``, and how many of the extensions were taken from the private cache (the others
    were compiled here, in one compile), which the build says. Each module has a cache folder of its own,
    so a core that several bundles carry is compiled once for all of them."""
    present = [rel for rel in HOT if (resources / lib / rel).is_file()]
    folders = {rel: cached(resources, lib, rel, pxd) for rel in present}
    if not present or None in folders.values():
        if present:
            _compile(resources, lib, present, pxd)
        return present, 0
    from orchestration import verified

    parent = next(iter(folders.values())).parent
    with _one_compiler(parent):  # a concurrent build of the same cores finds them compiled
        missing = [rel for rel in present
                   if not (verified.hold(folders[rel]) and take(folders[rel], resources / lib, rel))]
        if missing:
            _compile(resources, lib, missing, pxd)
            for rel in missing:
                keep(folders[rel], resources / lib, rel)
                verified.hold(folders[rel])  # not trimmed away by the trim it may call for
            verified.trim()
    return present, len(present) - len(missing)


@contextlib.contextmanager
def _one_compiler(folder: Path):
    """Hold the cache's lock (``LOCK_FILE`` beside its folders; released by the kernel when a holder dies):
    one process at a time looks for a bundle's cores and compiles those missing."""
    import fcntl

    with open(folder / LOCK_FILE, "a") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(lock, fcntl.LOCK_UN)


def _compile(resources: Path, lib: str, present: list[str], pxd: dict[str, str]) -> None:
    staged = [resources / lib / rel for rel in pxd]
    for path, text in zip(staged, pxd.values()):
        path.write_text(text)
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
    missing = [rel for rel in present if not (resources / lib / _extension(rel)).is_file()]
    if missing:
        raise CompileError(f"compiling the cores left no extension for {', '.join(missing)}")


def _extension(rel: str) -> str:
    """The extension compiled from the module ``rel`` (a path), for this interpreter."""
    return rel[:-3] + importlib.machinery.EXTENSION_SUFFIXES[0]


# what setuptools reads from the environment when it compiles and links (CFLAGS is ours)
_BUILD_ENV = ("CC", "CXX", "CPPFLAGS", "LDFLAGS", "LDSHARED", "ARCHFLAGS")  # the compiler itself: its path


def _toolchain() -> list[str]:
    """Everything but the sources an extension's bytes depend on: the compile script and flags, this
    Python and its build configuration, Cython, setuptools, the C compiler (its path and what it says
    its version is) and the environment the compiler reads; asked once per process and environment."""
    return _toolchain_in(tuple(os.environ.get(k, "") for k in (*_BUILD_ENV, "PATH")))


@functools.lru_cache(maxsize=4)
def _toolchain_in(environment: tuple[str, ...]) -> list[str]:
    from importlib import metadata

    compiler = (os.environ.get("CC") or compiler_name()).split()[0]
    try:
        version = subprocess.run([compiler, "--version"], capture_output=True, text=True, timeout=60).stdout
    except (OSError, subprocess.SubprocessError):
        version = "unknown"
    config = [str(sysconfig.get_config_var(v)) for v in ("CC", "CFLAGS", "CCSHARED", "LDSHARED", "EXT_SUFFIX")]
    return [_SCRIPT, CFLAGS, sys.version, sysconfig.get_paths()["include"], *config, metadata.version("Cython"),
            metadata.version("setuptools"), shutil.which(compiler) or compiler, version,
            *(f"{k}={os.environ.get(k, '')}" for k in _BUILD_ENV)]


def _declared_for(rel: str, lib: str, pxd: dict[str, str]) -> list[str]:
    """The ``.pxd`` files (paths under ``lib``) Cython reads to compile the module ``rel``: its own and those
    its declarations cimport, directly or through one another."""
    found: list[str] = []
    todo = [declarations(rel)]
    while todo:
        name = todo.pop()
        if name in pxd and name not in found:
            found.append(name)
            todo += _cimported(name, lib, pxd)
    return sorted(found)


def _cimported(name: str, lib: str, pxd: dict[str, str]) -> list[str]:
    """The ``.pxd`` files the declarations ``name`` cimport: ``from a.b cimport f`` reads ``a/b.pxd``; ``from a
    cimport b`` reads ``a/b.pxd`` (every ``.pxd`` of the package ``a`` is taken: the names are not parsed); a
    relative module is found from ``name``'s own package."""
    out = []
    for dotted in cimports(pxd[name]):
        bare = dotted.lstrip(".")
        if bare != dotted:  # relative: one dot is name's own package
            base = Path(name).parents[len(dotted) - len(bare) - 1].as_posix()
            path = "/".join(p for p in (base if base != "." else "", bare.replace(".", "/")) if p)
        else:
            path = dotted.removeprefix(f"{lib}.").replace(".", "/")
        out += [f"{path}.pxd"] if f"{path}.pxd" in pxd else [k for k in pxd if k.startswith(f"{path}/")]
    return out


def cached(resources: Path, lib: str, rel: str, pxd: dict[str, str], extra: tuple[str, ...] = ()) -> Path | None:
    """The private cache folder of the extension compiled from the module ``rel`` (a path under
    ``resources/lib``; ``lib``, the package name the extension carries, is part of the key), the ``pxd``
    files it reads, the toolchain and ``extra`` (what else the compile depends on: setup.py's own flags); None
    where no private cache can be made or the toolchain cannot be named (the cores are then compiled every
    time)."""
    from importlib import metadata

    from orchestration.verified import CORES
    from orchestration.outputs import OutputError, private_folder

    try:
        toolchain = _toolchain()
    except metadata.PackageNotFoundError:  # Cython or setuptools without package metadata: no version to key on
        return None
    h = hashlib.sha256()
    for part in [*toolchain, lib, *extra]:
        h.update(part.encode() + b"\0")
    h.update(rel.encode() + b"\0" + (resources / lib / rel).read_bytes() + b"\0")
    for name in _declared_for(rel, lib, pxd):
        h.update(name.encode() + b"\0" + pxd[name].encode() + b"\0")
    try:
        return private_folder(*CORES) / h.hexdigest()
    except OutputError:
        return None


def take(cache: Path, lib_dir: Path, rel: str) -> bool:
    """Copy the cached extension of the module ``rel`` beside it, checked against the cache's manifest as
    it is copied; False (nothing copied, a damaged cache folder removed) when it differs or is missing."""
    from orchestration import verified

    name = _extension(rel)
    manifest = verified.recorded(cache)
    if manifest is None:
        return False
    try:
        if sorted(manifest) != [name]:
            raise ValueError(cache)
        data = (cache / name).read_bytes()
        if hashlib.sha256(data).hexdigest() != manifest[name]:
            raise ValueError(cache / name)
        (lib_dir / name).parent.mkdir(parents=True, exist_ok=True)
        (lib_dir / name).write_bytes(data)
    except (OSError, ValueError):
        (lib_dir / name).unlink(missing_ok=True)
        verified.discard(cache)
        return False
    return True


def keep(cache: Path, lib_dir: Path, rel: str) -> None:
    """Store the extension just compiled from ``rel`` in the cache (a failure to store only costs the next
    build)."""
    from orchestration import verified

    def fill(staging: Path) -> None:
        target = staging / _extension(rel)
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(lib_dir / _extension(rel), target)

    try:
        verified.discard(cache)
        verified.place(cache, fill)
    except OSError:
        pass
