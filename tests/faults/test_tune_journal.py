"""Two ``tune`` stores of one stem (``t.json`` and ``t.toml``) shared one Optuna journal (``t.journal``):
the first command died with Optuna's "did not possess lock" (a traceback, exit 1) and never wrote its
store, the journal gained a FAIL trial. Each store now has its own journal, named from its whole name,
and the journal itself is locked while a command tunes into it."""
from __future__ import annotations

from pathlib import Path

import optuna

from orchestration.outputs import PathLock
from orchestration.study import optimize
from support.cli import one_line, run

ARGS = ["tune", "CT", "--budget", "2", "--polish", "0", "--seeds", "0", "--handlings", "accel", "--workers", "1"]


def _trial_states(journal: Path) -> list[str]:
    storage = optimize.storage(journal)
    return [t.state.name for s in storage.get_all_studies()
            for t in optuna.load_study(study_name=s.study_name, storage=storage).trials]


def test_two_stores_of_one_stem_keep_their_own_journals(tmp_path):
    for store in ("t.json", "t.toml"):
        proc = run([*ARGS, "--out", store], tmp_path)
        assert proc.returncode == 0, proc.stderr
        assert "0 already in" in proc.stdout and f"{store}.journal" in proc.stdout, proc.stdout  # not the other's
        assert (tmp_path / store).is_file()
        assert _trial_states(tmp_path / f"{store}.journal") == ["COMPLETE", "COMPLETE"]


def test_a_journal_in_use_is_refused_in_one_line(tmp_path):
    journal = tmp_path / "t.json.journal"
    with PathLock(journal, "test"):
        proc = run([*ARGS, "--out", "t.json"], tmp_path)
    assert proc.returncode == 2, proc.stderr
    assert "journal" in one_line(proc.stderr) and str(journal.name) in proc.stderr
    assert not (tmp_path / "t.json").exists() and not journal.exists()


def test_a_damaged_journal_line_is_named_in_one_line_and_the_tune_resumes(tmp_path):
    """A line of the journal cut in half in its middle (a torn write a later one went past): Optuna's
    JSONDecodeError traceback ended tune, exit 1. Now one line names the journal and the line, the
    journal as it was is kept, and the tune goes on with the trials the damage cannot have touched."""
    assert run([*ARGS, "--out", "t.json"], tmp_path).returncode == 0
    journal = tmp_path / "t.json.journal"
    lines = journal.read_bytes().splitlines(keepends=True)
    middle = len(lines) // 2
    lines[middle] = lines[middle][: len(lines[middle]) // 2] + b"\n"
    journal.write_bytes(b"".join(lines))
    damaged = journal.read_bytes()
    proc = run([*ARGS[:3], "3", *ARGS[4:], "--out", "t.json"], tmp_path)  # --budget 3: one more trial
    assert proc.returncode == 0, proc.stderr
    assert "Traceback" not in proc.stderr
    said = [line for line in proc.stderr.splitlines() if "journal" in line]
    assert len(said) == 1 and f"line {middle + 1} is not an Optuna journal record" in said[0], proc.stderr
    assert "t.json.journal" in said[0]
    assert (tmp_path / "t.json.journal.damaged").read_bytes() == damaged
    assert _trial_states(journal).count("COMPLETE") >= 3
