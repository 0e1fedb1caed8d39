"""Package one FMU so that it stands alone in any Python host: the child-process half of the build.

pythonfmu's binary puts an FMU's ``resources/`` first on ``sys.path`` and imports the script named
in ``resources/slavemodule.txt``; the modules stay in ``sys.modules`` for the life of the process,
after the FMU is freed and its folder deleted. Two FMUs that bundle a package under the same name
therefore share the first one's copy. So every name an FMU brings is unique to its model and build:

    resources/<stem>.py                  the FMU script               (slavemodule.txt: <stem>)
    resources/<stem>_lib/__init__.py
    resources/<stem>_lib/fmi_slave/...   the FMI slave framework
    resources/<stem>_lib/fmu_plant/...   the cores it needs
    resources/<stem>_lib/fmu_controller/...
    resources/<stem>_lib/pythonfmu/...   pythonfmu's Python half, imported from here only
    resources/<stem>_lib/fmi3_slave/...  FMI 3.0 only: the FMI 3 face of the same framework
    resources/<stem>_lib/pythonfmu3/...  FMI 3.0 only: pythonfmu3's Python half
    resources/requirements.txt           what the host must have (``pythonfmu deploy -f`` reads it)
    documentation/index.html             ports, parameters, equations, host requirements

with ``<stem> = sotc_<Model>_<hex digits of the build digest>``, ``STEM_LENGTH`` characters long for
every model (at least 12 digits), so that while it is staged and compiled a bundle carries one placeholder
of that length whatever its model (``placeholder``): each hot core is then compiled once for every bundle
that carries it (``compiled.build_cores``), and renamed into each. The repository keeps one
copy of every source; the renaming (``import fmu_plant.x`` -> ``import <stem>_lib.fmu_plant.x``)
happens here, and a check refuses the build if any import of a bundled package escaped it. The
script first checks the host's packages (``fmi_slave.host_check``), then imports its cores.

The modelDescription comes from an instance of the staged (renamed) model class, so it describes
exactly the code that ships; the binary is pythonfmu's (FMI 2.0) or pythonfmu3's (FMI 3.0), renamed
to the modelIdentifier. An FMI 3.0 FMU wraps the FMI 2.0 model class (``fmi3_slave``), so it bundles
both exporters' Python halves: pythonfmu's variable classes are the framework's variable model.
"""
from __future__ import annotations

import ast
import compileall
import hashlib
import html
import importlib
import importlib.metadata
import importlib.util
import py_compile
import re
import shutil
import sys
import tomllib
import zipfile
from pathlib import Path
from xml.dom.minidom import parseString
from xml.etree.ElementTree import Element, tostring

from fmi_slave.compiled_check import DIGESTS, extension_files
from fmi_slave.host_check import parse_requirement
from orchestration.fmu_build import compiled, shim
from orchestration.outputs import atomic_file

# top-level packages renamed into <stem>_lib
BUNDLED = ("fmi_slave", "fmi3_slave", *compiled.CORE_PACKAGES, "pythonfmu", "pythonfmu3")
EXPORTERS = {2: "pythonfmu", 3: "pythonfmu3"}  # FMI version -> the package whose binary an FMU carries
DISTRIBUTION = "sotc-cosim"
# CPython versions the project's test suite runs the built FMUs on (requires-python >= 3.11)
MEASURED_PYTHONS = ("3.11",)
_IMPORT = re.compile(r"^(\s*)(from|import)(\s+)(" + "|".join(BUNDLED) + r")\b", re.M)


class PackagingError(RuntimeError):
    pass


STEM_LENGTH = 48  # characters of every bundle stem whose model name has at most 30
_MIN_DIGITS = 12  # of the digest, in a stem


def bundle_stem(model: str, digest: str) -> str:
    """The name of a bundle's script and the prefix of its packages (``<stem>_lib``)."""
    return f"sotc_{model}_{digest[:max(_MIN_DIGITS, STEM_LENGTH - len(model) - 6)]}"


def placeholder(model: str) -> str:
    """The stem a bundle carries while it is staged and compiled, before its content names the real one:
    as long as the real one, and the same for every model whose name has at most 30 characters (``STEM_LENGTH``)."""
    return "sotc_" + "0" * (len(bundle_stem(model, "0" * 64)) - 5)


PLACEHOLDER = placeholder("")  # the stem every model's bundle is compiled under (``compile_cores_ahead``)


def bundle_digest(files: dict[str, bytes], stem: str, model: str) -> str:
    """SHA-256 of a bundle (path under resources/ -> bytes) with its own stem written as the
    placeholder stem: the digest a bundle's module names must carry (``bundle_stem``), so that one
    module name always stands for one content, whichever FMU brings it first into a process."""
    neutral = placeholder(model).encode()
    h = hashlib.sha256()
    for name in sorted(files, key=lambda n: n.replace(stem, "")):
        h.update(name.replace(stem, neutral.decode()).encode() + b"\0")
        h.update(files[name].replace(stem.encode(), neutral) + b"\0")
    return h.hexdigest()


# files under resources/ that the bundle digest leaves out: the parameter starts of a copy, the digests
# of the compiled cores (written after the renaming; the cores themselves are covered), and the FMI 3 size
# table (written from the modelDescription, which is checked on its own)
UNDIGESTED = ("parameter_starts.json", DIGESTS, shim.SIZES_FILE)


def digested(name: str) -> bool:
    """Whether ``bundle_digest`` covers a file of the bundle (its path under resources/): every file but
    ``UNDIGESTED`` and the ``.pyc`` files (``write_bytecode``: derived from the sources, after the digest)."""
    parts = name.split("/")
    return "__pycache__" not in parts and parts[-1] not in UNDIGESTED


def bundled_files(resources: Path) -> dict[str, bytes]:
    """What ``bundle_digest`` covers, from a staged folder."""
    return {f.relative_to(resources).as_posix(): f.read_bytes() for f in sorted(resources.rglob("*"))
            if f.is_file() and digested(f.relative_to(resources).as_posix())}


def write_core_digests(resources: Path) -> None:
    """``resources/compiled_cores.sha256``: the digest of every extension as it ships (after the
    renaming), which the FMU checks before loading one (``fmi_slave.compiled_check``)."""
    lines = [f"{hashlib.sha256((resources / rel).read_bytes()).hexdigest()}  {rel}\n"
             for rel in extension_files(str(resources))]
    if lines:
        (resources / DIGESTS).write_text("".join(lines))


def write_bytecode(resources: Path) -> None:
    """A checked-hash ``.pyc`` (PEP 552) beside every bundled module, for the building Python's version:
    an FMU is extracted into a new folder on every load, where each module would otherwise be compiled
    from source again (about 0.1 s for a controller and the arm). The host's importer reads a ``.pyc`` only
    when its hash matches the ``.py`` beside it, and a host of another Python version ignores them."""
    for pycache in resources.rglob("__pycache__"):
        shutil.rmtree(pycache)  # the staging imports' timestamp-checked files: stale once extracted
    if not compileall.compile_dir(str(resources), quiet=2, force=True, workers=1,
                                  invalidation_mode=py_compile.PycInvalidationMode.CHECKED_HASH):
        raise PackagingError(f"a bundled module under {resources} does not compile")


def _rename_bundle(resources: Path, old: str, new: str) -> None:
    for f in sorted(resources.rglob("*"), key=lambda p: len(p.parts), reverse=True):
        if f.is_file():
            f.write_bytes(f.read_bytes().replace(old.encode(), new.encode()))
        if old in f.name:
            f.rename(f.with_name(f.name.replace(old, new)))


def _pythonfmu_folder(package: str = "pythonfmu") -> Path:
    """pythonfmu's (or pythonfmu3's) installed folder, found without importing it into this process."""
    spec = importlib.util.find_spec(package)
    if spec is None or not spec.submodule_search_locations:
        raise PackagingError(f"{package} is not installed: it provides the FMUs' binaries")
    return Path(next(iter(spec.submodule_search_locations)))


def pythonfmu_sources(package: str = "pythonfmu") -> list[Path]:
    """The Python half of pythonfmu (or pythonfmu3) that an FMU carries (what its own builder copies)."""
    return sorted(_pythonfmu_folder(package).glob("*.py"))


def shim_unavailable() -> str | None:
    """Why FMI 3 FMUs built here carry pythonfmu3's binary alone, without the size checks (``shim``)."""
    return shim.unavailable(_pythonfmu_folder("pythonfmu3"))


def pythonfmu_binaries(package: str = "pythonfmu") -> list[tuple[Path, str]]:
    """(binary, its platform folder) for every platform pythonfmu (or pythonfmu3) ships an export library for."""
    root = _pythonfmu_folder(package) / "resources" / "binaries"
    return [(f, f.parent.relative_to(root).as_posix()) for ext in ("so", "dll", "dylib")
            for f in sorted(root.rglob(f"*.{ext}"))]


def rename_imports(text: str, lib: str) -> str:
    return _IMPORT.sub(lambda m: f"{m[1]}{m[2]}{m[3]}{lib}.{m[4]}", text)


def top_level_imports(tree: ast.AST) -> set[str]:
    """Top-level names of every absolute import anywhere in ``tree`` (functions included)."""
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names.update(a.name.split(".")[0] for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names.add(node.module.split(".")[0])
    return names


def project_requirements() -> dict[str, str]:
    """Distribution name -> requirement line, from the installed project's metadata (or pyproject)."""
    try:
        lines = [r for r in importlib.metadata.requires(DISTRIBUTION) or [] if "extra ==" not in r]
    except importlib.metadata.PackageNotFoundError:
        pyproject = Path(__file__).resolve().parents[2] / "pyproject.toml"
        lines = tomllib.loads(pyproject.read_text())["project"]["dependencies"]
    out = {}
    for line in lines:
        name, spec = parse_requirement(line.split(";")[0].split("#")[0])
        spec = ",".join(sorted((s for s in spec.split(",") if s),
                               key=lambda s: (not s.startswith((">", "=")), s)))  # lower bound first
        out[name.lower()] = f"{name}{spec}"
    return out


def host_requirements(third_party: set[str]) -> list[str]:
    """Requirement lines for the third-party modules the bundle imports; each must be a project
    dependency, so nothing reaches an FMU that the project does not declare and pin."""
    declared = project_requirements()
    dists = importlib.metadata.packages_distributions()
    lines = []
    for module in sorted(third_party):
        names = [d.lower() for d in dists.get(module, [module])]
        match = next((declared[n] for n in names if n in declared), None)
        if match is None:
            raise PackagingError(f"the FMU code imports '{module}', which is not a dependency of {DISTRIBUTION}")
        lines.append(match)
    return sorted(set(lines))


def _insert_header(text: str, header: str) -> str:
    """``header`` after the docstring and ``from __future__`` imports, which must stay first; into the body
    of a ``try`` that follows them (the FMI 3 script's import guard, ``fmi3.script_text``), so that the
    guard covers the header too."""
    tree = ast.parse(text)
    line, indent = 0, ""
    for i, node in enumerate(tree.body):
        is_doc = i == 0 and isinstance(node, ast.Expr) and isinstance(getattr(node, "value", None), ast.Constant)
        if is_doc or (isinstance(node, ast.ImportFrom) and node.module == "__future__"):
            line = node.end_lineno
            continue
        if isinstance(node, ast.Try):
            line, indent = node.body[0].lineno - 1, " " * node.body[0].col_offset
        break
    lines = text.splitlines(keepends=True)
    indented = "".join(indent + h for h in header.splitlines(keepends=True))
    return "".join(lines[:line]) + indented + "".join(lines[line:])


def stage(model: str, script: Path, packages: dict[str, Path], stem: str, dest: Path, fmi: int = 2) -> list[str]:
    """Write the renamed script and packages under ``dest`` (the future ``resources/``); return the
    host requirement lines. ``packages`` maps a bundled top-level name to its source folder."""
    lib = f"{stem}_lib"
    (dest / lib).mkdir(parents=True)
    (dest / lib / "__init__.py").write_text(f'"""Python code of the {model} FMU ({stem}); imported from here only."""\n')
    host_check = Path(packages["fmi_slave"], "host_check.py")
    files = {dest / lib / rel: src.read_text() for rel, src in bundle_closure(script, packages).items()}
    files.setdefault(dest / lib / "fmi_slave" / "host_check.py", host_check.read_text())
    files.setdefault(dest / lib / "fmi_slave" / "__init__.py", Path(packages["fmi_slave"], "__init__.py").read_text())
    files.setdefault(dest / lib / "fmi_slave" / "compiled_check.py",
                     Path(packages["fmi_slave"], "compiled_check.py").read_text())  # the header's second import
    # pythonfmu's own modules import each other relatively: it comes whole, as its builder copies it
    for exporter in dict.fromkeys(("pythonfmu", EXPORTERS[fmi])):
        files |= {dest / lib / exporter / f.name: f.read_text() for f in pythonfmu_sources(exporter)}
    third_party: set[str] = set()
    for target, text in files.items():
        target.parent.mkdir(exist_ok=True)
        renamed = rename_imports(text, lib)
        third_party |= _check_imports(renamed, lib, target)
        target.write_text(renamed)
    script_text = rename_imports(script.read_text(), lib)
    third_party |= _check_imports(script_text, lib, script)
    requirements = host_requirements(third_party)
    header = (f"# sotc-cosim build: check the host's packages before anything imports them\n"
              f"from {lib}.fmi_slave.host_check import require_host_packages\n"
              f"require_host_packages({model!r}, {tuple(requirements)!r})\n"
              f"# and verify the compiled cores before anything loads one\n"
              f"from os.path import dirname as _sotc_dirname\n"
              f"from {lib}.fmi_slave.compiled_check import verify_compiled_cores\n"
              f"verify_compiled_cores({model!r}, _sotc_dirname(__file__))\n")
    (dest / f"{stem}.py").write_text(_insert_header(script_text, header))
    (dest / "requirements.txt").write_text("".join(r + "\n" for r in requirements))
    (dest / "slavemodule.txt").write_text(stem)
    return requirements


def bundle_closure(script: Path, packages: dict[str, Path]) -> dict[Path, Path]:
    """The modules of ``packages`` a bundle carries for ``script`` (``import_closure`` of the script and
    of its generated first import, the host check)."""
    return import_closure([script, Path(packages["fmi_slave"], "host_check.py")], packages)


def compile_cores_ahead(packages: dict[str, Path], dest: Path) -> list[str]:
    """Every hot core of ``packages`` (the core packages' folders), compiled now into the private cache (or
    found there) as ``package_fmu`` compiles it for any bundle that carries it: written under ``dest`` as
    ``stage`` writes it (renamed into the placeholder's ``lib``). Every FMU's build then takes its cores
    from the cache."""
    lib = f"{PLACEHOLDER}_lib"
    (dest / lib).mkdir(parents=True)
    (dest / lib / "__init__.py").write_text("")  # the packages Cython names the modules by: lib.fmu_plant.x
    for rel in compiled.HOT:
        top = rel.split("/")[0]
        for name in ("__init__.py", rel[len(top) + 1:]):
            (dest / lib / top).mkdir(exist_ok=True)
            (dest / lib / top / name).write_text(rename_imports((packages[top] / name).read_text(), lib))
    return compiled.compile_bundle(dest, lib, _declarations(packages, dest / lib))


def compile_ahead(root: Path) -> None:
    """Compile every hot core of the project at ``root`` into the private cache, as every FMU's bundle
    carries it (FMI 2.0 and 3.0 alike), without building an FMU, with a line on stderr: ``pip install .``
    calls it (setup.py, where only setuptools and Cython are installed), so that no FMU's first build
    compiles."""
    import tempfile
    import time

    from orchestration.scratch import owner_prefix

    if not compiled.requested() or compiled.unavailable() is not None:
        return
    started = time.monotonic()
    with tempfile.TemporaryDirectory(prefix=owner_prefix("sotc_stage_")) as tmp:
        cores = compile_cores_ahead({pkg: root / pkg for pkg in compiled.CORE_PACKAGES}, Path(tmp))
    print(f"sotc-cosim: the FMUs' {len(cores)} cores in the cache ({time.monotonic() - started:.0f} s)",
          file=sys.stderr, flush=True)


def import_closure(starts: list[Path], packages: dict[str, Path]) -> dict[Path, Path]:
    """Every module of ``packages`` the files ``starts`` import, directly or through each other, plus
    the ``__init__.py`` of each package used: relative path under the bundle -> source file."""
    found: dict[Path, Path] = {}
    todo = list(starts)
    while todo:
        tree = ast.parse(todo.pop().read_text())
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                modules = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                modules = [node.module] + [f"{node.module}.{a.name}" for a in node.names]
            else:
                continue
            for dotted in modules:
                top, _, rest = dotted.partition(".")
                if top not in packages:
                    continue
                for rel in (Path(top, "__init__.py"), Path(top, *rest.split(".")).with_suffix(".py") if rest else None):
                    if rel is not None and rel not in found and (packages[top] / rel.relative_to(top)).is_file():
                        found[rel] = packages[top] / rel.relative_to(top)
                        todo.append(found[rel])
    return found


def _check_imports(text: str, lib: str, where: Path) -> set[str]:
    """Refuse a bundled package imported under its own name; return the third-party top-level imports."""
    names = top_level_imports(ast.parse(text, str(where)))
    escaped = names & set(BUNDLED)
    if escaped:
        raise PackagingError(f"{where}: import of {sorted(escaped)} was not renamed into {lib}")
    return {n for n in names if n not in sys.stdlib_module_names and n not in (lib, "__future__")}


def model_description(resources: Path, stem: str, model: str) -> Element:
    """The modelDescription of the staged model class (imported from ``resources``, then forgotten)."""
    sys.path.insert(0, str(resources))
    try:
        module = importlib.import_module(stem)
        instance = getattr(module, model)(instance_name="build", resources=str(resources))
        return instance.to_xml()
    finally:
        if str(resources) in sys.path:
            sys.path.remove(str(resources))
        for name in [n for n in sys.modules if n == stem or n.startswith(f"{stem}_lib")]:
            del sys.modules[name]


def _range(v: Element) -> str:
    low, high = v.get("min"), v.get("max")
    return "" if low is None and high is None else f"[{low if low is not None else '-inf'}, {high if high is not None else 'inf'}]"


def _compiled_html(cores: list[str]) -> str:
    if not cores:
        return "<h2>Compiled cores</h2><p>None: every module runs as Python source.</p>"
    names = ", ".join(f"<code>{html.escape(c)}</code>" for c in cores)
    return (f"<h2>Compiled cores</h2><p>{names} also ship compiled (Cython, from the same source) for "
            f"{html.escape(compiled.target())}; any other Python or platform runs their <code>.py</code>, "
            "with the same results.</p>")


def _requirements_html(model: str, requirements: list[str], exporter: str) -> str:
    if not requirements:
        return ("<p>Its code imports no package beyond Python's standard library, so "
                "<code>resources/requirements.txt</code> is empty and there is nothing to install.</p>")
    return (f"<p>These packages are listed in <code>resources/requirements.txt</code>; "
            f"<code>{exporter} deploy -f {html.escape(model)}.fmu</code> installs them. A missing package makes "
            "instantiation fail with a logged message that names it and its version range.</p>")


def documentation_html(model: str, xml: Element, equations: list[str], requirements: list[str],
                       cores: list[str] = ()) -> str:
    """``documentation/index.html``: what the FMU is, its ports, and what its host needs (no links)."""
    esc = html.escape
    rows: dict[str, list[str]] = {"input": [], "output": [], "parameter": []}
    for sv, typed, shape in _variables(xml):
        kind = sv.get("causality")
        if kind not in rows:
            continue
        rows[kind].append(
            f"<tr><td>{esc(sv.get('name'))}</td><td>{esc(typed.tag + shape)}</td><td>{esc(typed.get('unit') or '')}</td>"
            f"<td>{esc(typed.get('start') or '')}</td><td>{esc(_range(typed))}</td>"
            f"<td>{esc(sv.get('description') or '')}</td></tr>")
    tables = "".join(
        f"<h2>{title}</h2><table><tr><th>name</th><th>type</th><th>unit</th><th>start</th><th>range</th>"
        f"<th>meaning</th></tr>{''.join(rows[kind])}</table>"
        for kind, title in (("input", "Inputs"), ("output", "Outputs"), ("parameter", "Parameters")) if rows[kind])
    maths = "".join(f"<pre>{esc(text)}</pre>" for text in equations if text)
    reqs = "".join(f"<li><code>{esc(r)}</code></li>" for r in requirements)
    return (
        f"<!DOCTYPE html><html><head><meta charset=\"utf-8\"><title>{esc(model)}</title>"
        "<style>body{font-family:sans-serif;max-width:60em}td,th{border:1px solid #ccc;padding:2px 6px}"
        "table{border-collapse:collapse}pre{background:#f6f6f6;padding:6px}</style></head><body>"
        f"<h1>{esc(model)}</h1><p>{esc(xml.get('description') or '')}</p>"
        f"<p>FMI {esc(xml.get('fmiVersion'))} {' and '.join(_interfaces(xml))} FMU of sotc-cosim "
        f"{esc(xml.get('version') or '')}, {'instantiation token' if xml.get('instantiationToken') else 'GUID'} "
        f"<code>{esc(xml.get('guid') or xml.get('instantiationToken') or '')}</code>. Communication step T = {xml.find('DefaultExperiment').get('stepSize')} s by default.</p>"
        "<h2>Host requirements</h2><p>The FMU runs its Python code inside the host's Python interpreter "
        "(pythonfmu). That interpreter needs:</p>"
        f"<ul><li>CPython {' or '.join(MEASURED_PYTHONS)} (measured), with a shared libpython "
        "loaded into the host process</li>"
        f"{reqs}</ul>{_requirements_html(model, requirements, EXPORTERS[int(xml.get('fmiVersion', '2')[0])])}"
        f"{_compiled_html(list(cores))}{tables}<h2>Equations</h2>{maths}</body></html>\n")


def _variables(xml: Element):
    """(variable element, typed element, array shape text) of every variable, FMI 2.0 or 3.0."""
    if xml.get("fmiVersion", "").startswith("2"):
        return [(sv, next(iter(sv)), "") for sv in xml.iter("ScalarVariable")]
    return [(v, v, "".join(f"[{d.get('start')}]" for d in v.iter("Dimension")))
            for v in xml.find("ModelVariables")]


def _interfaces(xml: Element) -> list[str]:
    names = {"CoSimulation": "co-simulation", "ModelExchange": "Model Exchange"}
    return [label for tag, label in names.items() if xml.find(tag) is not None]


def write_fmu(dest_file: Path, model: str, resources: Path, xml: Element, documentation: str, fmi: int = 2,
              shim_binary: bytes | None = None) -> None:
    """Zip the FMU: modelDescription, pythonfmu's (pythonfmu3's) binaries renamed to the model (on
    ``shim.platform_folder``, ``shim_binary`` under that name and pythonfmu3's beside it), resources, docs."""
    with atomic_file(dest_file, "wb") as f, zipfile.ZipFile(f, "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr("modelDescription.xml", parseString(tostring(xml, "UTF-8")).toprettyxml(encoding="UTF-8"))
        for binary, platform in pythonfmu_binaries(EXPORTERS[fmi]):
            shimmed = shim_binary is not None and platform == shim.platform_folder()
            z.write(binary, f"binaries/{platform}/{model}{shim.INNER_SUFFIX if shimmed else ''}{binary.suffix}")
            if shimmed:
                z.writestr(f"binaries/{platform}/{model}{binary.suffix}", shim_binary)
        for item in sorted(resources.rglob("*")):
            if item.is_file():
                z.write(item, f"resources/{item.relative_to(resources).as_posix()}")
        z.writestr("documentation/index.html", documentation)


def _declarations(packages: dict[str, Path], lib: Path) -> dict[str, str]:
    """The ``.pxd`` files of the hot modules staged under ``lib`` (the bundle's library folder), renamed
    into it (``compiled.compile_bundle``)."""
    out = {}
    for rel in compiled.HOT:
        top, _, rest = compiled.declarations(rel).partition("/")
        source = Path(packages[top], rest) if top in packages else None
        if source is not None and source.is_file() and (lib / rel).is_file():
            out[f"{top}/{rest}"] = rename_imports(source.read_text(), lib.name)
    return out


def package_fmu(model: str, script: Path, packages: dict[str, Path], equations: list[Path],
                dest_file: Path, workdir: Path, compile_cores: bool = False,
                fmi: int = 2) -> tuple[Path, list[str], int]:
    """Stage, describe and zip one FMU into ``dest_file``; return it, the cores compiled into it
    (``compile_cores``: ``compiled.build_cores``) and how many of them came from the private cache. The
    bundle's module names carry the digest of its own content (``bundle_digest``), the extensions included."""
    resources = workdir / "resources"
    staged_stem = placeholder(model)
    requirements = stage(model, script, packages, staged_stem, resources, fmi)
    lib = f"{staged_stem}_lib"
    declared = _declarations(packages, resources / lib)
    cores, reused = compiled.build_cores(resources, lib, declared) if compile_cores else ([], 0)
    stem = bundle_stem(model, bundle_digest(bundled_files(resources), staged_stem, model))
    _rename_bundle(resources, staged_stem, stem)
    write_core_digests(resources)
    xml = model_description(resources, stem, model)
    write_bytecode(resources)
    shim_binary = None
    if fmi == 3 and shim_unavailable() is None:
        shim_binary = shim.binary(_pythonfmu_folder("pythonfmu3"), workdir)
        (resources / shim.SIZES_FILE).write_text(shim.sizes_table(xml))
    docs = [ast.get_docstring(ast.parse(p.read_text())) or "" for p in [script, *equations]]
    write_fmu(dest_file, model, resources, xml, documentation_html(model, xml, docs, requirements, cores), fmi,
              shim_binary)
    shutil.rmtree(resources)
    return dest_file, cores, reused
