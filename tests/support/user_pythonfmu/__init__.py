"""``user_pd.py`` built into ``UserPd.fmu`` by pythonfmu's own command, as its user builds it."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

SCRIPT = Path(__file__).resolve().parent / "user_pd.py"


def build(folder: Path) -> Path:
    done = subprocess.run([sys.executable, "-m", "pythonfmu", "build", "-f", str(SCRIPT), "-d", str(folder)],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stdout + done.stderr
    return folder / "UserPd.fmu"
