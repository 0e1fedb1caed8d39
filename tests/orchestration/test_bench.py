"""`sotc-cosim bench`: what it measures and writes (never how fast: no timed assertions), and the
generated tables in the docs (``speed`` blocks) are checked with every docgen block (test_docgen)."""
from __future__ import annotations

import contextlib
import io
import json
import math
import time

import pytest
from support import REPO

from orchestration.bench import foreign
from orchestration.bench.speed import MEASUREMENT, SET_UP, child_run, compare, format_markdown
from orchestration.bench.targets import check_targets, foreign_targets
from orchestration.cli import main


@pytest.fixture(scope="module")
def short_bench_run(fmu_dir, tmp_path_factory) -> tuple[dict, str]:
    """The short bench's JSON and what it said on stderr."""
    out = tmp_path_factory.mktemp("bench") / "b.json"
    with contextlib.redirect_stderr(io.StringIO()) as said:
        assert main(["bench", "--repeats", "2", "--long", "none", "--stop-time", "2", "--fmu-dir", str(fmu_dir),
                     "--json", str(out)]) == 0
    return json.loads(out.read_text())["speed"], said.getvalue()


@pytest.fixture(scope="module")
def short_bench(short_bench_run) -> dict:
    return short_bench_run[0]


def test_each_long_step_of_the_bench_says_it_starts_on_stderr(short_bench_run):
    """Its defaults run for minutes: a line as each step starts, the report alone on stdout."""
    steps = [line for line in short_bench_run[1].splitlines() if line.startswith("bench speed: ")]
    assert steps == ["bench speed: 2 s of paper side by side, 2 runs each ...",
                     "bench speed: the cost split per step, instrumented runs ...",
                     "bench speed: the plumbing's floor, then whole processes ..."], short_bench_run[1]


def test_bench_reports_floor_cosim_and_recording_side_by_side_with_its_method(short_bench):
    d = short_bench
    assert d["method"]["repeats"] == 2 and d["method"]["steps"] == 200
    assert d["machine"]["cores"] >= 1 and d["machine"]["cpu"]
    for name in ("floor", "cosim", "cosim_recorded"):
        r = d["runs"][name]
        assert len(r["runs"]) == 2 and 0 < r["min"] <= r["median"] <= r["max"]
    assert d["ratios"]["recorded_over_floor"] == pytest.approx(
        d["runs"]["cosim_recorded"]["median"] / d["runs"]["floor"]["median"])
    assert d["rrd_mb"] > 0


def test_the_cost_split_adds_up_to_the_instrumented_run(short_bench):
    split = short_bench["split"]
    parts = split["us_per_step"]
    cores = {f"{c} (core, inside the FMU)" for c in ("plant step", "controller evaluate", "controller learn", "reference")}
    assert cores | {"FMI get/set/doStep plumbing", "master's own work", SET_UP, "recording"} == set(parts)
    assert all(parts[c] > 0 for c in cores) and parts["FMI get/set/doStep plumbing"] > 0 and parts[SET_UP] > 0
    # each run's rows and what was taken out of them make up its instrumented wall time (the short bench
    # has 2 repeats: their medians are means, which keep sums)
    removed = split["removed_us_per_step"]
    assert set(removed) <= set(parts) and all(v > 0 for v in removed.values())
    assert math.isclose(sum(parts.values()) + sum(removed.values()), split["instrumented_us_per_step"], rel_tol=1e-9)
    assert split["wrapper_us_per_call"]["caller"] > 0 and 0 < sum(removed.values()) < split["instrumented_us_per_step"]
    recording = split["recording_parts_us_per_step"]  # start, blocks and finish make up the recording's row
    assert set(recording) == {"start", "block", "finish"} and all(v > 0 for v in recording.values())
    assert set(split["fmi_calls_us_per_step"]) == {"get", "set", "doStep"}
    assert {f"{c} (core, inside the FMU)" for c in split["floor_us_per_step"]} == cores  # the same cores in the floor


def test_the_targets_judge_start_up_and_each_part_outside_the_cores(short_bench):
    targets = short_bench["targets"]
    for part in ("FMI plumbing <= 30 us", "master <= 5 us", "recording <= 3 us", "start-up <= 0.5 s",
                 "cores <= 250 us"):
        assert [k for k in targets if k.startswith(part)], part
    process = short_bench["process"]
    assert 0 < process["startup"]["min"] <= process["startup"]["median"] <= process["startup"]["max"]
    assert "trial" not in short_bench  # a shortened bench runs no tuning trial
    floor = short_bench["plumbing_floor"]  # empty FMUs with our variables, in the same master
    assert set(floor["fmi_calls_us_per_step"]) == {"get", "set", "doStep"}
    assert math.isclose(sum(floor["fmi_calls_us_per_step"].values()), floor["us_per_step"], rel_tol=1e-9)


def test_compare_prints_each_figure_old_and_new(short_bench, fmu_dir, tmp_path, capsys):
    old = dict(short_bench, runs={k: dict(v, median=2 * v["median"]) for k, v in short_bench["runs"].items()})
    text = compare(old, short_bench)
    assert "floor median s" in text and "-50%" in text
    (tmp_path / "old.json").write_text(json.dumps({"speed": old}))
    capsys.readouterr()
    assert main(["bench", "integrator", "--compare", str(tmp_path / "old.json"), "--fmu-dir", str(fmu_dir)]) == 0
    assert main(["bench", "--compare", str(tmp_path / "missing.json"), "--fmu-dir", str(fmu_dir)]) == 2


def test_bench_refuses_bad_arguments_with_one_line(fmu_dir, capsys):
    assert main(["bench", "nosuch", "--fmu-dir", str(fmu_dir)]) == 2
    assert "known: speed" in capsys.readouterr().err
    with pytest.raises(SystemExit) as exc:
        main(["bench", "--long", "10,-1"])
    assert exc.value.code == 2


def test_a_long_run_is_measured_in_a_child_process(fmu_dir, tmp_path):
    """The child's wall time is the run's, measured inside the child: within the time the call took here."""
    started = time.perf_counter()
    r = child_run(2.0, fmu_dir, tmp_path / "x.rrd", record_every=5)
    around = time.perf_counter() - started  # the child's interval lies inside this one (one monotonic clock)
    assert r["stop_time"] == 2.0 and r["record_every"] == 5
    assert r["peak_rss_mb"] > 10 and r["rrd_mb"] > 0 and 0.0 < r["wall_s"] < around
    assert r["wall_per_sim_s_ms"] == 1e3 * r["wall_s"] / 2.0
    assert not (tmp_path / "x.rrd").exists()  # the recording is measured, then removed


def test_the_c_controller_row_runs_alone_with_its_fields_and_targets(tmp_path, monkeypatch, capsys):
    """``bench foreign``: one trial of the benchmark's loop with examples/pd_controller, in-process and hosted,
    its runs shortened (--stop-time) and its cores as the interpreter imports them (SOTC_COSIM_COMPILE=0), so no
    compile; what it prints and stores, not how fast (the 10 us target is judged on compiled cores only)."""
    from support.example_controller import skip_without_compiler

    skip_without_compiler()
    monkeypatch.setenv("SOTC_COSIM_COMPILE", "0")
    out = tmp_path / "f.json"
    assert main(["bench", "foreign", "--repeats", "1", "--stop-time", "0.5", "--json", str(out)]) == 0
    row = json.loads(out.read_text())["foreign"]
    # the child's cores as it imported them: an installed wheel's are compiled already (CI), no compile either way
    assert row["benchmark"] == "foreign" and row["cores"] in ("Python", "compiled") and row["repeats"] == 1
    assert row["points"] == 8 and row["stop_time"] == 0.5 and row["steps_per_run"] == 50
    for figure in ("trial", "hosted", "do_step"):
        f = row["us_per_step"][figure]
        assert 0 < f["min"] <= f["median"] <= f["max"], figure
    assert row["beyond_us_per_step"] == row["us_per_step"]["trial"]["median"] - row["us_per_step"]["do_step"]["median"]
    assert row["hosted_over_in_process"] > 0 and row["reinstantiated"] == 0 == row["host_restarts"]
    assert "cpu" in row  # both processes kept to one CPU where the platform can (Linux), else None
    assert row["trials_per_load"] == 2  # the warm trial and one repeat, on one load of the FMU
    printed = capsys.readouterr().out
    assert foreign.line(row) in printed and "| the C controller FMU loaded once, reset between runs | yes |" in printed
    if row["cores"] == "Python":
        assert "10 us" not in printed.split(foreign.line(row))[1]  # not judged: the cores were not compiled
    # the row in the speed bench's report and targets, in the stored measurement as --update-docs stores it
    data = dict(json.loads((REPO / MEASUREMENT).read_text()), foreign=row)
    assert foreign.line(row) in format_markdown(dict(data, targets=check_targets(data)))
    assert "the same trial through ForeignHost (a child process) <= 1.2x in-process" in check_targets(data)


def test_without_the_example_the_row_says_why_in_one_line(monkeypatch, tmp_path, capsys):
    import orchestration.fmu_build.build

    monkeypatch.setattr(foreign, "example_build", lambda: None)
    # where docs/ lives for --update-docs: the checkout, also where the suite imports an installed package (CI)
    monkeypatch.setattr(orchestration.fmu_build.build, "PACKAGE_ROOT", REPO)
    row = foreign.foreign_row(1)
    assert set(row) == {"date", "load_average_at_start", "skipped"} and "source checkout" in row["skipped"]
    assert "\n" not in foreign.line(row) and "not measured" in foreign.line(row)
    assert foreign_targets(row) == {} and foreign.figures(row) == {}
    # --update-docs does not replace a measured row by none
    assert main(["bench", "foreign", "--update-docs"]) == 2
    assert "the row foreign was not measured" in capsys.readouterr().err
