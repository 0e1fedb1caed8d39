"""Every path the README and the docs name exists: files, folders and tests' node ids (a doc once named
tests/test_docgen.py a year after the tests moved into folders by layer)."""
from __future__ import annotations

import pytest

from support import REPO
from support.doc_paths import exists, named_paths

PAGES = sorted(p.relative_to(REPO).as_posix() for p in [REPO / "README.md", *(REPO / "docs").glob("*.md")])


@pytest.mark.parametrize("page", PAGES)
def test_every_path_a_page_names_exists(page):
    assert [p for p in named_paths((REPO / page).read_text()) if not exists(p)] == []


def test_the_check_finds_what_is_missing():
    assert exists("tests/docs/test_doc_paths.py::test_every_path_a_page_names_exists")
    assert exists("test_doc_paths.py") and exists("orchestration/fmu_build/") and exists("fmu_plant/*_fmu.py")
    assert not exists("tests/test_docgen.py") and not exists("tests/docs/test_doc_paths.py::no_such_test")
    assert not exists("cli.py") and not exists("no_such_module.py") and not exists("fmu_controller/no_such.py")
    assert named_paths("`recordings/paper.rrd` `docs/sweeps/<sweep>/` `resources/x.py` `tests/a.py`") == ["tests/a.py"]
