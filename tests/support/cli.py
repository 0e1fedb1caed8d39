"""Run the installed ``sotc-cosim`` console script in a child process, as a user or a batch system
would, and read what it said."""
from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

SCRIPT = shutil.which("sotc-cosim", path=str(Path(sys.executable).parent)) or "sotc-cosim"
TIME_LIMIT = 240  # s: a child still running then has hung, and the test fails


def env_for(cwd: Path) -> dict[str, str]:
    """The environment with TMPDIR in ``cwd/tmp``, so a test can see what a command leaves there."""
    (cwd / "tmp").mkdir(parents=True, exist_ok=True)
    return {**os.environ, "TMPDIR": str(cwd / "tmp")}


def leftovers(cwd: Path, folders: bool = False) -> list[str]:
    """What is in the command's TMPDIR now but its private caches, kept on purpose: the unpacked FMUs (all
    of that cache) and the compiled cores (each whole folder, checked against its manifest: a half-made one
    is a leftover); ``folders``: empty folders count too."""
    from orchestration.verified import CORES
    from orchestration.fmu_build.compiled import LOCK_FILE
    from orchestration.outputs import private_root
    from orchestration.verified import intact

    tmp = cwd / "tmp"
    root = private_root(tmp)
    cores = root.joinpath(*CORES)
    skeleton = {root, cores.parent, cores, cores / LOCK_FILE}
    whole = [f for f in cores.glob("*") if intact(f)]

    def kept(p: Path) -> bool:
        return p in skeleton or "fmus" in p.relative_to(tmp).parts or any(p == f or f in p.parents for f in whole)

    return sorted(str(p.relative_to(tmp)) for p in tmp.rglob("*") if not kept(p) and (folders or not p.is_dir()))


def warm_core_cache(cwd: Path, leave: tuple[str, ...] = ()) -> None:
    """Give the command's TMPDIR (``env_for``) this process's compiled cores, as a user's cache holds them
    after a first build: a test about what a build does, not about compiling, then copies them (each still
    checked against its manifest) instead of compiling them for a minute. The modules of ``leave`` (paths such
    as ``fmu_plant/trajectory``) are not given: a build compiles them."""
    from orchestration.verified import CORES
    from orchestration.outputs import private_folder, private_root
    from orchestration.verified import intact

    root = private_root(cwd / "tmp")
    target = root.joinpath(*CORES)
    for folder in (cwd / "tmp", root, target.parent, target):  # each private, as private_folder makes them
        folder.mkdir(mode=0o700, exist_ok=True)
    for folder in private_folder(*CORES).iterdir():
        if folder.name.startswith(".") or not intact(folder):  # whole ones only: other workers build too
            continue
        if not any(next(folder.glob(f"{module}.*"), None) for module in leave):
            shutil.copytree(folder, target / folder.name)


def run(args: list[str], cwd: Path, limit_bytes: int | None = None, timeout: float = TIME_LIMIT):
    """``sotc-cosim ARGS`` in ``cwd``; ``limit_bytes`` sets RLIMIT_FSIZE (a file-size limit) first."""
    def limit() -> None:
        import resource

        resource.setrlimit(resource.RLIMIT_FSIZE, (limit_bytes, limit_bytes))

    return subprocess.run([SCRIPT, *args], cwd=cwd, capture_output=True, text=True, timeout=timeout,
                          preexec_fn=limit if limit_bytes else None, env=env_for(cwd))


def start(args: list[str], cwd: Path) -> subprocess.Popen:
    return subprocess.Popen([SCRIPT, *args], cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env=env_for(cwd))


def signal_when(proc: subprocess.Popen, ready, signum: int, timeout: float = TIME_LIMIT) -> tuple[int, str, str]:
    """Send ``signum`` once ``ready()`` is true (polled), then wait; return (exit code, stdout, stderr)."""
    deadline = time.monotonic() + timeout
    while not ready() and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.05)
    if proc.poll() is None:
        proc.send_signal(signum)
    out, err = proc.communicate(timeout=timeout)
    return proc.returncode, out, err


def one_line(err: str) -> str:
    """The single line a refused or failed command prints on stderr (no traceback)."""
    lines = [line for line in err.strip().splitlines() if line.strip()]
    assert len(lines) == 1 and "Traceback" not in err, err
    return lines[0]


def exit_code_of(signum: int) -> int:
    return 128 + signum


SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)

