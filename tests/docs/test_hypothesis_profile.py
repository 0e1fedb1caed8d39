"""CI (the env var CI set) draws the same hypothesis examples on every run, so one commit's result
never flips; elsewhere each run explores new ones (tests/conftest.py)."""
import os
import subprocess
import sys
from pathlib import Path

from hypothesis import settings

TESTS = Path(__file__).resolve().parents[1]


def test_this_session_loaded_the_profile_of_its_environment():
    assert settings.default.derandomize is bool(os.environ.get("CI"))


def test_ci_derandomizes_and_a_local_run_explores():
    code = ("import sys; sys.path.insert(0, sys.argv[1]); import conftest; "
            "from hypothesis import settings; print(settings.default.derandomize)")
    for ci, expected in (("true", "True"), ("", "False")):
        env = {k: v for k, v in os.environ.items() if k != "CI"} | ({"CI": ci} if ci else {})
        out = subprocess.run([sys.executable, "-c", code, str(TESTS)], env=env, capture_output=True, text=True,
                             timeout=120)
        assert out.stdout.strip() == expected, (ci, out.stderr[-2000:])
