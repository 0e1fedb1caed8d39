"""The project as a user gets it: a wheel built from this tree and installed into a fresh virtualenv.

Tests of the shipped product run its ``sotc-cosim`` console script (or its Python) in subprocesses,
from a temporary folder outside the repository, with no PYTHONPATH: nothing of the source tree is
importable there, so a command that only worked because the source packages were on ``sys.path``
fails here as it would for a user. The virtualenv gets the project's dependencies from the
interpreter running the tests (a ``.pth`` line after its own site-packages), so the wheel's copy of
the project always comes first and no test downloads anything but the build backend.
"""
from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import sysconfig
import time
import venv
from dataclasses import dataclass
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
# names a host without sotc-cosim does not have; ``BLOCK_PROJECT`` makes them unimportable
PROJECT_MODULES = ("fmu_numerics", "fmu_plant", "fmu_controller", "orchestration", "pythonfmu")
BLOCK_PROJECT = f'''
import importlib.abc, sys
class _NotInstalled(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] in {PROJECT_MODULES!r}:
            raise ModuleNotFoundError(f"{{name}} is not installed in this host", name=name)
        return None
sys.meta_path.insert(0, _NotInstalled())
'''


def _ignore(folder: str, names: list[str]) -> set[str]:
    skip = {".git", ".venv", "venv", "build", "dist", "recordings", "__pycache__", ".pytest_cache", ".hypothesis"}
    return {n for n in names if n in skip or n.endswith(".egg-info")}


def copy_sources(dest: Path) -> Path:
    shutil.copytree(REPO, dest, ignore=_ignore)
    return dest


@dataclass
class Shipped:
    """An installed copy of the project: its interpreter, its console script, a working folder."""

    root: Path
    python: Path
    script: Path
    src: Path  # a copy of the sources the wheel was built from (for variant builds)

    def env(self, **extra: str) -> dict[str, str]:
        env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME", "VIRTUAL_ENV")}
        env["PATH"] = f"{self.python.parent}{os.pathsep}{env.get('PATH', '')}"
        return env | extra

    def workdir(self, name: str) -> Path:
        folder = self.root / "work" / name
        folder.mkdir(parents=True, exist_ok=True)
        return folder

    def cli(self, *args: str, cwd: Path, timeout: float = 600) -> subprocess.CompletedProcess:
        return subprocess.run([str(self.script), *args], cwd=cwd, env=self.env(), capture_output=True,
                              text=True, timeout=timeout)

    def python_code(self, code: str, *args: str, cwd: Path, timeout: float = 600,
                    block_project: bool = False, env: dict[str, str] | None = None) -> subprocess.CompletedProcess:
        """Run ``code`` in a fresh interpreter of the installed project (``-I``: no cwd, no user site), with
        ``env`` added to its environment."""
        prefix = BLOCK_PROJECT if block_project else ""
        return subprocess.run([str(self.python), "-I", "-c", prefix + code, *args], cwd=cwd,
                              env=self.env(**(env or {})), capture_output=True, text=True, timeout=timeout)

    def interrupt(self, args: list[str], cwd: Path, ready, timeout: float = 300,
                  sig: int = signal.SIGINT) -> subprocess.CompletedProcess:
        """Start the CLI, wait until ``ready()`` is true (polled), send ``sig`` (SIGINT), and wait for it."""
        proc = subprocess.Popen([str(self.script), *args], cwd=cwd, env=self.env(), stdout=subprocess.PIPE,
                                stderr=subprocess.PIPE, text=True)
        deadline = time.monotonic() + timeout
        while not ready() and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.02)
        if proc.poll() is None:
            proc.send_signal(sig)
        out, err = proc.communicate(timeout=timeout)
        return subprocess.CompletedProcess(proc.args, proc.returncode, out, err)


def install(root: Path) -> Shipped:
    """Build a wheel of this tree, install it into a new virtualenv under ``root``."""
    src = copy_sources(root / "src")
    wheels = root / "wheels"
    subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", str(wheels), str(src)],
                   check=True, capture_output=True, text=True)
    env_dir = root / "venv"
    venv.EnvBuilder(with_pip=False, clear=True).create(env_dir)  # this pip installs into it (--python): 5 s less
    bindir = "Scripts" if sys.platform == "win32" else "bin"
    python = env_dir / bindir / ("python.exe" if sys.platform == "win32" else "python")
    site = Path(subprocess.run([str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                               check=True, capture_output=True, text=True).stdout.strip())
    wheel = next(wheels.glob("sotc_cosim-*.whl"))
    # the wheel first: once the .pth below is in place, pip would see the test runner's own copy of
    # sotc-cosim (CI installs it non-editable) as already installed and skip the wheel
    subprocess.run([sys.executable, "-m", "pip", "--python", str(python), "install", "--no-deps", "--no-index", "-q",
                    str(wheel)],
                   check=True, capture_output=True, text=True)
    # the dependencies: this interpreter's site-packages, searched after the venv's own
    (site / "zz_test_dependencies.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    if not (site / "orchestration" / "__init__.py").is_file():
        raise RuntimeError(f"the wheel {wheel.name} did not install into {site}")
    return installed(root)


def installed(root: Path) -> Shipped:
    """The copy ``install`` made under ``root``."""
    bindir = root / "venv" / ("Scripts" if sys.platform == "win32" else "bin")
    return Shipped(root, bindir / ("python.exe" if sys.platform == "win32" else "python"), bindir / "sotc-cosim",
                   root / "src")
