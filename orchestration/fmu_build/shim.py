"""The binary of an FMI 3.0 FMU where a C compiler is found: ``fmi3_shim.c`` in front of pythonfmu3's.

pythonfmu3 0.3.4's binary cannot answer a get or set of the wrong size or type with fmi3Error
(docs/reliability.md): it never hands nValues of a get to Python, turns every Python exception
into fmi3Fatal, and aborts the host on a type it does not implement (Float32, Binary, ...). So the
FMU's ``binaries/<platform>/<model>.so`` is the shim, which checks nValues and the type of every get
and set against ``resources/fmi3_sizes.txt`` (``sizes_table``: each value reference's number of
elements, type and name, from the modelDescription) and forwards every call to pythonfmu3's binary
beside it, ``<model>_pythonfmu3.so``. The shim is compiled with the C compiler and the flags of
the compiled cores (``compiled``) against the FMI 3.0 headers that pythonfmu3's package carries, once
per build process (``binary``). Where there is no C compiler, no headers, or the platform is not Linux,
the FMU carries pythonfmu3's binary alone (``unavailable`` says why; the build says it in one line).
"""
from __future__ import annotations

import hashlib
import os
import platform
import subprocess
import sys
from pathlib import Path
from xml.etree.ElementTree import Element

from orchestration.fmu_build import compiled

SOURCE = Path(__file__).with_name("fmi3_shim.c")
INNER_SUFFIX = "_pythonfmu3"  # pythonfmu3's binary beside the shim: <model>_pythonfmu3.so
SIZES_FILE = "fmi3_sizes.txt"  # under resources/: "valueReference size type name" per variable
# the type of the get and set functions of a variable, where it is not the variable's element name
ACCESS_TYPES = {"Enumeration": "Int64"}
FLAGS = (*compiled.CFLAGS.split(), "-std=c99", "-shared", "-fPIC",
         f'-DSHIM_INNER_SUFFIX="{INNER_SUFFIX}.so"', f'-DSHIM_SIZES_FILE="{SIZES_FILE}"')
TIME_LIMIT = 120.0  # s for compiling the shim
_BUILT: dict[str, bytes] = {}  # digest of what it is compiled from -> the shim, for the FMUs of one build


def platform_folder() -> str | None:
    """The ``binaries/`` folder of this machine, where the shim goes (None: not Linux, no shim)."""
    return f"{platform.machine()}-linux" if sys.platform.startswith("linux") else None


def headers(exporter: Path) -> Path:
    """The FMI 3.0 standard's headers (``fmi3Functions.h``) in pythonfmu3's package ``exporter``."""
    return exporter / "pythonfmu-export" / "src" / "fmi"


def unavailable(exporter: Path) -> str | None:
    """Why the FMI 3 FMUs built here carry pythonfmu3's binary alone (None: they carry the shim)."""
    if platform_folder() is None:
        return f"the size-checking binary is built on Linux only, not {sys.platform}"
    if compiled.c_compiler() is None:
        return f"no C compiler ({compiled.compiler_name()}) on PATH for the size-checking binary"
    if not (headers(exporter) / "fmi3Functions.h").is_file():
        return f"pythonfmu3 at {exporter} carries no FMI 3 headers for the size-checking binary"
    return None


def binary(exporter: Path, workdir: Path) -> bytes:
    """The compiled shim (compiled in ``workdir`` the first time this process asks)."""
    folder = headers(exporter)
    h = hashlib.sha256(SOURCE.read_bytes() + " ".join(FLAGS).encode() + compiled.c_compiler().encode())
    for header in sorted(folder.glob("fmi3*.h")):
        h.update(header.read_bytes())
    key = h.hexdigest()
    if key not in _BUILT:
        from orchestration.fmu_build.child import run_compiler  # the compile dies with the build

        out = workdir / "fmi3_shim.so"
        cmd = [compiled.c_compiler(), *FLAGS, f"-I{folder}", str(SOURCE), "-o", str(out), "-ldl"]
        try:
            proc = run_compiler(cmd, workdir, dict(os.environ), TIME_LIMIT)
        except subprocess.TimeoutExpired:
            raise compiled.CompileError(f"compiling {SOURCE.name} took over {TIME_LIMIT:g} s") from None
        if proc.returncode != 0 or not out.is_file():
            last = next((ln for ln in reversed(proc.stderr.splitlines()) if ln.strip()), "no message")
            raise compiled.CompileError(f"compiling {SOURCE.name} failed: {last.strip()}")
        _BUILT[key] = out.read_bytes()
        out.unlink()
    return _BUILT[key]


def sizes_table(xml: Element) -> str:
    """``resources/fmi3_sizes.txt`` of an FMI 3.0 modelDescription: per variable its value reference,
    number of elements (the product of its fixed dimensions), type (of its get and set functions) and name."""
    lines = []
    for variable in xml.find("ModelVariables"):
        size = 1
        for dimension in variable.iter("Dimension"):
            size *= int(dimension.get("start"))
        kind = ACCESS_TYPES.get(variable.tag, variable.tag)
        lines.append(f"{variable.get('valueReference')} {size} {kind} {variable.get('name')}\n")
    return "".join(lines)
