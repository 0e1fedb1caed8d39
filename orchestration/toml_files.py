"""Reading a user's TOML file (a scenario or a sweep) so that a hostile or broken file gives one line
naming it, never a traceback and never a hang: too large, not UTF-8, not TOML, nested deeper than any
sotc-cosim file needs (Python's ``tomllib`` parses nested arrays and inline tables recursively, so
100,000 ``[`` would end in a ``RecursionError``; everything that reads the parsed tree later recurses
too), or a key of too many dotted parts (``tomllib`` takes time quadratic in them: 20,000 parts of one
key or table header took 63 s). Both are bounded by one scan before parsing. A signal the command
defers (``orchestration.run.interrupt``) also ends a parse at once (it waited for the parse's end).
"""
from __future__ import annotations

import re
import signal
import stat
import threading
import tomllib
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from orchestration.exit_codes import UsageError

MAX_BYTES = 1_000_000  # the shipped files are a few kB; a bigger one is not a scenario or sweep
MAX_DEPTH = 16  # tables and arrays nested in each other (the shipped files need at most 5)
# a tomllib parse may recurse a few frames per level: this many levels never reach Python's limit
_PARSE_DEPTH = 100
MAX_KEY_PARTS = 32  # dotted parts of one key or table header (the shipped files need at most 3)
# one token of the scan before parsing: strings and comments (skipped), a float (its dot is no key's),
# a separator between keys (group 1) or a dot (group 2)
_TOKENS = re.compile(r'''"""[\s\S]*?"""|\'\'\'[\s\S]*?\'\'\'|"(?:[^"\\\n]|\\.)*"|'[^'\n]*'|#[^\n]*'''
                     r"|[+-]?\d[\d_]*\.\d[\d_]*(?:[eE][+-]?\d[\d_]*)?|([=,{}\[\]\n])|(\.)")


def _depth(tree: Any) -> int:
    """How deeply tables and arrays nest in ``tree`` (iterative: a deep tree cannot exhaust the stack)."""
    deepest, todo = 0, [(tree, 0)]
    while todo:
        node, level = todo.pop()
        deepest = max(deepest, level)
        children = node.values() if isinstance(node, dict) else node if isinstance(node, list) else ()
        todo.extend((child, level + 1) for child in children)
    return deepest


def _structure(text: str) -> tuple[int, int]:
    """Upper bounds, before parsing, of the nesting of arrays and tables in ``text`` and of the dotted
    parts of any one key or header (strings and comments skipped; an unterminated one makes the bounds
    only larger: they are used to refuse, never to accept)."""
    level = deepest = dots = most = 0
    for match in _TOKENS.finditer(text):
        separator, dot = match.group(1), match.group(2)
        if dot:
            dots += 1
            most = max(most, dots)
        elif separator:
            dots = 0
            if separator in "[{":
                level += 1
                deepest = max(deepest, level)
            elif separator in "]}":
                level = max(0, level - 1)
    return deepest, most + 1


@contextmanager
def _signals_stop_reading(error: UsageError):
    """While a file is read and parsed (pure Python, no FMU call to protect), a signal the command
    defers still reaches its handler (which notes it) and then raises ``error`` at once: the command
    ends with the signal's exit code instead of after the parse."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)}

    def stop(signum, frame):
        previous[signum](signum, frame)
        raise error

    deferred = [s for s, handler in previous.items() if callable(handler) and handler is not signal.default_int_handler]
    for s in deferred:
        signal.signal(s, stop)
    try:
        yield
    finally:
        for s in deferred:
            signal.signal(s, previous[s])


def _parse(data: bytes, label: str, error: type[UsageError]) -> dict[str, Any]:
    if len(data) > MAX_BYTES:
        raise error(f"{label}: {len(data):,} bytes is too large for a sotc-cosim file (at most {MAX_BYTES:,})")
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise error(f"{label}: not UTF-8 text (byte {exc.start} is {data[exc.start:exc.start + 1]!r}); "
                    "save it as UTF-8") from None
    too_deep = f"{label}: tables and arrays nested more than {MAX_DEPTH} deep; sotc-cosim files need a few levels"
    depth, parts = _structure(text)
    if depth > _PARSE_DEPTH:
        raise error(too_deep)
    if parts > MAX_KEY_PARTS:
        raise error(f"{label}: a key or table header of more than {MAX_KEY_PARTS} dotted parts; sotc-cosim "
                    "files need a few")
    try:
        raw = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise error(f"{label} is not valid TOML: {exc}") from None
    except RecursionError:
        raise error(too_deep) from None
    if _depth(raw) > MAX_DEPTH:
        raise error(too_deep)
    return raw


def parse_toml(data: bytes, label: str, error: type[UsageError] = UsageError) -> dict[str, Any]:
    """The parsed file ``label`` (its bytes ``data``), or ``error`` with one line naming it."""
    with _signals_stop_reading(error(f"{label}: reading it was interrupted")):
        return _parse(data, label, error)


def read_toml(path: Path, label: str, error: type[UsageError] = UsageError) -> dict[str, Any]:
    """``parse_toml`` of the file at ``path``; one that cannot be read is ``error`` too (its size is
    looked at before it is read)."""
    with _signals_stop_reading(error(f"{label}: reading it was interrupted")):
        try:
            st = path.stat()
            if not stat.S_ISREG(st.st_mode) and not stat.S_ISDIR(st.st_mode):  # a folder: read_bytes says so
                raise error(f"{label}: not a regular file (a FIFO or a device would block the read or never end)")
            size = st.st_size
            if size > MAX_BYTES:
                raise error(f"{label}: {size:,} bytes is too large for a sotc-cosim file (at most {MAX_BYTES:,})")
            data = path.read_bytes()
        except OSError as exc:
            raise error(f"{label}: cannot be read ({exc.strerror or exc})") from None
        return _parse(data, label, error)


def unknown_file(name_or_path: str, what: str, known: list[str], error: type[UsageError] = UsageError) -> UsageError:
    """The error for a ``what`` (scenario, sweep) that is neither a shipped one nor a ``.toml`` file: a file or
    folder of that name is said to be one (``sweep /etc/passwd`` said "no sweep" of a file that exists)."""
    path, choose = Path(name_or_path), f"give a .toml path or one of {', '.join(known)}"
    if path.is_dir():
        return error(f"{what} '{name_or_path}': is a folder, not a TOML {what} file; {choose}")
    if path.exists():
        return error(f"{what} '{name_or_path}': not a TOML {what} file (a {what} file's name ends in .toml); {choose}")
    return error(f"no {what} '{name_or_path}': {choose}")
