"""The order in which pytest-xdist hands the test files to its workers (``--dist loadfile`` with
``--no-loadscope-reorder``): the longest files first, so that the last file a worker takes is a short one
and both workers end together. xdist's own order (the most tests first) put long files with few tests,
such as the shipped tune and the sweep acceptance, at the end, and one worker ran alone for the last
half-minute. The list is a hint measured from CI's ``--durations=0``: a file missing from it runs after
these in collection order, and a wrong order costs time, never a result."""
from __future__ import annotations

# heaviest first; each file runs in one worker (loadfile), so a file's own length is what matters
LONGEST_FIRST = (
    "tests/shipped/test_shipped_cli.py",
    "tests/docs/test_docgen.py",
    "tests/orchestration/test_cpu_independence.py",
    "tests/shipped/test_shipped_fmus.py",
    "tests/orchestration/test_reference_runs.py",
    "tests/faults/test_damaged_cores.py",
    "tests/shipped/test_shipped_fmi3.py",
    "tests/orchestration/test_validate.py",
    "tests/faults/test_build_signals.py",
    "tests/faults/test_planted_and_corrupt.py",
    "tests/shipped/test_shipped_tune.py",
    "tests/orchestration/test_sweep_acceptance.py",
    "tests/faults/test_tune_journal.py",
    "tests/orchestration/test_check_controller.py",
    "tests/orchestration/test_bench.py",
    "tests/unit/test_swap_margin.py",
    "tests/fmu/test_compiled_cores.py",
    "tests/fmu/test_fmu_properties.py",
    "tests/unit/test_elementary.py",
    "tests/faults/test_output_faults.py",
    "tests/faults/test_signals.py",
    "tests/faults/test_validate_faults.py",
    "tests/faults/test_hostile_inputs.py",
    "tests/orchestration/test_recording.py",
    "tests/fmu/test_noexcept.py",
    "tests/shipped/test_shipped_optimum.py",
)


def longest_first(items: list) -> None:
    """Reorder ``items`` (pytest's collected tests) in place: the files of ``LONGEST_FIRST`` in its order,
    then the others as collected; the tests of one file keep their order."""
    rank = {path: i for i, path in enumerate(LONGEST_FIRST)}
    position = {}
    for i, item in enumerate(items):
        position.setdefault(item.nodeid.split("::")[0], i)
    items.sort(key=lambda item: (rank.get(item.nodeid.split("::")[0], len(rank)), position[item.nodeid.split("::")[0]]))
