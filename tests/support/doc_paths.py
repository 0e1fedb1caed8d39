"""The repository paths a document names, and whether each exists: for the tests that keep the docs in step
with the code (tests/docs/test_architecture.py, tests/docs/test_doc_paths.py)."""
from __future__ import annotations

import re
from pathlib import Path

from support import REPO

OUTPUTS = ("recordings/", "build/")  # folders the commands write; nothing in them is committed
_SKIP = {".venv", "build", ".git"}


def named_paths(text: str) -> list[str]:
    """The repository paths a document names in backticks: those under a top-level folder of the repository
    (a test's node id ``file::name`` too), and bare file names of sources (``x.py``, ``x.pxd``, ``x.c``);
    paths inside an FMU (``resources/...``), placeholders (``<name>``), outputs and URLs are no repository paths."""
    top = {p.name for p in REPO.iterdir()}
    spans = set(re.findall(r"`([^`\s]+)`", text))
    return sorted(s for s in spans if "<" not in s and not s.startswith(OUTPUTS)
                  and ("/" in s and s.split("/")[0] in top or "/" not in s and re.fullmatch(r"[\w*]+\.(py|pxd|c)(::\w+)?", s)))


def _files(name: str, under_tests: bool) -> list[Path]:
    found = [p for p in REPO.rglob(name) if not _SKIP & set(p.relative_to(REPO).parts)]
    return [p for p in found if ("tests" in p.relative_to(REPO).parts) == under_tests]


def exists(path: str) -> bool:
    """A path under the repository (a node id's test function defined in its file), or a bare file name
    that names exactly one file: of the tests for a test module (``test_*.py``), of the project's own code
    otherwise (``cli.py`` names no module since cli became a package)."""
    path, _, test = path.partition("::")
    if "/" in path:
        files = sorted(REPO.glob(path.rstrip("/"))) if "*" in path else [REPO / path]
        files = [f for f in files if f.exists()]
    else:
        files = _files(path, under_tests=path.startswith("test_"))
        files = files if len(files) == 1 or "*" in path else []  # a pattern (`*_fmu.py`) may name several
    if test:
        return any(f.is_file() and re.search(rf"^def {test}\(", f.read_text(), re.M) for f in files)
    return bool(files)
