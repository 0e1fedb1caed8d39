"""What a newcomer reads in a terminal: ``--help`` without reStructuredText markup, ``scenarios`` in two
columns, ``validate`` without a line that means nothing to a user (``reproduce``'s width: test_reproduce)."""
from __future__ import annotations

from pathlib import Path

import pytest

from orchestration.cli import build_parser, main
from orchestration.compliance.validate import FmuReport, ValidationReport, format_report


def _help(argv: list[str], capsys) -> str:
    with pytest.raises(SystemExit):
        main(argv)
    return capsys.readouterr().out


def test_help_has_no_restructuredtext_markup(capsys):
    commands = build_parser()._subparsers._group_actions[0].choices
    for argv in [["--help"]] + [[c, "--help"] for c in commands]:
        text = _help(argv, capsys)
        assert "``" not in text, (argv, text)
    assert _help(["--help"], capsys).splitlines()[4].startswith("sotc-cosim: build the FMUs")


def test_scenarios_are_two_columns_at_any_name_length(capsys, monkeypatch):
    monkeypatch.setenv("COLUMNS", "100")
    assert main(["scenarios"]) == 0
    lines = capsys.readouterr().out.splitlines()
    names = [line.split()[0] for line in lines if not line.startswith(" ")]
    column = max(map(len, names)) + 2
    assert "paper-near-literal" in names and max(map(len, lines)) <= 100
    for line in lines:  # a name, or the wrapped description's next line, then the description at one column
        assert line[column - 2:column] == "  " and line[column] != " ", line


def test_validate_says_nothing_of_the_set_when_it_passes_and_what_fails_when_not():
    report = ValidationReport([FmuReport(Path("A.fmu"))], [])
    assert "set" not in format_report(report).lower().replace("passes", "")
    failed = format_report(ValidationReport([FmuReport(Path("A.fmu"))], ["script module 'x' of B bundles other code"]))
    assert "FMUs together: FAIL" in failed and "  together: script module 'x'" in failed, failed
