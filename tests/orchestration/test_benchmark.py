"""sotc-cosim benchmark (docs/benchmark.md, "The benchmark") on the example's controller file
(examples/pd_controller/pd.toml) at a small budget: the report, the plots, the recording and the store; a rerun
resumes to the same store; a search cut short and taken further equals one run at once; a controller that
crashes in some trials fails those trials with their reason and the search goes on; a trial's measure equals
`sotc-cosim run` through the FMUs bit for bit; a controller file the benchmark cannot take is one line, exit 2."""
from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
from support.example_controller import EXAMPLE, PORTS, built_fmu
from support.hostile import build as build_hostile

from orchestration.cli import main
from orchestration.run.master import run
from orchestration.run.scenario import load_scenario
from orchestration.run.summary import summarize
from orchestration.study import optimize, polish, tuning
from orchestration.sweep import benchmark_jobs

SMALL = ["--budget", "4", "--polish", "2", "--seeds", "0", "--points", "2", "--workers", "1"]


def _controller_file(folder: Path, fmu: Path, search: str | None = None, ports=PORTS) -> Path:
    text = (EXAMPLE / "pd.toml").read_text().replace('"PdController.fmu"', json.dumps(str(fmu)))
    if ports is not PORTS:
        text = "\n".join(line for line in text.splitlines() if not line.startswith("ports"))
    if search is not None:
        text = text.split("[search]")[0] + search
    path = folder / "mine.toml"
    path.write_text(text)
    return path


@pytest.fixture(scope="module")
def example(tmp_path_factory) -> Path:
    return built_fmu(tmp_path_factory.mktemp("pd"))


@pytest.fixture(scope="module")
def benchmarked(example, fmu_dir, tmp_path_factory):
    """One small benchmark of the example: (its output folder, the controller file, what it printed)."""
    folder = tmp_path_factory.mktemp("bench")
    file = _controller_file(folder, example)
    out = folder / "out"
    assert main(["benchmark", str(file), *SMALL, "--out", str(out), "--fmu-dir", str(fmu_dir)]) == 0
    return out, file


def test_the_report_plots_recording_and_store_are_written(benchmarked):
    out, file = benchmarked
    names = {"report.md", "criterion.png", "heldout.png", "benchmark.rrd", "scenario.toml", "benchmark.json",
             "benchmark.journal", "heldout.json"}
    assert names <= {p.name for p in out.iterdir()}
    report = (out / "report.md").read_text()
    assert "Not the protocol, not converged by its budget" in report and "not converged (a smaller budget)" in report
    for section in ("## Tuned designs", "## Held-out figures", "## Paired verdicts", "## Against the optimum",
                    "## Samples the bound cut", "## Failures"):
        assert section in report
    assert "these 16 verdicts are corrected as members of one family with the README's 72 (m = 88)" in report
    store = json.loads((out / "benchmark.json").read_text())
    seed = store["seeds_results"]["0"]
    assert seed["search"]["trials"] == 6 and len(seed["search"]["criterion"]) == 6
    for which in ("initial states", "perturbed"):
        assert len(seed["heldout"][which]["mse"]) == 3 * 2  # 3 draws x the first 2 points
        assert all(v is not None and v > 0 for v in seed["heldout"][which]["mse"])
    assert len(seed["optimum"]["ratios"]) == 17 and all(r > 1 for r in seed["optimum"]["ratios"])
    assert load_scenario(str(out / "scenario.toml")).instances["controller"].parameters["Kp"] == \
        seed["search"]["best_design"]["Kp"]
    assert (out / "benchmark.rrd").read_bytes()[:4] == b"RRF2"


def test_a_rerun_resumes_to_the_same_store(benchmarked, example):
    out, file = benchmarked
    before = (out / "benchmark.json").read_text()
    problem = _problem(file)
    settings = {"file": str(file), "budget": 4, "polish": 2, "seeds": [0], "points": 2}
    outcome = benchmark_jobs.run(out, problem, settings, 1, None)
    assert outcome.tuning.trials_before == 6 and not outcome.interrupted
    assert (out / "benchmark.json").read_text() == before


def test_a_folder_that_holds_another_controllers_benchmark_is_refused(benchmarked, fmu_dir, capsys):
    """A complete search is never reopened: a changed controller file (here its fixed bound) would otherwise be
    reported with the numbers of the file benchmarked before into the same folder."""
    out, file = benchmarked
    changed = file.with_name("changed")
    changed.mkdir(exist_ok=True)
    other = changed / file.name
    other.write_text(file.read_text().replace("umax = 4.0", "umax = 2.0"))
    before = {p.name: p.stat().st_mtime_ns for p in out.iterdir()}
    assert main(["benchmark", str(other), *SMALL, "--out", str(out), "--fmu-dir", str(fmu_dir)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "holds the benchmark of another controller file" in err[0]
    assert {p.name: p.stat().st_mtime_ns for p in out.iterdir()} == before


def test_no_verdict_is_stated_where_the_controller_failed_a_run(benchmarked):
    """A failed run of A drops out of its pairs: its verdict would judge A on the points where it ran only."""
    from orchestration.reports import benchmark_report

    out, _ = benchmarked
    store = json.loads((out / "benchmark.json").read_text())
    store["seeds_results"]["0"]["heldout"]["perturbed"]["mse"][0] = None  # draw 7's first point failed
    verdicts, _ = benchmark_report._verdicts(store, benchmark_report.reference())
    for (which, _, name), per in verdicts.items():
        for (draw, _), v in per.items():
            failed = which == "perturbed" and name == "mse" and draw == store["draws"][0]
            assert v.verdict.startswith(benchmark_report.FAILED_ON) == failed
    assert "failed 1 held-out run" in benchmark_report.headline(store, benchmark_report.reference())


def _problem(file: Path):
    from orchestration.cli.benchmark_commands import _problem as problem_of

    return problem_of(file)


def test_a_search_cut_short_and_taken_further_equals_one_run_at_once(benchmarked, tmp_path):
    out, file = benchmarked
    problem = _problem(file)
    assert polish.search(tmp_path / "j.journal", problem, 0, 2, 0) == 2  # in process: the Dask path is the fixture's
    assert polish.search(tmp_path / "j.journal", problem, 0, 4, 2) == 4
    again = polish.record(optimize.storage(tmp_path / "j.journal"), problem, 0, 4, 2)
    stored = json.loads((out / "benchmark.json").read_text())["seeds_results"]["0"]["search"]
    assert again["criterion"] == stored["criterion"] and again["best_design"] == stored["best_design"]


def test_trials_of_a_controller_that_crashes_fail_with_their_reason_and_the_search_goes_on(tmp_path, monkeypatch):
    fmu = build_hostile("segv", tmp_path, monkeypatch, kp_above=100.0)
    file = _controller_file(tmp_path, fmu, ports=None)  # the hostile FMUs carry the contract's own names
    problem = _problem(file)
    assert polish.search(tmp_path / "j.journal", problem, 0, tuning.INITIAL_DESIGN, 0) == tuning.INITIAL_DESIGN
    record = polish.record(optimize.storage(tmp_path / "j.journal"), problem, 0, tuning.INITIAL_DESIGN, 0)
    crashed = {int(i) for i in record.get("failures", {})}
    states = record["state"]
    assert len(states) == tuning.INITIAL_DESIGN  # every trial ran: a crash failed its trial only
    assert crashed and crashed == {i for i, s in enumerate(states) if s == "failed"}
    assert all("SIGSEGV in fmi2DoStep" in record["failures"][str(i)] for i in crashed)
    assert any(s == "complete" for s in states) and record["best_design"]["Kp"] <= 100.0


def test_a_trial_measures_what_sotc_cosim_run_gives_bit_for_bit(benchmarked, example, fmu_paths, tmp_path):
    """The first training point (the initial-states kind) of the nominal design, against the master's run of
    `paper` from that state, 20 s, with the controller file as its controller."""
    out, file = benchmarked
    problem = _problem(file)
    point = tuning.training_points()[0]
    measured = problem.measure(problem.nominal(), point, tuning.STOP_TIME)
    (tmp_path / "scn.toml").write_text(
        f'extends = "paper"\nname = "mine"\nstop_time = {tuning.STOP_TIME}\n[instances.controller]\n'
        f'controller = {json.dumps(str(file))}\nparameters = {{ Kp = {problem.nominal()["Kp"]!r}, '
        f'Kd = {problem.nominal()["Kd"]!r} }}\n')
    scenario = load_scenario(str(tmp_path / "scn.toml")).with_parameters(
        {"plant.phi1_0": point["phi0"][0], "plant.phi2_0": point["phi0"][1]})
    result = run(scenario, fmu_paths)
    assert not result.failed, result.error
    summary = summarize(result)
    assert measured["mse"] == summary["mse"][0] + summary["mse"][1]
    assert measured["cuts"] == summary["torque_cuts"]


@pytest.mark.parametrize("search, said", [
    ("", "search: no parameter to tune"),
    ('[search]\nKp = { low = 10.0, high = 1.0 }\n', "search.Kp: low = 10, high = 1: an empty or reversed range"),
    ('[search]\nu1 = { low = 1.0, high = 2.0 }\n', "search.u1: a port (ports.tau1 = 'u1')"),
    ('[search]\nKp = { low = 1.0, high = inf }\n', "search.Kp.high: inf is not finite"),
    ('[search]\numax = { low = 1.0, high = 8.0 }\n', "search.umax: also fixed in parameters"),
])
def test_a_controller_file_the_benchmark_cannot_take_is_one_line_and_exit_2(example, tmp_path, capsys, search, said):
    file = _controller_file(tmp_path, example, search=search)
    assert main(["benchmark", str(file), *SMALL, "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and said in err[0] and str(file) in err[0]
    assert not (tmp_path / "out").exists()


def test_an_fmu_a_missing_file_or_a_seed_of_ours_not_stored_is_one_line_and_exit_2(example, tmp_path, capsys):
    file = _controller_file(tmp_path, example)
    for args, said in (([str(example)], "a controller file (.toml"), ([str(tmp_path / "none.toml")], "no such file"),
                       ([str(file), "--seeds", "7"], "--seeds: each seed's design is judged against ours")):
        assert main(["benchmark", *args, "--out", str(tmp_path / "out")]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and said in err[0]
