"""``sotc-cosim tune`` as a user runs it: the installed console script, from a folder outside the
repository, with a tiny budget (the stored search's is in docs/baselines.md)."""
from __future__ import annotations

import json
import re
from pathlib import Path

from orchestration.study.tuning import INITIAL_DESIGN

# one TPE trial beyond the initial design (the sampler's model, and its trials' identity on resume, through the
# installed wheel) and a CMA-ES polish: enough that the Ctrl-C after the second trial lands mid-search however
# fast the cores run (a compiled CT trial takes a third of a second; 20 trials are left when it comes). Each
# trial costs each of the three runs of the command
BUDGET, POLISH = INITIAL_DESIGN + 1, 2
ARGS = ["tune", "CT", "--budget", str(BUDGET), "--polish", str(POLISH), "--seeds", "0", "1", "--handlings", "accel",
        "--workers", "1"]


def _finished(journal: Path) -> int:
    """Trials the journal holds as complete or pruned (Optuna's log line that sets a trial's state)."""
    text = journal.read_text() if journal.is_file() else ""
    return len(re.findall(r'"op_code":6,[^\n]*"state":[12],', text))


def _searches(store: dict) -> dict:
    return store["controllers"]["CtController"]["handlings"]["accel"]["seeds"]


def test_tune_refuses_bad_values_with_one_line(shipped):
    work = shipped.workdir("tune-refused")
    for args in (["tune", "--budget", "0"], ["tune", "PID"], ["tune", "--seeds", "-1"], ["tune", "--handlings", "none"],
                 ["tune", "--polish", "-1"]):
        proc = shipped.cli(*args, cwd=work)
        assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1, (args, proc.stderr)
        assert "Traceback" not in proc.stderr
    assert not any(work.iterdir())


def test_tune_writes_the_store_and_resumes_after_ctrl_c_to_the_same_trials(shipped):
    work = shipped.workdir("tune")
    for folder in ("whole", "cut"):  # a file output's folder must exist (docs/commands.md, outputs)
        (work / folder).mkdir()
    whole = shipped.cli(*ARGS, "--out", "whole/tuned.json", cwd=work)
    assert whole.returncode == 0, whole.stderr
    store = json.loads((work / "whole" / "tuned.json").read_text())
    assert (store["budget"], store["polish"], store["seeds"], store["training_points"], store["complete"]) == (
        BUDGET, POLISH, [0, 1], 8, True)
    for seed, r in _searches(store).items():
        assert len(r["criterion"]) == len(r["state"]) == BUDGET + POLISH and set(r["best_design"]) == {"kp", "kd"}
        assert r["polish_from"] == BUDGET and r["criterion"][r["best"]] == min(v for v in r["criterion"] if v is not None)
        assert f"CtController accel seed {seed}: {BUDGET + POLISH} trials" in whole.stdout

    journal = work / "cut" / "tuned.json.journal"
    cut = shipped.interrupt([*ARGS, "--out", "cut/tuned.json"], work, ready=lambda: _finished(journal) >= 2)
    assert cut.returncode == 130 and "resume with:" in cut.stdout, cut.stdout + cut.stderr
    assert f"--polish {POLISH}" in cut.stdout and "(incomplete)" in cut.stdout
    partial = json.loads((work / "cut" / "tuned.json").read_text())
    assert not partial["complete"]
    resumed = shipped.cli(*ARGS, "--out", "cut/tuned.json", cwd=work)
    assert resumed.returncode == 0, resumed.stderr
    again = json.loads((work / "cut" / "tuned.json").read_text())
    assert again["complete"]
    for seed, r in _searches(store).items():
        other = _searches(again)[seed]
        assert (other["criterion"], other["state"], other["best_design"]) == (r["criterion"], r["state"], r["best_design"])
