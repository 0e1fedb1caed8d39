"""The ``cores`` check of ``validate``: an FMU that carries compiled cores gives the same outputs, bit for
bit, when its ``.py`` run instead (what any host whose Python or platform cannot load the extension
runs).

Both runs drive the FMU through the same input experiment for ``STEPS`` communication steps, each in a
fresh interpreter (the two share module names, so they cannot share a process: ``children``): once as
built, once from a copy without its extension files. Run as ``python -m
orchestration.compliance.core_paths FMU``, this module is that child: it prints the outputs of every
step as JSON.
"""
from __future__ import annotations

import json
import math
import sys
import tempfile
import zipfile
from pathlib import Path

from fmi_slave.compiled_check import DIGESTS, problems as compiled_problems
from fmu_plant.dynamics import STEP_SIZE  # the paper's sampling period T
from orchestration.compliance import children
from orchestration.fmu_build import compiled

STEPS = 500  # 5 s at T: the probing phase, the CL stack filling and replayed


def drive(start: float, index: int, t: float) -> float:
    """Input values of validate's experiments: away from the start value, varying in time."""
    return start + 0.3 * math.cos(2.0 * t + index)


def python_copy(path: Path, dest: Path) -> Path:
    """The FMU without its extension files: its cores run from their ``.py``."""
    with zipfile.ZipFile(path) as src, zipfile.ZipFile(dest, "w", zipfile.ZIP_DEFLATED) as out:
        for item in src.infolist():
            if not compiled.is_extension(item.filename):
                out.writestr(item, src.read(item))
    return dest


def outputs_of(path: Path, steps: int = STEPS) -> tuple[list[str], list[list[float]]]:
    """(output names, their values at every step) of the FMU driven by ``drive``."""
    instance = children.open_instance(path, "cores")
    md = instance.md  # FMI 3: in FMI 2 terms (fmi3_direct)
    inputs = [v for v in md.modelVariables if v.causality == "input" and v.type == "Real"]
    outputs = [u.variable for u in md.outputs if u.variable.type == "Real"]
    step = float(md.defaultExperiment.stepSize) if md.defaultExperiment and md.defaultExperiment.stepSize \
        else STEP_SIZE
    start = [float(v.start if v.start is not None else 0.0) for v in inputs]
    vrs = [v.valueReference for v in outputs]
    try:
        instance.initialize()
        rows = []
        for k in range(steps):
            instance.set(**{v.name: drive(s, i, k * step) for i, (v, s) in enumerate(zip(inputs, start))})
            rows.append(list(instance.fmu.getReal(vrs)))
            instance.fmu.doStep(currentCommunicationPoint=k * step, communicationStepSize=step)
        instance.fmu.terminate()
    finally:
        instance.free()
    return [v.name for v in outputs], rows


def _child(path: Path) -> tuple[list[str], list[list[float]]] | str:
    """``outputs_of`` the FMU at ``path`` from a child process (``children``), or why there are none."""
    try:
        lines = children.run("orchestration.compliance.core_paths", path)
    except children.ChildFailed as exc:
        return str(exc)
    names, rows = json.loads(lines[-1])
    return names, rows


def same(a: float, b: float) -> bool:
    """Equal bit for bit as values, NaN equal to NaN."""
    return a == b or (math.isnan(a) and math.isnan(b))


def digest_problems(path: Path) -> list[str]:
    """The FMU's extensions that its own check (``fmi_slave.compiled_check``) would not load: their
    bytes and the recorded digests are read from the archive (nothing of it is loaded)."""
    with tempfile.TemporaryDirectory(prefix="sotc_cores_") as tmp, zipfile.ZipFile(path) as z:
        wanted = [n for n in z.namelist() if compiled.is_extension(n) or n == f"resources/{DIGESTS}"]
        for name in wanted:
            z.extract(name, tmp)  # archive_problems has refused entries that leave the folder
        return [f"resources/{rel}: {why}" for rel, why in compiled_problems(str(Path(tmp, "resources"))).items()]


def problems(path: Path) -> list[str]:
    """A compiled core that would not be loaded, or where the compiled and the Python cores of the FMU
    at ``path`` differ (nothing to check: [])."""
    if not compiled.extensions(path):
        return []
    damaged = digest_problems(path)
    if damaged:
        return damaged
    fast = _child(path)
    with tempfile.TemporaryDirectory(prefix="sotc_cores_") as tmp:
        pure = _child(python_copy(path, Path(tmp) / Path(path).name))
    for label, got in (("compiled", fast), ("Python", pure)):
        if isinstance(got, str):
            return [f"the run with the {label} cores failed: {got}"]
    names, fast_rows = fast
    for k, (a_row, b_row) in enumerate(zip(fast_rows, pure[1])):
        for name, a, b in zip(names, a_row, b_row):
            if not same(a, b):
                return [f"'{name}' at step {k}: {a!r} with the compiled cores, {b!r} with their .py"]
    return []


def main(argv: list[str] | None = None) -> int:
    names, rows = outputs_of(Path((argv or sys.argv[1:])[0]))
    print(json.dumps([names, rows]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
