"""What the benchmark judges a foreign controller against, shipped with the package so that an installed
``sotc-cosim benchmark`` needs no source checkout: the stored fair comparison's held-out runs of our tuned
controllers under the README's verdict handling (docs/fair/evaluation.json), the size of the README's family
of verdicts, and the stored optimum's states with our tuned controllers' J / J* (docs/optimum/optimum.json).
``python -m orchestration.reports.benchmark_report --reference`` writes it from those stores, and
tests/docs/test_benchmark_reference.py fails when it differs from them."""
from __future__ import annotations

import functools
import json
from pathlib import Path
from typing import Any

REFERENCE_FILE = Path(__file__).with_name("benchmark_reference.json")


@functools.lru_cache(maxsize=1)
def load() -> dict[str, Any]:
    return json.loads(REFERENCE_FILE.read_text())
