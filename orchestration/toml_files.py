"""Reading a user's TOML file (a scenario or a sweep) so that a hostile or broken file gives one line
naming it, never a traceback: too large, not UTF-8, not TOML, or nested deeper than any sotc-cosim
file needs (Python's ``tomllib`` parses nested arrays and inline tables recursively, so 100,000 ``[``
would end in a ``RecursionError``; everything that reads the parsed tree later recurses too).
"""
from __future__ import annotations

import tomllib
from pathlib import Path
from typing import Any

from orchestration.exit_codes import UsageError

MAX_BYTES = 1_000_000  # the shipped files are a few kB; a bigger one is not a scenario or sweep
MAX_DEPTH = 16  # tables and arrays nested in each other (the shipped files need at most 5)
# a tomllib parse may recurse a few frames per level: this many levels never reach Python's limit
_PARSE_DEPTH = 100


def _depth(tree: Any) -> int:
    """How deeply tables and arrays nest in ``tree`` (iterative: a deep tree cannot exhaust the stack)."""
    deepest, todo = 0, [(tree, 0)]
    while todo:
        node, level = todo.pop()
        deepest = max(deepest, level)
        children = node.values() if isinstance(node, dict) else node if isinstance(node, list) else ()
        todo.extend((child, level + 1) for child in children)
    return deepest


def _bracket_depth(text: str) -> int:
    """An upper bound of the nesting of inline arrays and tables in ``text`` (strings not excluded,
    so a bracket inside a string counts too: the bound is only used to refuse before parsing)."""
    level = deepest = 0
    for ch in text:
        if ch in "[{":
            level += 1
            deepest = max(deepest, level)
        elif ch in "]}":
            level = max(0, level - 1)
    return deepest


def parse_toml(data: bytes, label: str, error: type[UsageError] = UsageError) -> dict[str, Any]:
    """The parsed file ``label`` (its bytes ``data``), or ``error`` with one line naming it."""
    if len(data) > MAX_BYTES:
        raise error(f"{label}: {len(data):,} bytes is too large for a sotc-cosim file (at most {MAX_BYTES:,})")
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise error(f"{label}: not UTF-8 text (byte {exc.start} is {data[exc.start:exc.start + 1]!r}); "
                    "save it as UTF-8") from None
    too_deep = f"{label}: tables and arrays nested more than {MAX_DEPTH} deep; sotc-cosim files need a few levels"
    if _bracket_depth(text) > _PARSE_DEPTH:
        raise error(too_deep)
    try:
        raw = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise error(f"{label} is not valid TOML: {exc}") from None
    except RecursionError:
        raise error(too_deep) from None
    if _depth(raw) > MAX_DEPTH:
        raise error(too_deep)
    return raw


def read_toml(path: Path, label: str, error: type[UsageError] = UsageError) -> dict[str, Any]:
    """``parse_toml`` of the file at ``path``; one that cannot be read is ``error`` too (its size is
    looked at before it is read)."""
    try:
        size = path.stat().st_size
        if size > MAX_BYTES:
            raise error(f"{label}: {size:,} bytes is too large for a sotc-cosim file (at most {MAX_BYTES:,})")
        data = path.read_bytes()
    except OSError as exc:
        raise error(f"{label}: cannot be read ({exc.strerror or exc})") from None
    return parse_toml(data, label, error)
