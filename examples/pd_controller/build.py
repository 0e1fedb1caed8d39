"""Build PdController.fmu from pd_controller.c and modelDescription.xml (the files beside this script).

    python build.py [--out DIR]

Compiles the C source with the system C compiler ($CC, else cc or gcc on PATH) against the FMI 2.0
headers fmpy ships, into binaries/<platform>/PdController.<so|dylib|dll> (fmpy's platform names,
e.g. linux64), zips it with modelDescription.xml and the source into DIR/PdController.fmu (DIR: the
current folder by default) and prints the FMU's path. A missing file, folder, compiler or fmpy: one
line on stderr, exit 2; a failed compilation: the compiler's messages, exit 1. The FMU is written
under a temporary name in DIR and renamed when complete, so DIR never holds half an FMU.

Needs Python 3.8+ and fmpy (pip install fmpy); nothing else of the project this example comes from.
"""
from __future__ import annotations

import argparse
import os
import shlex
import shutil
import signal
import subprocess
import sys
import tempfile
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
SOURCE = HERE / "pd_controller.c"
DESCRIPTION = HERE / "modelDescription.xml"
IDENTIFIER = "PdController"  # the modelIdentifier of modelDescription.xml: the binary's and the FMU's name


class Refused(Exception):
    """Bad input or a missing tool: the message is the one line the user sees (exit 2)."""


def _compiler() -> list[str]:
    """The C compiler's command: $CC (which may carry options), else cc or gcc from PATH."""
    if os.environ.get("CC"):
        command = shlex.split(os.environ["CC"])
        if not shutil.which(command[0]):
            raise Refused(f"no C compiler: CC={os.environ['CC']} is not an executable")
        return command
    for name in ("cc", "gcc"):
        if shutil.which(name):
            return [name]
    raise Refused("no C compiler: neither cc nor gcc is on PATH (set CC to one)")


def _fmpy_headers() -> tuple[Path, str, str]:
    """The folder of fmpy's FMI headers, fmpy's platform name and shared-library extension."""
    try:
        import fmpy
    except ImportError:
        raise Refused("fmpy is not installed (pip install fmpy): it provides the FMI 2.0 headers") from None
    headers = Path(fmpy.__file__).parent / "c-code"
    if not (headers / "fmi2Functions.h").is_file():
        raise Refused(f"fmpy {fmpy.__version__} ships no FMI 2.0 headers: {headers / 'fmi2Functions.h'} is missing")
    return headers, fmpy.platform, fmpy.sharedLibraryExtension


def _guid() -> str:
    """The guid of modelDescription.xml, which the binary checks at fmi2Instantiate."""
    try:
        guid = ET.parse(DESCRIPTION).getroot().get("guid")
    except (OSError, ET.ParseError) as error:
        raise Refused(f"{DESCRIPTION}: {error}") from None
    if not guid:
        raise Refused(f"{DESCRIPTION}: no guid attribute")
    return guid


def _compile(binary: Path, headers: Path, platform: str) -> None:
    command = [*_compiler(), "-std=c99", "-Wall", "-Wextra", "-O2", "-shared",
               *([] if platform.startswith("win") else ["-fPIC"]),
               f"-I{headers}", f'-DPD_GUID="{_guid()}"', "-o", str(binary), str(SOURCE), "-lm"]
    done = subprocess.run(command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    sys.stderr.write(done.stdout)  # the compiler's warnings, or its errors
    if done.returncode != 0:
        raise RuntimeError(f"{command[0]} failed (exit {done.returncode}) on {SOURCE}")


def build(out: Path) -> Path:
    """Compile and zip; return the FMU's path. Raises Refused (bad input) or RuntimeError (compilation)."""
    if not out.is_dir():
        raise Refused(f"--out: {out} is not a folder")
    if not os.access(out, os.W_OK):
        raise Refused(f"--out: {out} is not writable")
    for needed in (SOURCE, DESCRIPTION):
        if not needed.is_file():
            raise Refused(f"{needed.name} is missing beside build.py ({HERE})")
    headers, platform, extension = _fmpy_headers()
    fmu = out / f"{IDENTIFIER}.fmu"
    with tempfile.TemporaryDirectory() as scratch:
        binary = Path(scratch) / f"{IDENTIFIER}{extension}"
        _compile(binary, headers, platform)
        handle, partial = tempfile.mkstemp(prefix=f".{IDENTIFIER}.", suffix=".fmu.partial", dir=out)
        try:
            with os.fdopen(handle, "wb") as stream, zipfile.ZipFile(stream, "w", zipfile.ZIP_DEFLATED) as zf:
                zf.write(DESCRIPTION, "modelDescription.xml")
                zf.write(binary, f"binaries/{platform}/{binary.name}")
                zf.write(SOURCE, f"sources/{SOURCE.name}")
            os.chmod(partial, 0o644)  # mkstemp made it private to the user
            os.replace(partial, fmu)
        except BaseException:
            os.unlink(partial)
            raise
    return fmu


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="Build PdController.fmu (FMI 2.0 Co-Simulation) from its C source.")
    parser.add_argument("--out", type=Path, default=Path.cwd(), help="folder to write PdController.fmu into (default: the current folder)")
    args = parser.parse_args(argv)
    signal.signal(signal.SIGTERM, lambda signum, frame: sys.exit(128 + signum))  # cleans up as Ctrl-C does
    try:
        print(build(args.out.resolve()))
    except Refused as error:
        print(f"build.py: {error}", file=sys.stderr)
        return 2
    except (RuntimeError, OSError) as error:
        print(f"build.py: {error}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("build.py: interrupted, nothing written", file=sys.stderr)
        return 130
    return 0


if __name__ == "__main__":
    sys.exit(main())
