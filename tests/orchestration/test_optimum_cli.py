"""``sotc-cosim optimum`` refuses what it cannot run in one line, exit 2, before any cluster starts."""
from __future__ import annotations

import sys

import pytest

from orchestration.cli import main


@pytest.mark.parametrize("args, named", [
    (["--states", "18"], "--states 18"),
    (["--horizon", "0.015"], "horizon 0.015"),
    (["--workers", "2", "--scheduler", "tcp://localhost:1"], "--scheduler: not allowed with argument --workers"),
])
def test_a_request_it_cannot_run_is_one_line_and_exit_2(args, named, capsys):
    pytest.importorskip("casadi", reason="CasADi is missing: pip install '.[optimum]' (the test extra has it)")
    try:
        code = main(["optimum", *args])
    except SystemExit as exc:  # argparse's own refusal (the same in sweep, tune and optimum)
        code = exc.code
    assert code == 2
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and named in lines[0] and captured.out == "", captured


def test_without_casadi_it_names_the_extra(monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "casadi", None)  # import casadi raises ImportError
    assert main(["optimum", "--states", "1"]) == 2
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and 'pip install "sotc-cosim[optimum]"' in lines[0], captured


def test_rescore_refuses_a_missing_or_mismatched_store_in_one_line(tmp_path, capsys):
    """``--rescore`` keeps a stored optimum: without one, or with another horizon, it says so (exit 2)."""
    pytest.importorskip("casadi", reason="CasADi is missing: pip install '.[optimum]' (the test extra has it)")
    stored = tmp_path / "o.json"
    assert main(["optimum", "--rescore", "--json", str(stored)]) == 2
    stored.write_text('{"horizon": 20.0, "objective": "A", "states": []}')
    assert main(["optimum", "--rescore", "--horizon", "10", "--json", str(stored)]) == 2
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert len(lines) == 2 and "--rescore needs --json" in lines[0] and "same --horizon" in lines[1], captured
