"""docs/robustness.md: the stored rows behind each generated block (docs/sweeps/<sweep>/points.jsonl)
are the points of the shipped sweep file as it is now, and its table is what the writer makes of them
(tests/docs/test_docgen.py checks the blocks themselves). Re-running the sweeps takes minutes:
`sotc-cosim sweep NAME --doc docs/robustness.md`."""
import json
from pathlib import Path

import pytest

from orchestration.sweep.results import table_csv
from orchestration.sweep.spec import load_sweep

DOCS = Path(__file__).resolve().parents[2] / "docs"


@pytest.mark.parametrize("name", ["robustness", "controllers"])
def test_stored_rows_are_the_points_of_the_shipped_sweep(name):
    sweep = load_sweep(name)
    folder = DOCS / "sweeps" / name
    rows = [json.loads(line) for line in (folder / "points.jsonl").read_text().splitlines()]
    assert [r["settings"] for r in rows] == [p.settings for p in sweep.points()], "the sweep file changed: rerun it"
    assert (folder / "points.csv").read_text() == table_csv(sweep, rows)
    assert all((DOCS / "sweeps" / name / f).is_file() for f in {p.name for p in folder.glob("*.png")})
    assert len(list(folder.glob("*.png"))) == len(sweep.groups())
