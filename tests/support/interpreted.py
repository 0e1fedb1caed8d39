"""The cores as their ``.py`` sources, whatever the installed build: CI installs the package compiled, and a
compiled module is C (its constants C variables, its interpreted paths never taken), so a test of the
interpreted build's own code loads that code from this checkout's ``.py`` files explicitly.

``interpreted("fmu_numerics.elementary_interpreted", ...)`` imports the named modules, and every module of the
project's core packages they import, from the ``.py`` files under the repository, into a separate set of
module objects: ``sys.modules`` and the installed packages are left as they were."""
from __future__ import annotations

import contextlib
import importlib
import importlib.abc
import importlib.util
import sys
from pathlib import Path
from types import ModuleType

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = ("fmi_slave", "fmu_numerics", "fmu_plant", "fmu_controller")


class _SourceFinder(importlib.abc.MetaPathFinder):
    """Finds the core packages and their modules as ``.py`` files under ``ROOT`` (never an extension)."""

    def find_spec(self, fullname, path=None, target=None):
        parts = fullname.split(".")
        if parts[0] not in PACKAGES:
            return None
        folder = ROOT.joinpath(*parts)
        if folder.is_dir():
            return importlib.util.spec_from_file_location(fullname, folder / "__init__.py",
                                                          submodule_search_locations=[str(folder)])
        return importlib.util.spec_from_file_location(fullname, folder.with_suffix(".py"))


@contextlib.contextmanager
def _own_modules():
    """Inside: the core packages import from their sources; outside again, as they were."""
    ours = [name for name in sys.modules if name.split(".")[0] in PACKAGES]
    saved = {name: sys.modules.pop(name) for name in ours}
    finder = _SourceFinder()
    sys.meta_path.insert(0, finder)
    try:
        yield
    finally:
        sys.meta_path.remove(finder)
        for name in [n for n in sys.modules if n.split(".")[0] in PACKAGES]:
            del sys.modules[name]
        sys.modules.update(saved)


def interpreted(*names: str) -> tuple[ModuleType, ...]:
    """The modules ``names`` loaded from their ``.py`` files (and what they import of the core packages)."""
    with _own_modules():
        modules = tuple(importlib.import_module(name) for name in names)
    for module in modules:
        assert module.__file__.endswith(".py"), module.__file__
    return modules
