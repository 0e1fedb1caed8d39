"""``sotc-cosim validate``: check built FMUs against the FMI standard and the project's invariants.

Per FMU:

- ``archive``: the file is a zip archive, and no entry may leave its folder when extracted (an absolute
  path, a drive or a ``..`` component); a file that fails this is not read further: every other check
  is "not run" (``-`` in the table, and one line saying so), never "ok";
- ``fmpy``: ``fmpy.validation.validate_fmu`` (schema, units, model structure);
- ``fmutool``: the checkers ``fmutool -input X.fmu -check`` runs (XSD schema and FMI 2.0 semantic
  rules, fmu-manipulation-toolbox), called through its Python API; an ERROR record is a problem;
- ``units``: every Real (FMI 3: Float64) variable, ports and parameters, names a unit defined in
  UnitDefinitions; an FMI 3 array whose elements differ in unit (the SOTC's z) names each element's
  unit in its description instead;
- ``starts``: every input has a start value, and every start value of an input or parameter in the
  XML is exactly (bitwise) the value a fresh instance holds;
- ``descriptions``: the model and every variable have a description;
- ``step``: DefaultExperiment stepSize is the paper's T = 0.01 s;
- ``ranges``: every parameter declares a min or a max (both, if both sides are bounded), unless it is
  in ``FREE_PARAMETERS`` (initial conditions and positions, which any real value may take), and its
  start value lies within them;
- ``state``: canGetAndSetFMUstate and canSerializeFMUstate are declared;
- ``dependencies``: checked by experiment on an initialized instance (``dependencies``), in a child
  process (``children``), as the ``starts`` check's fresh instance is: an FMU that crashes the process
  loading it (a truncated binary or compiled core: SIGBUS) is a finding naming the file, one whose
  instantiation hangs a finding after ``children.INSTANTIATE_LIMIT``, not the end of validate. An FMU
  whose script is missing (``slavemodule.txt`` names no ``resources/<module>.py``) is not instantiated
  at all: pythonfmu3's binary hangs on it, pythonfmu's crashes;

- ``standalone``: every pythonfmu FMU in a process shares one interpreter and one ``sys.modules``,
  so the FMU's Python lives under names of its own: the script ``resources/<stem>.py`` named in
  ``slavemodule.txt`` and the package ``resources/<stem>_lib/``, no other Python file, and every
  import is of the standard library, of ``<stem>_lib`` or of a package in ``resources/requirements.txt``;
- ``cores``: an FMU that carries compiled cores gives the same outputs, bit for bit, with them and with
  its ``.py`` (``core_paths``: two fresh interpreters, 500 steps of the same input experiment).

Across the set: two FMUs whose script modules have the same name must bundle the same code (a copy
of one build); otherwise the second would run the first one's modules.

This module must not import ``fmu_plant``/``fmu_controller``: the FMUs it loads import their own
bundled copies, and a source-tree copy already in ``sys.modules`` would be used instead.
"""
from __future__ import annotations

import fnmatch
import logging
import math
import re
import zipfile
from dataclasses import dataclass, field
from pathlib import Path

from fmu_plant.dynamics import STEP_SIZE  # the paper's sampling period T
from orchestration import scratch
from orchestration.compliance import children, core_paths, dependencies

# parameters that may take any real value (no physical bound): name pattern -> why
FREE_PARAMETERS: dict[str, str] = {
    "W0_*": "initial critic weights: any real number",
    "init_phi*": "an elbow angle: any real number",
    "phase": "phase of the path parameter: any angle",
}
MAX_EXPANDED_BYTES = 256 * 1024 * 1024  # an FMU of ours expands to about 3 MB
MAX_ENTRIES = 10_000
CHECKS = ("archive", "fmpy", "fmutool", "units", "starts", "descriptions", "step", "ranges", "state", "standalone",
          "dependencies", "cores")
SCRATCH = "sotc_validate_"  # $TMPDIR/sotc_validate_<host>-<pid>-...: everything validate extracts or runs in


@dataclass
class FmuReport:
    path: Path
    model: str = ""  # the modelIdentifier (the file's name until the modelDescription is read)
    problems: dict[str, list[str]] = field(default_factory=lambda: {c: [] for c in CHECKS})
    not_run: dict[str, str] = field(default_factory=dict)  # check -> why it was not run (or not whole)

    def __post_init__(self) -> None:
        self.model = self.model or self.path.name

    @property
    def ok(self) -> bool:
        return not any(self.problems.values()) and not self.not_run

    def skip(self, checks, why: str) -> None:
        """The checks of ``checks`` that found nothing were not run, or not whole, because ``why``."""
        self.not_run |= {c: why for c in checks if not self.problems[c]}


@dataclass
class ValidationReport:
    fmus: list[FmuReport]
    set_problems: list[str]

    @property
    def ok(self) -> bool:
        return not self.set_problems and all(f.ok for f in self.fmus)


# --- the checks ---------------------------------------------------------------------------------

def fmpy_problems(path: Path) -> list[str]:
    from fmpy.validation import validate_fmu

    return [str(p) for p in validate_fmu(str(path))]


def archive_problems(path: Path) -> list[str]:
    """What makes ``path`` unsafe to extract: not a zip, an entry leaving its folder, or more than
    ``MAX_EXPANDED_BYTES`` or ``MAX_ENTRIES`` when expanded (a zip bomb). Read from the zip's
    directory only: nothing is extracted."""
    try:
        with zipfile.ZipFile(path) as archive:
            infos = archive.infolist()
    except (OSError, zipfile.BadZipFile, ValueError) as exc:
        return [f"not an FMU: not a readable zip archive: {exc}"]
    names = [i.filename for i in infos]
    expanded = sum(i.file_size for i in infos)
    if expanded > MAX_EXPANDED_BYTES or len(infos) > MAX_ENTRIES:
        return [f"expands to {expanded:,} bytes in {len(infos):,} entries; at most {MAX_EXPANDED_BYTES:,} bytes "
                f"and {MAX_ENTRIES:,} entries are accepted (nothing was extracted)"]
    problems = []
    for name in names:
        parts = name.replace("\\", "/").split("/")
        if name.startswith(("/", "\\")) or ".." in parts or (len(name) > 1 and name[1] == ":"):
            problems.append(f"entry '{name}' would be extracted outside the FMU's folder")
    return problems


class _Records(logging.Handler):
    def __init__(self) -> None:
        super().__init__(level=logging.ERROR)
        self.messages: list[str] = []

    def emit(self, record: logging.LogRecord) -> None:
        self.messages.append(record.getMessage())


def _fmutool_problems(path: Path) -> list[str]:
    """What ``fmutool -input PATH -check`` reports as errors (its exit code 7)."""
    try:
        from fmu_manipulation_toolbox.checker import OperationGenericCheck, get_checkers
        from fmu_manipulation_toolbox.operations import FMU, FMUError
    except ImportError:
        return ["fmu-manipulation-toolbox is not installed (pip install 'sotc-cosim[test]'): fmutool -check not run"]

    logger = logging.getLogger("fmu_manipulation_toolbox")
    records = _Records()
    logger.addHandler(records)
    propagate, logger.propagate = logger.propagate, False
    try:
        checkers = [checker() for checker in get_checkers()]
        with FMU(str(path)) as fmu:
            for checker in checkers:
                fmu.apply_operation(checker, None)
    except FMUError as exc:
        return [f"fmutool cannot read the FMU: {exc}"]
    finally:
        logger.removeHandler(records)
        logger.propagate = propagate
    problems = list(records.messages)
    generic = next((c for c in checkers if isinstance(c, OperationGenericCheck)), None)
    if generic is not None and not generic.compliant_with_version and not problems:
        problems.append("fmutool: not compliant with the FMI schema")
    return problems


def _metadata_problems(md, report: FmuReport) -> None:
    p = report.problems
    defined = {u.name for u in md.unitDefinitions}
    if not md.description:
        p["descriptions"].append("the model has no description")
    for v in md.modelVariables:
        if not v.description:
            p["descriptions"].append(f"'{v.name}' has no description")
        if v.type in ("Real", "Float64") and v.causality in ("parameter", "input", "output"):
            element_units = _element_units(v)
            if not v.unit and not element_units:
                p["units"].append(f"'{v.name}' ({v.causality}) has no unit")
            elif not v.unit and not element_units <= defined:
                p["units"].append(f"'{v.name}': element units {sorted(element_units - defined)} are not in UnitDefinitions")
            elif v.unit and v.unit not in defined:
                p["units"].append(f"'{v.name}': unit '{v.unit}' is not in UnitDefinitions")
        if v.causality == "input" and v.start is None:
            p["starts"].append(f"input '{v.name}' has no start value")
        if v.causality == "parameter":
            p["ranges"] += _range_problems(v)
    experiment = md.defaultExperiment
    step = None if experiment is None or experiment.stepSize is None else float(experiment.stepSize)
    if step != STEP_SIZE:
        p["step"].append(f"DefaultExperiment stepSize is {step}, expected {STEP_SIZE}")
    cs = md.coSimulation
    if cs is None:
        p["state"].append("no CoSimulation element")
    else:
        for flag in ("canGetAndSetFMUstate", "canSerializeFMUstate"):
            if not getattr(cs, flag):
                p["state"].append(f"{flag} is not declared true")


def _element_units(v) -> set[str]:
    """An FMI 3.0 array whose elements differ in unit has none; its description then ends each
    element's part with its unit ("[1] ... (rad); [2] ... (rad/s)", ``fmi3_slave.slave``): those
    units, or none if any element lacks one."""
    size = int(math.prod(getattr(v, "shape", None) or ())) if getattr(v, "shape", None) else 1
    parts = (v.description or "").split("; [")
    units = [m.group(1) for m in (re.search(r"\(([^()]+)\)$", part) for part in parts) if m]
    return set(units) if size > 1 and len(parts) == size and len(units) == size else set()


def _range_problems(v) -> list[str]:
    low = None if v.min is None else float(v.min)
    high = None if v.max is None else float(v.max)
    free = any(fnmatch.fnmatchcase(v.name, pattern) for pattern in FREE_PARAMETERS)
    problems = []
    if low is None and high is None and not free:
        problems.append(f"parameter '{v.name}' has neither min nor max (and is not in FREE_PARAMETERS)")
    if low is not None and high is not None and low > high:
        problems.append(f"parameter '{v.name}': min {low} > max {high}")
    if v.start is not None:
        start = float(v.start)
        if (low is not None and start < low) or (high is not None and start > high):
            problems.append(f"parameter '{v.name}': start {start} is outside [{low}, {high}]")
    return problems


def _slave_module(path: Path) -> str | None:
    with zipfile.ZipFile(path) as z:
        try:
            return z.read("resources/slavemodule.txt").decode().strip()
        except KeyError:
            return None


def _python_bundle(path: Path) -> dict[str, bytes]:
    """Every Python file under resources/ (zip name -> bytes)."""
    with zipfile.ZipFile(path) as z:
        return {n: z.read(n) for n in z.namelist() if n.startswith("resources/") and n.endswith(".py")}


def _digest_problems(path: Path, stem: str) -> list[str]:
    """The module names must carry the digest of the bundled content (one name, one content)."""
    from orchestration.fmu_build.packaging import bundle_digest, bundle_stem, digested

    model, _, named = stem.removeprefix("sotc_").rpartition("_")
    with zipfile.ZipFile(path) as z:
        every = {n[len("resources/"):]: z.read(n) for n in z.namelist() if n.startswith("resources/") and not n.endswith("/")}
    files = {n: data for n, data in every.items() if digested(n)}
    actual = bundle_stem(model, bundle_digest(files, stem, model)).rpartition("_")[2]
    problems = [] if actual == named else [
        f"the bundled code has digest {actual}, but its module names say {named}: changed after the build"]
    return problems + _bytecode_problems(every)


def _bytecode_problems(files: dict[str, bytes]) -> list[str]:
    """Every ``.pyc`` of the bundle is a checked-hash one of the ``.py`` beside it (packaging.write_bytecode)."""
    import importlib.util

    out = []
    for name, data in sorted(files.items()):
        folder, _, file = name.rpartition("/")
        if not folder.endswith("__pycache__") or not file.endswith(".pyc"):
            continue
        source = files.get(f"{folder.removesuffix('__pycache__')}{file.split('.')[0]}.py")
        if source is None or int.from_bytes(data[4:8], "little") != 3 or data[8:16] != importlib.util.source_hash(source):
            out.append(f"resources/{name} is not a checked-hash .pyc of the .py beside it: changed after the build")
    return out


def _script_problems(path: Path, stem: str) -> list[str]:
    """The script ``slavemodule.txt`` names must be there: pythonfmu3's binary hangs for ever without it
    (pythonfmu's crashes), so such an FMU is never instantiated (``validate_fmu_file``)."""
    with zipfile.ZipFile(path) as z:
        if f"resources/{stem}.py" in z.namelist():
            return []
    return [f"resources/slavemodule.txt names the module '{stem}', but resources/{stem}.py is missing: the FMU's "
            "code cannot be imported (pythonfmu3's binary hangs on it, pythonfmu's crashes)"]


def _standalone_problems(path: Path) -> list[str]:
    import ast
    import sys

    from fmi_slave.host_check import parse_requirement
    from orchestration.fmu_build.packaging import top_level_imports

    stem = _slave_module(path)
    if not stem:
        return ["resources/slavemodule.txt is missing: not a pythonfmu FMU"]
    problems = _digest_problems(path, stem) + _script_problems(path, stem)
    lib = f"{stem}_lib"
    with zipfile.ZipFile(path) as z:
        try:
            requirements = z.read("resources/requirements.txt").decode().split()
        except KeyError:
            return ["resources/requirements.txt is missing: a host cannot tell what to install"]
    allowed = {lib, "__future__"} | {parse_requirement(r)[0].lower().replace("-", "_") for r in requirements}
    for name, text in sorted(_python_bundle(path).items()):
        if name != f"resources/{stem}.py" and not name.startswith(f"resources/{lib}/"):
            problems.append(f"{name} lies outside {stem}.py and {lib}/: another FMU may bring the same module name")
        try:
            tree = ast.parse(text, name)
        except SyntaxError as exc:
            problems.append(f"{name} does not parse: {exc}")
            continue
        for top in sorted(top_level_imports(tree) - allowed - set(sys.stdlib_module_names)):
            problems.append(f"{name} imports '{top}', which is neither bundled in {lib} nor in requirements.txt")
    return problems


# --- driver -------------------------------------------------------------------------------------

def validate_fmu_file(path: Path) -> FmuReport:
    """Every check of one FMU (``children.Stopped`` after a signal the command deferred)."""
    from fmpy import read_model_description

    report = FmuReport(Path(path))
    report.problems["archive"] = archive_problems(path)
    if report.problems["archive"]:
        report.skip(CHECKS, "the file is not an FMU that can be read (archive)")
        return report
    report.problems["fmpy"] = fmpy_problems(path)
    report.problems["fmutool"] = _fmutool_problems(path)
    children.check()
    try:
        md = read_model_description(str(path), validate=False)
    except Exception as exc:  # an unreadable modelDescription: fmpy/fmutool say why
        report.problems["descriptions"].append(f"cannot read modelDescription.xml: {exc}")
        report.skip(CHECKS[CHECKS.index("fmutool") + 1:], "its modelDescription.xml cannot be read (descriptions)")
        return report
    report.model = md.coSimulation.modelIdentifier if md.coSimulation else md.modelName
    _metadata_problems(md, report)
    report.problems["standalone"] = _standalone_problems(path)
    stem = _slave_module(path)
    if stem and _script_problems(path, stem):  # pythonfmu3's binary would hang, pythonfmu's crash
        report.skip(("starts", "dependencies", "cores"), "the FMU's code cannot be imported (standalone): "
                    "it was not instantiated")
        return report
    _instance_problems(path, report)
    return report


def _instance_problems(path: Path, report: FmuReport) -> None:
    """The checks on instances, each in child processes (``children``)."""
    try:
        starts, report.problems["dependencies"] = dependencies.in_child(path)
        report.problems["starts"] += starts
    except children.ChildFailed as exc:
        report.problems["dependencies"] = [str(exc)]
        report.skip(("starts",), "no fresh instance could be read (dependencies)")
        if exc.hung:  # each run of the cores check would hang as long
            report.skip(("cores",), "instantiating the FMU hung (dependencies)")
            return
    children.check()
    report.problems["cores"] = core_paths.problems(path)


def validate_fmus(paths: list[Path]) -> ValidationReport:
    """Every check of every FMU, in a scratch folder of this process (``SCRATCH``: a later validate removes
    the one a killed validate left); ``children.Stopped`` after a signal the command deferred."""
    with scratch.owned_tempdir(SCRATCH):
        reports = []
        for p in paths:
            reports.append(validate_fmu_file(Path(p)))
            children.check()
    set_problems = []
    seen: dict[str, tuple[Path, dict[str, bytes]]] = {}
    for r in reports:
        stem = None if r.problems["archive"] else _slave_module(r.path)
        if stem is None:
            continue
        bundle = _python_bundle(r.path)
        if stem in seen and seen[stem][1] != bundle:
            set_problems.append(f"script module '{stem}' of {r.path} bundles other code than {seen[stem][0]}: "
                                "in one process the second would run the first one's modules")
        seen.setdefault(stem, (r.path, bundle))
    return ValidationReport(reports, set_problems)


def format_report(report: ValidationReport, details: bool = True) -> str:
    """The table (``ok``, ``FAIL(n)``, ``-``: not run), then a line per problem and per reason a check was not run."""
    width = max([len("FMU")] + [len(r.model) for r in report.fmus])
    cols = [max(len(c), 6) for c in CHECKS]
    lines = ["  ".join(["FMU".ljust(width)] + [c.ljust(w) for c, w in zip(CHECKS, cols)] + ["verdict"])]
    for r in report.fmus:
        cells = [f"FAIL({len(r.problems[c])})" if r.problems[c] else "-" if c in r.not_run else "ok" for c in CHECKS]
        lines.append("  ".join([r.model.ljust(width)] + [x.ljust(w) for x, w in zip(cells, cols)]
                               + ["pass" if r.ok else "FAIL"]))
    if report.set_problems:  # said only when it fails: a line that passes meant nothing to a user
        lines.append("FMUs together: FAIL (two of them cannot run in one process)")
    if details:
        for r in report.fmus:
            for check in CHECKS:
                for problem in r.problems[check]:
                    lines.append(f"  {r.model} [{check}] {problem}")
            for why in dict.fromkeys(r.not_run.values()):
                skipped = ", ".join(c for c in CHECKS if r.not_run.get(c) == why)
                lines.append(f"  {r.model} [{skipped}] not run: {why}")
        lines += [f"  together: {p}" for p in report.set_problems]
    lines.append("all FMUs pass" if report.ok else "validation FAILED")
    return "\n".join(lines)
