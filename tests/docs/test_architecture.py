"""The layout docs/architecture.md promises, checked on the sources: what each folder may import, no
import cycle (imports inside functions count; ``if TYPE_CHECKING:`` blocks aside), small modules,
short functions where the maths and the loop live, and the tree the document opens with."""
from __future__ import annotations

import ast
import functools
import re

import pytest

from support import REPO
from support.doc_paths import exists, named_paths
from support.imports import PACKAGES, cycles, graph, modules, room, third_party

# folder -> the folders of the project it may import (besides itself); docs/architecture.md's table
ALLOWED = {
    "fmi_slave": set(),
    "fmi3_slave": {"fmi_slave"},
    "fmu_numerics": set(),
    "fmu_plant": {"fmi_slave", "fmu_numerics"},
    "fmu_controller": {"fmi_slave", "fmu_numerics", "fmu_plant"},
    "orchestration/run": {"fmi_slave", "fmi3_slave", "fmu_numerics", "fmu_plant", "fmu_controller", "orchestration"},
    "orchestration/fmu_build": {"fmi_slave", "fmu_numerics", "fmu_plant", "fmu_controller", "orchestration"},
    "orchestration/recording": {"fmu_numerics", "fmu_plant", "fmu_controller", "orchestration", "orchestration/run"},
    "orchestration/study": {"fmu_numerics", "fmu_plant", "fmu_controller", "orchestration", "orchestration/run"},
    "orchestration/compliance": {"fmi_slave", "fmu_numerics", "fmu_plant", "fmu_controller", "orchestration", "orchestration/run",
                                 "orchestration/fmu_build"},
    "orchestration/sweep": {"fmu_numerics", "fmu_plant", "fmu_controller", "orchestration", "orchestration/run",
                            "orchestration/fmu_build", "orchestration/recording", "orchestration/study"},
    "orchestration/bench": {"fmu_numerics", "fmu_plant", "fmu_controller", "orchestration", "orchestration/run",
                            "orchestration/fmu_build", "orchestration/recording", "orchestration/study",
                            "orchestration/sweep"},
    "orchestration/reports": {"fmu_numerics", "fmu_plant", "fmu_controller", "orchestration", "orchestration/run",
                              "orchestration/study", "orchestration/sweep", "orchestration/bench"},
}
BASE = {"orchestration.paths", "orchestration.progress", "orchestration.markdown", "orchestration.exit_codes",
        "orchestration.outputs", "orchestration.toml_files", "orchestration.scratch"}
ARM_MODEL = {"fmu_plant.dynamics", "fmu_plant.kinematics", "fmu_plant.trajectory"}
CORE_FOLDERS = ("fmi_slave", "fmi3_slave", "fmu_numerics", "fmu_plant", "fmu_controller")
MAX_MODULE_LINES = 500
MAX_FUNCTION_LINES = 80


@functools.lru_cache(maxsize=1)
def _graph() -> dict:
    """The import graph, parsed when a test first asks (at import it cost every xdist worker's collection a second)."""
    return graph()


def _folder_of(module: str) -> str:
    return "orchestration" if module in BASE or module == "orchestration" else room(module)


def test_no_import_cycle():
    assert cycles(_graph()) == []


@pytest.mark.parametrize("folder", sorted(ALLOWED))
def test_each_folder_imports_only_what_it_may(folder):
    wrong = sorted(f"{m} -> {t}" for m, targets in _graph().items() if _folder_of(m) == folder
                   for t in targets if _folder_of(t) not in ALLOWED[folder] | {folder})
    assert wrong == []


def test_the_base_modules_of_orchestration_import_no_other_part_of_it():
    wrong = sorted(f"{m} -> {t}" for m in BASE for t in _graph()[m] if t.startswith("orchestration") and t not in BASE)
    assert wrong == []


def test_the_fmu_packages_need_no_pythonfmu_and_controllers_only_the_arm_model():
    imports = third_party()
    assert sorted(m for m in imports if m.startswith(("fmu_plant", "fmu_controller")) and "pythonfmu" in imports[m]) == []
    assert sorted(imports["fmi_slave.parameters"]) == []  # the cores' parameter tables need no pythonfmu
    wrong = sorted(f"{m} -> {t}" for m, targets in _graph().items() if m.startswith("fmu_controller")
                   for t in targets if t.startswith("fmu_plant") and t not in ARM_MODEL)
    assert wrong == []
    assert not any(t.startswith("orchestration") for m, ts in _graph().items() if m.startswith(CORE_FOLDERS) for t in ts)


# the floors of the FMU packages, lowest first: a module imports only its own floor and those below
FLOORS = ("fmu_numerics", "fmu_plant", "fmu_controller")


def test_no_import_runs_up_a_floor():
    """The numerics under the arm, the arm under the controllers: the plant needs no controller code (so
    its FMU bundles none) and the numerics need neither."""
    floor = {m: FLOORS.index(m.split(".")[0]) for m in _graph() if m.split(".")[0] in FLOORS}
    up = sorted(f"{m} -> {t}" for m in floor for t in _graph()[m] if t in floor and floor[t] > floor[m])
    assert up == []


def test_orchestration_is_grouped_by_role():
    top = sorted(p.stem for p in (REPO / "orchestration").glob("*.py"))
    packages = sorted(p.name for p in (REPO / "orchestration").iterdir() if (p / "__init__.py").is_file())
    assert len(top) <= 10 and len(packages) >= 4, (top, packages)


def _python_files():
    for folder in (*PACKAGES, "tests"):
        yield from sorted((REPO / folder).rglob("*.py"))


def test_no_module_over_500_lines():
    long = [f"{p.relative_to(REPO)}: {n}" for p in _python_files() if (n := p.read_text().count("\n")) > MAX_MODULE_LINES]
    assert long == []


def test_no_function_over_80_lines_in_the_cores_and_the_master():
    files = [p for f in CORE_FOLDERS for p in sorted((REPO / f).rglob("*.py"))] + [REPO / "orchestration/run/master.py"]
    long = [f"{p.relative_to(REPO)}:{node.lineno} {node.name} ({node.end_lineno - node.lineno + 1} lines)"
            for p in files for node in ast.walk(ast.parse(p.read_text()))
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef))
            and node.end_lineno - node.lineno + 1 > MAX_FUNCTION_LINES]
    assert long == []


def test_architecture_md_opens_with_the_tree_of_every_package_folder():
    text = (REPO / "docs" / "architecture.md").read_text()
    tree = text.split("```")[1]  # the first code block
    assert text.index("```") < text.index("\n## "), "the tree comes before the first section"
    folders = {str(p.parent.relative_to(REPO)) for m, p in modules().items() if p.name == "__init__.py"}
    folders |= {"tests/unit", "tests/fmu", "tests/orchestration", "tests/shipped", "tests/docs", "tests/support",
                "tests/faults"}
    named = {line.split()[0].rstrip("/") for line in tree.splitlines() if line.strip()}
    leaves = {f.split("/")[-1] for f in folders if "scenarios" not in f and "presets" not in f}
    assert leaves <= {n.split("/")[-1] for n in named}, sorted(leaves - {n.split("/")[-1] for n in named})


def test_readme_layout_section_names_the_same_folders_as_architecture_md():
    arch = (REPO / "docs" / "architecture.md").read_text().split("```")[1]
    readme = (REPO / "README.md").read_text()
    layout = readme[readme.index("## Layout"):]
    layout = layout[:layout.index("\n## ", 1)] if "\n## " in layout[1:] else layout
    top = {line.split()[0].rstrip("/") for line in arch.splitlines() if line and not line.startswith(" ")}
    assert all(re.search(rf"`{re.escape(name)}/?`", layout) for name in top), (top, layout)


def test_every_path_architecture_md_names_exists():
    named = named_paths((REPO / "docs" / "architecture.md").read_text())
    assert len(named) > 20 and "orchestration/run/master.py" in named
    assert [p for p in named if not exists(p)] == []
