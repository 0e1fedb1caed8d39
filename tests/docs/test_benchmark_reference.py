"""The benchmark's reference shipped with the package (orchestration/study/benchmark_reference.json) is what
``python -m orchestration.reports.benchmark_reference`` writes from the stored fair comparison and optimum."""
from support import REPO

from orchestration.reports.benchmark_reference import text
from orchestration.study.benchmark_reference import REFERENCE_FILE


def test_the_shipped_reference_is_the_stores():
    assert REFERENCE_FILE.read_text() == text(REPO), "rerun: python -m orchestration.reports.benchmark_reference"
