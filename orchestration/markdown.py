"""The one Markdown writer of sotc-cosim: numbers in cells, tables, and the generated blocks
(``<!-- BEGIN generated:NAME -->`` ... ``<!-- END generated:NAME -->``) that commands rewrite in
README.md and docs/."""
from __future__ import annotations

import math
import re
import statistics
from decimal import ROUND_CEILING, ROUND_FLOOR, Decimal
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


def _is_int(value: Any) -> bool:
    return isinstance(value, int) and not isinstance(value, bool) or type(value).__name__.startswith(("int", "uint"))


def _missing(value: Any) -> bool:
    """None, or a value that is not a finite number (printed as ``MISSING``)."""
    return value is None or isinstance(value, bool) or not _is_int(value) and not math.isfinite(float(value))


MIN_DIGITS = 2  # a figure of which fewer significant digits hold over the perturbed runs is printed as chaotic


def stable(value: Any, others: Sequence[Any], spec: str = ".4g") -> str:
    """``value`` to at most ``spec``'s significant digits, and to no more than every one of ``others``
    (the same figure after each perturbation of the initial state, ``comparison.PERTURBATIONS``) shares
    with it: only the digits that reproduce. A figure of which fewer than ``MIN_DIGITS`` hold is printed as
    'chaotic: ' with the median and the range of all the runs; counts that differ as their range; a figure
    that some runs do not have, as the rule gives it over the runs that have it, and '-' for the others."""
    values = [value, *others]
    present = [v for v in values if not _missing(v)]
    if len(present) < len(values):
        if not present:
            return MISSING
        shown = stable(present[0], present[1:], spec)
        return f"{MISSING} (or {shown})" if _missing(value) else f"{shown} (or {MISSING})"
    if all(_is_int(v) for v in values):
        low, high = min(values), max(values)
        return number(value) if low == high else f"{number(low)}–{number(high)}"
    digits = int(spec.strip(".g"))
    for d in range(digits, min(MIN_DIGITS, digits) - 1, -1):
        text = format(float(value), f".{d}g")
        if all(format(float(v), f".{d}g") == text for v in others):
            return text
    return chaotic([float(v) for v in values])


def chaotic(values: Sequence[float]) -> str:
    """'chaotic: ' the median of ``values`` (two digits), and their range rounded outwards."""
    low, high = min(values), max(values)
    return f"chaotic: {format(statistics.median(values), '.2g')} ({_outward(low, False)}–{_outward(high, True)})"


def _outward(v: float, up: bool) -> str:
    """v (as its shortest decimal) to two significant digits, rounded away from the inside of a range (up
    for its top)."""
    d = Decimal(repr(v))
    if d == 0:
        return "0"
    q = d.quantize(Decimal(1).scaleb(d.adjusted() - 1), rounding=ROUND_CEILING if up else ROUND_FLOOR)
    return format(float(q), ".2g")


def stable_pair(values: Sequence[Any] | None, others: Sequence[Sequence[Any] | None], spec: str = ".4g") -> str:
    """Two joints' values as 'a / b', each to the digits it shares with every one of ``others`` (``stable``)."""
    if values is None:
        return pair(values, spec)
    return " / ".join(stable(values[j], [None if o is None else o[j] for o in others], spec) for j in (0, 1))
