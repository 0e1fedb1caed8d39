"""``sotc-cosim optimum`` as a user runs it: the installed console script, from a folder outside the
repository, on a local Dask cluster; and, without CasADi, one line naming the extra."""
from __future__ import annotations

import json

import pytest


def test_optimum_solves_the_papers_state_and_no_controller_beats_it(shipped):
    pytest.importorskip("casadi", reason="CasADi is missing: pip install '.[optimum]' (the test extra has it)")
    work = shipped.workdir("optimum")
    # 5 s of the paper's 20 (docs/optimum.md): the same transcription, solves and rescoring, a quarter of the time
    proc = shipped.cli("optimum", "--states", "1", "--horizon", "5", "--json", "o.json", "--workers", "1", cwd=work)
    assert proc.returncode == 0, f"{proc.stdout}\n{proc.stderr}"
    assert "Traceback" not in proc.stderr, proc.stderr
    data = json.loads((work / "o.json").read_text())
    [state] = data["states"]
    assert state["index"] == 0 and state["phi0"] == [0.5, -0.5] and len(state["torques"]) == 500
    assert f"J* at the paper's initial state: {state['J_star']:.6g}" in proc.stdout
    assert len(data["summary"]) == len(state["J"]) >= 14  # every fair configuration (per tuning seed) and the frozen W
    for label, s in data["summary"].items():
        assert s["paper"] >= 1.0, label
        assert f"| {label} | {s['paper']:.3f} |" in proc.stdout  # printed for every controller
    assert state["cold"]["relative_difference"] <= 1e-6


def test_optimum_without_casadi_names_the_extra(shipped):
    code = ("import sys; sys.modules['casadi'] = None\n"
            "from orchestration.cli import main\nraise SystemExit(main(['optimum', '--states', '1']))")
    proc = shipped.python_code(code, cwd=shipped.workdir("no-casadi"))
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "sotc-cosim[optimum]" in lines[0] and "Traceback" not in proc.stderr, proc.stderr
    assert proc.stdout == ""
