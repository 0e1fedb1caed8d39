"""Mutation testing of the pure cores with mutmut (the scheduled job; not part of `pytest`, which it would
lengthen by about an hour on 2 cores).

    python .ci/mutation.py [MODULE ...]      # default: every module of MODULES

For each module, in a scratch copy of the repository's tracked files (the work tree is never touched),
mutmut mutates that module alone and runs the unit tests of MODULES against each mutant. Prints, per
module, the mutants, those killed and each survivor (with its diff), and exits 1 when a survivor is not
listed as equivalent in docs/testing.md (a line "- `NAME`: why"), 0 otherwise. Mutants are named by
function and number, so a change of a module renumbers them: run this again and update the list.
"""
from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
UNIT = "tests/unit/"
# module -> the unit tests that exercise it (each mutant runs those of them that call the mutated function)
MODULES = {
    "fmu_controller/saturation.py": ["test_saturation.py", "test_saturation_exact.py"],
    "fmu_plant/dynamics.py": ["test_arm_dynamics.py", "test_arm_lagrangian.py", "test_arm_integration.py"],
    "fmu_plant/kinematics.py": ["test_kinematics_exact.py", "test_trajectory.py", "test_arm_dynamics.py"],
    "fmu_plant/trajectory.py": ["test_kinematics_exact.py", "test_trajectory.py"],
    # test_sotc_core.py's loops would take hours over every mutant: the references of test_sotc_exact.py do
    "fmu_controller/sotc_math.py": ["test_sotc_exact.py", "test_interpreted_paths.py"],
    "fmu_controller/sotc_math_interpreted.py": ["test_interpreted_paths.py"],
    "orchestration/study/statistics.py": ["test_statistics.py"],
    "orchestration/run/metrics.py": ["test_metrics.py", "test_metrics_exact.py"],
}
# FMU tests (they build FMUs) and the slow ones stay out; one process per mutant, no xdist
PYTEST_ARGS = ["-n", "0", "-p", "no:cacheprovider", "-m", "not slow", "-q", "-k", "not fmu"]
EQUIVALENT = re.compile(r"^- `([\w.]+__mutmut_\d+)`: ", re.M)
DETECTED = ("killed", "timeout")  # a mutant that makes its tests fail, or hang past mutmut's limit


def scratch_copy(dest: Path) -> None:
    files = subprocess.run(["git", "ls-files", "-z"], cwd=ROOT, capture_output=True, check=True).stdout.split(b"\0")
    for name in (f.decode() for f in files if f):
        if (ROOT / name).is_file():
            (dest / name).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(ROOT / name, dest / name)


def configure(dest: Path, module: str) -> None:
    tests = [UNIT + t for t in MODULES[module]]
    with open(dest / "pyproject.toml", "a") as f:
        f.write(f"""
[tool.mutmut]
source_paths = ["fmi_slave/", "fmu_numerics/", "fmu_plant/", "fmu_controller/", "orchestration/"]
only_mutate = ["{module}"]
pytest_add_cli_args = {PYTEST_ARGS!r}
pytest_add_cli_args_test_selection = {tests!r}
""".replace("'", '"'))


def mutate(module: str, children: int) -> tuple[dict[str, str], dict[str, str]]:
    """(status by mutant, diff by survivor) of one module."""
    with tempfile.TemporaryDirectory(prefix="sotc_mutation_") as tmp:
        dest = Path(tmp)
        scratch_copy(dest)
        configure(dest, module)
        env = {**os.environ, "PYTHONPATH": "", "CI": "true"}  # CI: hypothesis's derandomized profile
        subprocess.run([sys.executable, "-m", "mutmut", "run", "--max-children", str(children)], cwd=dest, env=env,
                       stdout=subprocess.DEVNULL, check=True)
        listing = subprocess.run([sys.executable, "-m", "mutmut", "results", "--all", "true"], cwd=dest, env=env,
                                 capture_output=True, text=True, check=True).stdout
        status = dict(re.findall(r"^\s*([\w.]+__mutmut_\d+): (.+)$", listing, re.M))
        diffs = {name: subprocess.run([sys.executable, "-m", "mutmut", "show", name], cwd=dest, env=env,
                                      capture_output=True, text=True).stdout
                 for name, what in status.items() if what not in DETECTED}
    return status, diffs


def main(argv: list[str]) -> int:
    modules = argv or list(MODULES)
    unknown = [m for m in modules if m not in MODULES]
    if unknown:
        print(f"mutation: unknown module {unknown[0]}; known: {', '.join(MODULES)}", file=sys.stderr)
        return 2
    equivalent = set(EQUIVALENT.findall((ROOT / "docs" / "testing.md").read_text()))
    unexplained = 0
    for module in modules:
        status, diffs = mutate(module, max(1, os.cpu_count() or 1))
        killed = sum(1 for s in status.values() if s in DETECTED)
        print(f"## {module}: {len(status)} mutants, {killed} killed, {len(status) - killed} not")
        for name, what in sorted(status.items()):
            if what in DETECTED:
                continue
            said = "equivalent (docs/testing.md)" if name in equivalent else "NOT EXPLAINED"
            unexplained += name not in equivalent
            print(f"- {name}: {what}, {said}")
            print("".join(f"    {line}\n" for line in diffs[name].splitlines() if line[:2] in ("- ", "+ ")), end="")
    print(f"{unexplained} survivor(s) neither killed nor explained")
    return 1 if unexplained else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
