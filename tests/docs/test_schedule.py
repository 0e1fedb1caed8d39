"""The order the workers take the test files in (tests/support/schedule.py): longest first, every listed
file one that exists, and xdist told to keep the order (it reorders by test count otherwise)."""
from __future__ import annotations

import tomllib
from pathlib import Path
from types import SimpleNamespace

from support import REPO
from support.schedule import LONGEST_FIRST, longest_first


def test_every_listed_file_exists_once():
    assert len(set(LONGEST_FIRST)) == len(LONGEST_FIRST)
    assert [p for p in LONGEST_FIRST if not (REPO / p).is_file()] == []


def test_listed_files_come_first_in_their_order_and_the_rest_as_collected():
    ids = ["tests/a.py::t1", f"{LONGEST_FIRST[1]}::x", "tests/b.py::t1", f"{LONGEST_FIRST[0]}::y",
           "tests/a.py::t2", f"{LONGEST_FIRST[1]}::z"]
    items = [SimpleNamespace(nodeid=i) for i in ids]
    longest_first(items)
    assert [i.nodeid for i in items] == [f"{LONGEST_FIRST[0]}::y", f"{LONGEST_FIRST[1]}::x", f"{LONGEST_FIRST[1]}::z",
                                         "tests/a.py::t1", "tests/a.py::t2", "tests/b.py::t1"]


def test_xdist_keeps_the_collected_order_of_the_files():
    options = tomllib.loads((REPO / "pyproject.toml").read_text())["tool"]["pytest"]["ini_options"]["addopts"].split()
    assert "--dist" in options and options[options.index("--dist") + 1] == "loadfile"
    assert "--no-loadscope-reorder" in options
