"""docs/robustness.md: every generated block is what the table writer makes of the stored rows of
that run (docs/sweeps/<sweep>/points.jsonl), and those rows are the points of the shipped sweep file
as it is now. (Re-running the sweeps takes minutes: `sotc-cosim sweep NAME --doc docs/robustness.md`.)"""
import json
from pathlib import Path

import pytest

from orchestration.sweep_file import load_sweep
from orchestration.sweep_results import begin_marker, doc_block, end_marker, plot_name, table_csv

DOCS = Path(__file__).resolve().parent.parent / "docs"


@pytest.mark.parametrize("name", ["robustness", "controllers"])
def test_generated_block_matches_the_stored_run(name):
    sweep = load_sweep(name)
    folder = DOCS / "sweeps" / name
    rows = [json.loads(line) for line in (folder / "points.jsonl").read_text().splitlines()]
    assert [r["settings"] for r in rows] == [p.settings for p in sweep.points()], "the sweep file changed: rerun it"
    assert (folder / "points.csv").read_text() == table_csv(sweep, rows)
    plots = [f"sweeps/{name}/{plot_name(group)}" for group in sweep.groups()]
    assert all((DOCS / p).is_file() for p in plots)
    text = (DOCS / "robustness.md").read_text()
    committed = begin_marker(name) + text.split(begin_marker(name), 1)[1].split(end_marker(name), 1)[0] + end_marker(name)
    assert committed == doc_block(sweep, rows, len(sweep.points()), plots)
