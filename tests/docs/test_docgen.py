"""No number by hand: every generated block in README.md and docs/ is what the code produces now."""
from pathlib import Path

import pytest

from orchestration.reports import docgen

REPO = Path(__file__).resolve().parents[2]


@pytest.fixture(autouse=True)
def _this_checkout(monkeypatch):
    """The docs of this checkout: CI imports the installed package, whose folder has no docs."""
    monkeypatch.setattr(docgen, "ROOT", REPO)


FAST = [n for n, b in docgen.BLOCKS.items() if not b.slow]
SLOW = [n for n, b in docgen.BLOCKS.items() if b.slow]


@pytest.mark.parametrize("name", FAST)
def test_quick_generated_block_matches_the_code(name):
    assert docgen.committed(name) == docgen.render(name), \
        f"run: python -m orchestration.reports.docgen write {name}"


@pytest.mark.slow
@pytest.mark.parametrize("name", SLOW)
def test_long_generated_block_matches_the_code(name):
    assert docgen.committed(name) == docgen.render(name), \
        f"run: python -m orchestration.reports.docgen write {name}"


def test_a_hand_edited_number_is_caught(tmp_path, monkeypatch):
    """In a copy of the docs, edit one number of a block: ``check`` reports it (exit 1), and ``write``
    puts back what the code produces. The generator is stood in for by the committed text (the
    comparison itself is what is under test here; the real generators are checked above)."""
    produced = docgen.committed("settings")
    for rel in {b.file for b in docgen.BLOCKS.values()}:
        (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / rel).write_text((docgen.ROOT / rel).read_text())
    monkeypatch.setattr(docgen, "ROOT", tmp_path)
    monkeypatch.setattr(docgen, "render", lambda name: produced)
    monkeypatch.setattr(docgen, "store_perturbed", lambda names, workers: None)  # its runs: test_perturbed_store
    assert docgen.main(["check", "settings"]) == 0
    path = tmp_path / docgen.BLOCKS["settings"].file
    number = next(w for w in produced.split() if w.replace(".", "").isdigit() and "." in w)
    path.write_text(path.read_text().replace(produced, produced.replace(number, number + "1", 1)))
    assert docgen.main(["check", "settings"]) == 1
    assert docgen.main(["write", "settings"]) == 0 and docgen.committed("settings") == produced


@pytest.mark.parametrize("name", list(docgen.BLOCKS))
def test_every_block_has_its_markers_once_around_some_text(name):
    text = (REPO / docgen.BLOCKS[name].file).read_text()
    begin, end = f"<!-- BEGIN generated:{name} -->", f"<!-- END generated:{name} -->"
    assert text.count(begin) == 1 and text.count(end) == 1 and text.index(begin) < text.index(end), name
    assert docgen.committed(name).strip(), f"block {name} is empty"
