"""What the tests share: FMU drivers, the installed-wheel fixture, the reference runs, the import
graph. ``tests/`` is on ``sys.path`` through pytest's ``pythonpath`` setting (pyproject.toml); a
child process gets it through ``child_env``."""
from __future__ import annotations

import os
from pathlib import Path

TESTS = Path(__file__).resolve().parents[1]
REPO = TESTS.parent


def child_env() -> dict[str, str]:
    """This process's environment with ``tests/`` on PYTHONPATH, for ``python -m support.<module>``."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(TESTS), env.get("PYTHONPATH", "")) if p)
    return env
