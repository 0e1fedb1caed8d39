"""The one Markdown writer of sotc-cosim: numbers in cells, tables, and the generated blocks
(``<!-- BEGIN generated:NAME -->`` ... ``<!-- END generated:NAME -->``) that commands rewrite in
README.md and docs/."""
from __future__ import annotations

import math
import re
from typing import Any, Sequence

MISSING = "-"  # a number that is absent or undefined (None, NaN, infinity)


def number(value: Any, spec: str = ".4g") -> str:
    """``value`` formatted with ``spec``; an integer as itself; None or a non-finite value as '-'."""
    if value is None:
        return MISSING
    if isinstance(value, int) and not isinstance(value, bool) or type(value).__name__.startswith(("int", "uint")):
        return str(int(value))
    value = float(value)
    return format(value, spec) if math.isfinite(value) else MISSING


def pair(values: Sequence[Any] | None, spec: str = ".4g") -> str:
    """Two joints' values as 'a / b'."""
    return MISSING if values is None else f"{number(values[0], spec)} / {number(values[1], spec)}"


def table(header: Sequence[str], rows: Sequence[Sequence[Any]], align: str = "") -> str:
    """A Markdown table; ``align`` has one letter per column ('l' or 'r', default 'l'). A '|' inside
    a cell is escaped, so a cell can never split the row."""
    def cells(row: Sequence[Any]) -> str:
        return "| " + " | ".join(str(c).replace("|", "\\|") for c in row) + " |"

    rule = ["---:" if align[i:i + 1] == "r" else "---" for i in range(len(header))]
    return "\n".join([cells(header), "| " + " | ".join(rule) + " |", *(cells(r) for r in rows)])


def block_pattern(name: str) -> re.Pattern[str]:
    return re.compile(rf"(<!-- BEGIN generated:{re.escape(name)} -->\n)(.*?)(<!-- END generated:{re.escape(name)} -->)",
                      re.S)


def replace_block(text: str, name: str, content: str) -> str:
    """``text`` with block ``name`` holding ``content`` (the block is appended if ``text`` has none)."""
    content = content.rstrip("\n") + "\n"
    if block_pattern(name).search(text) is None:
        return text.rstrip("\n") + f"\n\n<!-- BEGIN generated:{name} -->\n{content}<!-- END generated:{name} -->\n"
    return block_pattern(name).sub(lambda m: m.group(1) + content + m.group(3), text)


def stable(value: Any, other: Any, spec: str = ".4g") -> str:
    """``value`` to at most ``spec``'s significant digits, and to no more than it shares with ``other``,
    the same figure after a tiny change of the initial state (``comparison.NUDGE``): only the digits
    that reproduce. A figure whose first digit already moves is printed as '~' and that digit."""
    if other is None or value is None or isinstance(value, (bool, int)) or type(value).__name__.startswith(("int", "uint")):
        return number(value, spec) if value == other else f"{number(value, spec)} (or {number(other, spec)})"
    a, b = float(value), float(other)
    if not (math.isfinite(a) and math.isfinite(b)):
        return number(a, spec)
    digits = int(spec.strip(".g"))
    for d in range(digits, 0, -1):
        if format(a, f".{d}g") == format(b, f".{d}g"):
            return format(a, f".{d}g")
    return "~" + format(a, ".1g")


def stable_pair(values: Sequence[Any] | None, others: Sequence[Any] | None, spec: str = ".4g") -> str:
    """Two joints' values as 'a / b', each to its reproducible digits (``stable``)."""
    if values is None or others is None:
        return pair(values, spec)
    return f"{stable(values[0], others[0], spec)} / {stable(values[1], others[1], spec)}"
