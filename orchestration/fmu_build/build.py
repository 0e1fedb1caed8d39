"""Build the FMUs from the installed sources, always in a child process.

pythonfmu's builder imports the model script to write the modelDescription; if that happened in
the process that later simulates, the simulation would silently run the already-imported source
tree instead of the FMU. So ``build_fmus`` runs ``python -m orchestration.fmu_build.build`` as a subprocess,
which packages each FMU with ``orchestration.fmu_build.packaging`` (every bundled module under a name unique
to the model and build, so any mix of FMUs runs side by side in one interpreter).

A ``<Model>.sources.sha256`` file beside each FMU records the digest of what it was built from (its
sources, pythonfmu's Python half, and this packaging code), so ``ensure_built`` rebuilds exactly
the FMUs whose inputs changed. The digest also names the FMU's bundled modules.
"""
from __future__ import annotations

import argparse
import hashlib
import os
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from fmu_controller.catalog import CONTROLLERS
from orchestration.outputs import atomic_write
from orchestration.paths import DEFAULT_FMU_DIR, FMI_VERSIONS, OutputPathError, check_output_folder
from orchestration.fmu_build import compiled, fmi3, packaging, shim
from orchestration.fmu_build.child import BuildError, Stopped, die_with_parent, run_child, stop_on_signals
from orchestration.scratch import owner_prefix, remove_stale

PACKAGE_ROOT = Path(__file__).resolve().parents[2]  # folder holding fmu_plant/, fmu_controller/


@dataclass(frozen=True)
class FmuSource:
    model: str  # modelIdentifier == FMU file stem
    script: str  # path relative to PACKAGE_ROOT
    packages: tuple[str, ...]  # packages bundled (renamed) under resources/
    equations: tuple[str, ...] = ()  # modules whose docstrings summarise the FMU's equations


# the packages an FMU may bundle; only the modules a script imports go in (packaging.import_closure), so a
# plant FMU carries no controller code
BUNDLED = ("fmi_slave", *compiled.CORE_PACKAGES)
FMU_SOURCES: dict[str, FmuSource] = {
    s.model: s
    for s in (
        FmuSource("ArmPlant", "fmu_plant/arm_plant_fmu.py", BUNDLED, ("fmu_plant/dynamics.py", "fmu_plant/kinematics.py")),
        FmuSource("ReferenceTrajectory", "fmu_plant/reference_trajectory_fmu.py", BUNDLED,
                  ("fmu_plant/trajectory.py", "fmu_plant/kinematics.py")),
        *(FmuSource(c.model, c.script, BUNDLED, (c.equations,)) for c in CONTROLLERS.values()),
        *(FmuSource(m, f"fmu_plant/{s}_fmu.py", BUNDLED, ("fmu_plant/perturbation.py",)) for m, s in (("Disturbance", "disturbance"), ("MeasurementNoise", "measurement_noise"))),
    )
}


def packages_of(source: FmuSource, fmi: int) -> tuple[str, ...]:
    """The packages an FMU of this FMI version bundles: FMI 3 adds the FMI 3 face of the framework."""
    return source.packages + ((fmi3.FMI3_PACKAGE,) if fmi == 3 else ())


def _source_files(source: FmuSource, fmi: int = 2) -> list[Path]:
    files = [PACKAGE_ROOT / source.script, Path(__file__).resolve(), Path(packaging.__file__).resolve(),
             Path(compiled.__file__).resolve(), Path(fmi3.__file__).resolve()]
    if fmi == 3:  # the size-checking binary in front of pythonfmu3's
        files += [Path(shim.__file__).resolve(), shim.SOURCE]
    for pkg in packages_of(source, fmi):
        files += sorted((PACKAGE_ROOT / pkg).glob("*.py")) + sorted((PACKAGE_ROOT / pkg).glob("*.pxd"))
    exporters = dict.fromkeys(("pythonfmu", packaging.EXPORTERS[fmi]))
    return sorted(set(files)) + [f for e in exporters for f in packaging.pythonfmu_sources(e)]


def source_digest(source: FmuSource, fmi: int = 2, compiled_cores: bool | None = None) -> str:
    """What the FMU is built from: its sources, pythonfmu's Python half, the packaging code, its FMI
    version, whether its cores are compiled (``compiled_cores``; default: what a build here does) and,
    for FMI 3, whether it carries the size-checking binary (``shim``)."""
    compiled_cores = compiles() if compiled_cores is None else compiled_cores
    fmi3_binary = (b" FMI 3.0" + (b" shim" if packaging.shim_unavailable() is None else b"")) if fmi == 3 else b""
    h = hashlib.sha256(source.model.encode() + (f" compiled for {compiled.target()}".encode() if compiled_cores else b"")
                       + fmi3_binary)
    for f in _source_files(source, fmi):
        h.update(f.name.encode())
        h.update(f.read_bytes())
    return h.hexdigest()


def fmu_path(model: str, out_dir: Path) -> Path:
    return Path(out_dir) / f"{model}.fmu"


def file_digest(path: Path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def is_current(model: str, out_dir: Path, fmi: int = 2, compiled_cores: bool | None = None) -> bool:
    """The FMU is there, built from today's sources (cores compiled or not: ``source_digest``), and its
    bytes are the ones that build wrote (the stamp holds both digests): a truncated, corrupt or
    replaced FMU is built again."""
    stamp, fmu = Path(out_dir) / f"{model}.sources.sha256", fmu_path(model, out_dir)
    try:
        lines = stamp.read_text().split()
        return fmu.is_file() and lines == [source_digest(FMU_SOURCES[model], fmi, compiled_cores), file_digest(fmu)]
    except OSError:
        return False


def compiles() -> bool:
    """Whether builds compile the hot cores: asked for (``compiled.SWITCH``) and possible here."""
    return compiled.requested() and compiled.unavailable() is None


def _build_one(source: FmuSource, out_dir: Path, fmi: int = 2) -> tuple[Path, list[str], int]:
    """Runs in the child process only."""
    with tempfile.TemporaryDirectory(prefix=owner_prefix("sotc_stage_")) as tmp:
        digest = source_digest(source, fmi)
        script = PACKAGE_ROOT / source.script
        if fmi == 3:
            script = fmi3.write_script(source.model, script, PACKAGE_ROOT, Path(tmp))
        built, cores, reused = packaging.package_fmu(
            source.model, script, {pkg: PACKAGE_ROOT / pkg for pkg in packages_of(source, fmi)},
            [PACKAGE_ROOT / e for e in source.equations], fmu_path(source.model, out_dir), Path(tmp), compiles(), fmi)
    atomic_write(out_dir / f"{source.model}.sources.sha256", f"{digest}\n{file_digest(built)}\n")
    return built, cores, reused


def cores_made(cores: list[str], reused: int) -> str:
    """What a build did for an FMU's hot cores: took ``reused`` of them from the private cache and compiled
    the others, or kept them Python."""
    if not cores:
        return "Python"
    head = f"{len(cores)} core{'s' if len(cores) > 1 else ''}"
    if reused in (0, len(cores)):
        return f"{head} {'from the cache' if reused else 'compiled'}"
    return f"{head}: {reused} from the cache, {len(cores) - reused} compiled"


def build_fmus(models: list[str] | None = None, out_dir: Path = DEFAULT_FMU_DIR, fmi: int = 2,
               report: Callable[[str], None] | None = None) -> list[Path]:
    """Build the named FMUs (all by default) into ``out_dir`` in a child process, for FMI 2.0 or 3.0;
    ``report`` gets a line before and one per FMU as it is built (default: stderr). A signal stops the
    child (``child.BuildInterrupted``)."""
    models = list(FMU_SOURCES) if not models else models
    unknown = [m for m in models if m not in FMU_SOURCES]
    if unknown:
        raise BuildError(f"unknown FMU {unknown}; known: {', '.join(FMU_SOURCES)}")
    out_dir = Path(out_dir)
    try:
        check_output_folder(out_dir, "the FMU folder")
    except OutputPathError as exc:
        raise BuildError(f"{', '.join(models)} must be built: {exc}") from None
    occupied = [str(fmu_path(m, out_dir)) for m in models if fmu_path(m, out_dir).exists()
                and not fmu_path(m, out_dir).is_file()]
    if occupied:
        raise BuildError(f"{', '.join(occupied)}: not a file where the FMU goes; remove it")
    out_dir.mkdir(parents=True, exist_ok=True)
    report = report or _to_stderr
    report(f"building {len(models)} FMU{'s' if len(models) > 1 else ''} (FMI {fmi}.0) into {out_dir}: {cores_note()}")
    unshimmed = packaging.shim_unavailable() if fmi == 3 else None
    if unshimmed:
        report(f"FMI 3 sizes stay unchecked in C (a wrong nValues gives fmi3Fatal or worse): {unshimmed}")
    cmd = [sys.executable, "-m", "orchestration.fmu_build.build", "--out", str(out_dir.resolve()), "--fmi", str(fmi),
           "--parent", str(os.getpid()), *models]
    code, errors = run_child(cmd, str(PACKAGE_ROOT), lambda line: report(f"  {line}"))
    if code != 0:  # the child's last line says why (its whole output would be a traceback)
        last = next((line for line in reversed(errors) if line.strip()), "no message")
        raise BuildError(f"building {', '.join(models)} in {out_dir} failed: {last.strip()}")
    return [fmu_path(m, out_dir) for m in models]


def _to_stderr(line: str) -> None:
    print(line, file=sys.stderr, flush=True)


def python_only_reason() -> str | None:
    """Why a build here keeps the hot cores Python (None: it compiles them)."""
    if compiles():
        return None
    return compiled.unavailable() if compiled.requested() else f"{compiled.SWITCH}=0 asks for Python cores"


def cores_note() -> str:
    """What a build here makes of the hot cores, and why they stay Python when they do."""
    why = python_only_reason()
    return f"hot cores stay Python: {why}" if why else \
        (f"hot cores compiled with Cython for {compiled.target()} (each compiled once, "
         "then taken from the private cache by every FMU that carries it)")


def kept_in_other_mode(models: list[str], out_dir: Path, fmi: int, current: set[str]) -> list[str]:
    """The FMUs that are current but built in the other mode (cores compiled, or Python under
    ``SOTC_COSIM_COMPILE=0``): the user's build, kept unless the switch is set for this command.
    ``current``: the models found current in this mode (each check digests the sources and the FMU,
    so it is done once)."""
    if compiled.SWITCH in os.environ:
        return []
    return [m for m in models if m in FMU_SOURCES and m not in current
            and is_current(m, out_dir, fmi, not compiles())]


def ensure_built(models: list[str], out_dir: Path = DEFAULT_FMU_DIR, fmi: int = 2) -> dict[str, Path]:
    """Build the FMUs that are missing or older than their sources (those current in the other mode
    are kept, and said so: ``kept_in_other_mode``); return model -> path."""
    models = list(dict.fromkeys(models))
    current = {m for m in models if m in FMU_SOURCES and is_current(m, out_dir, fmi)}  # digested once
    kept = kept_in_other_mode(models, out_dir, fmi, current)
    if kept:
        mode = f"cores Python, as {compiled.SWITCH}=0 builds them" if compiles() else "cores compiled"
        _to_stderr(f"{', '.join(kept)} in {out_dir}: kept as built ({mode}); "
                   f"sotc-cosim build --out {out_dir}{' --fmi 3' if fmi == 3 else ''} rebuilds them ({cores_note()})")
    stale = [m for m in models if m not in kept and m not in current]
    if stale:
        build_fmus(stale, out_dir, fmi)
    return {m: fmu_path(m, out_dir) for m in models}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="Build sotc-cosim FMUs (child-process entry point)")
    parser.add_argument("--out", type=Path, default=DEFAULT_FMU_DIR)
    parser.add_argument("--fmi", type=int, choices=FMI_VERSIONS, default=2)
    parser.add_argument("--parent", type=int, help="the command's pid: stop when it dies")
    parser.add_argument("models", nargs="*")
    args = parser.parse_args(argv)
    models = args.models or list(FMU_SOURCES)
    try:
        with stop_on_signals():
            if args.parent is not None:
                die_with_parent(args.parent)
            for prefix in ("sotc_stage_", "sotc_cython_"):  # left by a build that was killed
                remove_stale(Path(tempfile.gettempdir()), prefix)
            args.out.mkdir(parents=True, exist_ok=True)
            begun = time.monotonic()
            for i, model in enumerate(models, 1):
                print(f"[{i}/{len(models)}] {model} ...", flush=True)
                started = time.monotonic()
                built, cores, reused = _build_one(FMU_SOURCES[model], args.out, args.fmi)
                print(f"[{i}/{len(models)}] {model}: {built.name} in {time.monotonic() - started:.0f} s "
                      f"({cores_made(cores, reused)})", flush=True)
            print(f"built {len(models)} FMU{'s' if len(models) > 1 else ''} in {time.monotonic() - begun:.0f} s",
                  flush=True)
    except Stopped as exc:
        return 128 + exc.signum
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
