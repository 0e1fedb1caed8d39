"""`sotc-cosim reproduce`: Table 1 extended, every number from this invocation's runs."""
import csv
from pathlib import Path

import numpy as np
import pytest
from rerun.chunk import RrdReader

import orchestration.run.summary as summary_module
from orchestration.cli import main
from orchestration.study.comparison import run_metrics
from orchestration.study.reproduce import (
    COLUMNS,
    PAPER_TABLE1,
    REPRODUCE_RUNS,
    compact_table,
    table_rows,
    chaos_notes,
    learning_pairs,
    REPRODUCE_SCENARIOS,
)


def _read(path):
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    return rows[0], rows[1:]


def test_reproduce_writes_the_table_from_its_own_runs(fmu_dir, tmp_path, monkeypatch, capsys):
    captured = []
    real = summary_module.summarize

    def spy(result):
        s = real(result)
        captured.append(s)
        return s

    monkeypatch.setattr(summary_module, "summarize", spy)
    monkeypatch.chdir(tmp_path)
    rrd = tmp_path / "out" / "reproduce.rrd"
    rrd.parent.mkdir()  # a file output outside recordings/ must be in an existing folder (issue 47)
    # a controller of one's own beside ours: here our CT given as an FMU file, so the actuator stands before it
    (tmp_path / "mine.toml").write_text(f'extends = "paper-ct"\nname = "mine"\n[instances.controller]\n'
                                        f'fmu = "{fmu_dir / "CtController.fmu"}"\n')
    code = main(["reproduce", "--stop-time", "3", "--fmu-dir", str(fmu_dir), "--out", str(tmp_path / "out"),
                 "--recording", str(rrd), "--with", "mine.toml"])
    printed = capsys.readouterr().out
    assert code == 0
    header, rows = _read(tmp_path / "out" / "table1.csv")
    md = (tmp_path / "out" / "table1.md").read_text()
    first, value = md.split("## The learned value function")
    assert first.count("\n| ") == len(rows) + 2 and value.count("\n| ") == 2 * (2 + 4)  # two tables: header, rule, 4 W
    assert header[:4] == ["source", "scenario", "controller", "status"] and len(header) == 4 + len(COLUMNS)
    paper_rows = [r for r in rows if r[0] == "paper Table 1"]
    ours = [r for r in rows if r[0] == "this run"]
    assert [(r[2], float(r[5]), float(r[6])) for r in paper_rows] == [(k, *v) for k, v in PAPER_TABLE1.items()]
    assert [r[1] for r in ours] == [*REPRODUCE_SCENARIOS, "mine"]
    assert [s["scenario"] for s in captured] == [*REPRODUCE_SCENARIOS, "mine"]
    assert [r[header.index("samples cut")] for r in ours] == ["0"] * len(ours)  # the CT bounds itself
    # the same torques and metrics; the limit handling of a file's controller is not ours to name
    assert ours[-1][2] == "CtController.fmu" and ours[-1][4] == ""
    assert ours[-1][5:] == ours[REPRODUCE_SCENARIOS.index("paper-ct")][5:]
    for row, s in zip(ours, captured):
        assert s["stop_time"] == 3.0 and s["samples"] == 301
        assert row[4:] == [get(s, True) for _, _, get in COLUMNS]  # table1.csv: full precision
        assert row[4] == (s["limit_handling"] or "") and float(row[5]) == s["mse"][0]
        assert s["mse_after_5s"] is None and row[header.index("MSE1 t>=5s [rad^2]")] == ""  # a 3 s run
        after = s["mse_after_limit"]
        assert row[header.index("MSE2 after last limit [rad^2]")] == ("" if after is None else repr(after[1]))
        assert float(row[header.index("realised cost int z'z")]) == s["tracking_cost"]
        assert int(row[header.index("samples over limit")]) == s["samples_over_limit"]
    # every controller under every limit handling, the OTC clipped and unclipped
    cells = {(s["controller"], s["limit_handling"]) for s in captured}
    for fmu in ("SotcController", "CtController", "LqrController"):
        assert {(fmu, h) for h in ("radial", "joint", "accel")} <= cells
    assert {("OtcController", h) for h in ("none", "radial", "joint", "accel")} <= cells
    assert {s["scenario"] for s in captured} >= {"paper-literal", "paper-near-literal"}
    unclipped = next(s for s in captured if s["scenario"] == "paper-otc")
    assert unclipped["samples_over_limit"] > 0 and all(
        s["samples_over_limit"] == 0 for s in captured if s["limit_handling"] != "none")
    assert "paper-otc-accel" in printed and "wrote" in printed
    # what fits a terminal, and says the run's stop time beside the paper's 100 s; every column in table1.md
    shown = printed.replace(str(tmp_path), "TMP").splitlines()  # the folder's name is the user's
    assert max(map(len, shown)) <= 120, max(shown, key=len)
    assert "stop time 3 s" in printed and not any(line.startswith("|") for line in printed.splitlines())
    # every controller tuned by the one protocol, under accel and radial (the README's tuned rows)
    assert {f"{sc}-tuned-{h}" for sc in ("paper", "paper-ct", "paper-lqr", "paper-otc") for h in ("accel", "radial")} <= {
        line.split()[0] for line in printed.splitlines() if line.split()}
    # the docs' tables come from the pure loop: it gives these FMU runs' numbers
    by_name = {s["scenario"]: s for s in captured}
    for run in REPRODUCE_RUNS:
        pure = run_metrics(run.scenario, 3.0, **run.overrides())
        name, fmu = run.name, by_name[run.name]
        assert np.allclose(pure["mse"], fmu["mse"], rtol=1e-9, atol=0.0), name
        assert pure["tracking_cost"] == pytest.approx(fmu["tracking_cost"], rel=1e-9), name
        assert (pure["samples_over_limit"], pure["last_limit_time"]) == (fmu["samples_over_limit"], fmu["last_limit_time"])
    # the SOTC with and without learning, paired at its nominal and its tuned designs
    assert "What the critic's learning adds" in printed
    for on, off in learning_pairs():
        assert by_name[off.name]["controller"] == "SotcController" and off.scenario == on.scenario
        assert f"{on.name}: MSE_1 + MSE_2" in printed and f"{on.name}: MSE_1 + MSE_2" in md
    assert {on.name for on, _ in learning_pairs()} == {"paper", "paper-tuned-accel", "paper-tuned-radial"}
    # the comparison recording overlays every run of this invocation (paper Figs 10-12)
    entities = {c.entity_path for c in RrdReader(rrd).stream().to_chunks()}
    for name in [*REPRODUCE_SCENARIOS, "mine"]:
        assert f"/{name}/fmu/plant" in entities, sorted(entities)[:20]


def test_a_scenario_with_a_name_reproduce_runs_is_refused(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["reproduce", "--with", "paper-ct", "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("sotc-cosim: error: --with paper-ct: its name 'paper-ct' is already a run of this reproduce")
    assert len(err.splitlines()) == 1 and list(tmp_path.iterdir()) == []


def test_a_chaotic_reading_is_reported_as_not_tracking_with_its_sensitivity(monkeypatch):
    """A chaotic reading is said as such (the results blocks and reproduce share comparison.chaos_of): its
    runs under the perturbations of the initial state are stood in for by constructed metrics, `paper-literal`'s
    moving by up to 60 %, `paper-accel`'s by 1e-6."""
    from orchestration.study import comparison

    def runs(scenario, *a, **k):
        base, moves = ((1.7, 6.6), (0.6, 0.3, -0.1)) if scenario == "paper-literal" else ((0.003, 0.008), (1e-6,))
        return {"mse": list(base)}, [{"mse": [m * (1 + c) for m in base]} for c in moves]

    monkeypatch.setattr(comparison, "run_perturbed", runs)
    notes = chaos_notes([{"scenario": "paper-literal", "stop_time": 100.0}, {"scenario": "paper-accel", "stop_time": 100.0}])
    assert list(notes) == ["paper-literal"]
    assert notes["paper-literal"] == ("does not track (MSE_1 + MSE_2 chaotic: 9.5 (7.4–14); moves up to 60 % under 3 "
                                      "perturbations of the initial state)")
    table = compact_table([{"scenario": "paper-literal", "controller": "SotcController", "limit_handling": "radial",
                            "stop_time": 100.0, "mse": [1.7, 6.6], "tracking_cost": 1885.0, "max_norm_tau": 4.0, "samples_over_limit": 0}], notes)
    assert "stop time 100 s" in table.splitlines()[0] and max(map(len, table.splitlines())) <= 120, table
    assert "1.7" not in table.splitlines()[4] and "chaotic: see below" in table and notes["paper-literal"] in " ".join(table.split())
    summary = {"scenario": "paper-literal", "controller": "SotcController", "status": "ok", "mse": [1.7, 6.6]}
    _, rows = table_rows([summary], chaotic=frozenset(notes))
    assert rows[-1][4 + 1:4 + 7] == ["chaotic (see below)"] * 6 and "1.7" not in rows[-1]
    _, full = table_rows([summary], full=True)  # table1.csv keeps the measured numbers
    assert full[-1][5] == repr(1.7)


def test_the_commands_page_counts_the_runs_reproduce_makes():
    commands = (Path(__file__).resolve().parents[2] / "docs" / "commands.md").read_text()
    assert f"{len(REPRODUCE_RUNS)} runs;" in " ".join(commands.split())
