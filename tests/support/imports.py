"""The project's import graph, read from the sources (imports inside functions included; those under
``if TYPE_CHECKING:`` aside), for the architecture tests."""
from __future__ import annotations

import ast
import sys
from pathlib import Path

from orchestration.fmu_build.compiled import cimports

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = ("fmi_slave", "fmi3_slave", "fmu_numerics", "fmu_plant", "fmu_controller", "orchestration")


def modules(root: Path = ROOT) -> dict[str, Path]:
    """Dotted module name -> file, for every module of the project's packages."""
    out = {}
    for pkg in PACKAGES:
        for path in sorted((root / pkg).rglob("*.py")):
            parts = path.relative_to(root).with_suffix("").parts
            out[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    return out


def _type_checking_nodes(tree: ast.AST) -> set[int]:
    skip = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            skip.update(id(n) for child in node.body for n in ast.walk(child))
    return skip


def imported_names(path: Path, module: str) -> set[str]:
    """Every dotted name ``module`` imports (``from a import b`` gives ``a`` and ``a.b``)."""
    tree = ast.parse(path.read_text(), str(path))
    skip = _type_checking_nodes(tree)
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    names = set()
    for node in ast.walk(tree):
        if id(node) in skip:
            continue
        if isinstance(node, ast.Import):
            names.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package.split(".")[: len(package.split(".")) - node.level + 1]
                base = ".".join(anchor + ([node.module] if node.module else []))
            names.add(base)
            names.update(f"{base}.{a.name}" for a in node.names)
    return names


def cimported_names(path: Path) -> set[str]:
    """What the ``.pxd`` beside a module cimports (the compiled build's imports; none without a ``.pxd``)."""
    pxd = path.with_suffix(".pxd")
    return cimports(pxd.read_text()) if pxd.is_file() else set()


def graph(root: Path = ROOT) -> dict[str, set[str]]:
    """Module -> the project modules it imports, its ``.pxd``'s cimports included."""
    mods = modules(root)
    return {m: {n for n in imported_names(p, m) | cimported_names(p) if n in mods and n != m} for m, p in mods.items()}


def third_party(root: Path = ROOT) -> dict[str, set[str]]:
    """Module -> the top-level names of what it imports outside the project and the standard library."""
    mods = modules(root)
    return {m: {n.split(".")[0] for n in imported_names(p, m)} - set(PACKAGES) - set(sys.stdlib_module_names)
            for m, p in mods.items()}


def cycles(edges: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []
    for start in edges:
        if start in index:
            continue
        work = [(start, iter(sorted(edges[start])))]
        index[start] = low[start] = len(index)
        stack.append(start)
        on_stack.add(start)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = len(index)
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(edges.get(child, ())))))
                elif child in on_stack:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                component = []
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.append(member)
                    if member == node:
                        break
                if len(component) > 1:
                    found.append(sorted(component))
    return found


def room(module: str) -> str:
    """The folder a module lives in, as docs/architecture.md names it (``orchestration/run``,
    ``orchestration`` for the top-level modules, ``fmu_plant``...)."""
    parts = module.split(".")
    if parts[0] == "orchestration" and len(parts) > 2:
        return f"orchestration/{parts[1]}"
    if parts[0] == "orchestration" and len(parts) == 2 and (ROOT / "orchestration" / parts[1]).is_dir():
        return f"orchestration/{parts[1]}"
    return parts[0]
