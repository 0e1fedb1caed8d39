"""docs/testing.md and the mutation job agree with the code: every module the job mutates and every test
file it runs exist, and every mutant the page calls equivalent names a function of a mutated module."""
import importlib.util
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def _job():
    spec = importlib.util.spec_from_file_location("ci_mutation", ROOT / ".ci" / "mutation.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_job_names_modules_and_tests_that_exist():
    job = _job()
    assert set(Path(m).stem for m in job.MODULES) == {"saturation", "dynamics", "kinematics", "trajectory",
                                                      "sotc_math", "sotc_math_interpreted", "statistics", "metrics"}
    for module, tests in job.MODULES.items():
        assert (ROOT / module).is_file(), module
        assert all((ROOT / job.UNIT / t).is_file() for t in tests), tests


def test_every_equivalent_mutant_names_a_function_of_a_mutated_module():
    job = _job()
    names = job.EQUIVALENT.findall((ROOT / "docs" / "testing.md").read_text())
    assert names
    for name in names:
        dotted, function = re.fullmatch(r"([\w.]+)\.(?:x_|xǁ\w+ǁ)(\w+?)__mutmut_\d+", name).groups()
        path = dotted.replace(".", "/") + ".py"
        assert path in job.MODULES, name
        assert re.search(rf"^\s*def {re.escape(function)}\(", (ROOT / path).read_text(), re.M), name
