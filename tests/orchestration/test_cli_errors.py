"""Malformed invocations and scenario files: one line on stderr naming the file, key or
argument and what is allowed, exit code 2, no traceback, nothing written. Plus hypothesis over
scenario files (any TOML shape) and option values."""
from __future__ import annotations

import json
import math
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from orchestration.cli import main
from orchestration.run.scenario import MAX_STEPS, Scenario, ScenarioError, load_scenario

PAPER_HEAD = 'extends = "paper"\n'
SCENARIO_CASES = {  # file text -> what the message must name
    "parameters-not-a-table": (PAPER_HEAD + "[instances.plant]\nparameters = 5\n", "instances.plant.parameters"),
    "instances-an-integer": ("instances = 5\n", "instances"),
    "connect-a-string": (PAPER_HEAD + 'connect = "plant"\n', "connect"),
    "port-an-integer": (PAPER_HEAD + '[[connection]]\nfrom = 3\nto = "controller.phi1"\n', "connection[0].from"),
    "time-true": (PAPER_HEAD + "stop_time = true\n", "stop_time"),
    "no-instances": ('name = "empty"\n', "no instances"),
    "step-not-whole-ns": (PAPER_HEAD + "step_size = 0.0100000001\nstop_time = 1.0000000001\n", "nanoseconds"),
    "step-1e-12": (PAPER_HEAD + "step_size = 1e-12\nstop_time = 1e-10\n", "step_size"),
    "stop-1e12": (PAPER_HEAD + "stop_time = 1e12\n", "at most"),
    "parameter-a-string": (PAPER_HEAD + '[instances.plant.parameters]\np1 = "x"\n', "instances.plant.parameters.p1"),
    "unknown-key": (PAPER_HEAD + "stoptime = 3\n", "stoptime"),
}


def _one_line_error(err: str) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert "Traceback" not in err and lines[0].startswith("sotc-cosim"), err
    return lines[0]


@pytest.mark.parametrize("case", list(SCENARIO_CASES))
def test_malformed_scenario_file_is_refused_in_one_line(case, tmp_path, monkeypatch, capsys):
    text, named = SCENARIO_CASES[case]
    monkeypatch.chdir(tmp_path)
    path = tmp_path / f"{case}.toml"
    path.write_text(text)
    for argv in (["run", str(path)], ["export-ssp", str(path), "--out", str(tmp_path / "x.ssp")]):
        assert main(argv) == 2
        line = _one_line_error(capsys.readouterr().err)
        assert named in line and path.name in line, line
    assert sorted(p.name for p in tmp_path.iterdir()) == [path.name], "something was written"


@pytest.fixture
def not_a_folder(tmp_path) -> Path:
    f = tmp_path / "plain-file"
    f.write_text("")
    return f


def _bad_paths(tmp_path: Path, plain: Path) -> list[Path]:
    return [plain / "under-a-file.out", tmp_path, Path("/proc/sotc-cosim-test.out")]


@pytest.mark.parametrize("command", [
    ["run", "paper", "--summary", "{}", "--no-recording"],
    ["run", "paper", "--recording", "{}"],
    ["export-ssp", "paper", "--out", "{}"],
    ["compare", "paper", "--recording", "{}"],
])
def test_unwritable_output_path_is_refused_before_anything_runs(command, tmp_path, not_a_folder, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    before = sorted(tmp_path.iterdir())
    for bad in _bad_paths(tmp_path, not_a_folder):
        argv = [str(bad) if a == "{}" else a for a in command] + ["--fmu-dir", str(tmp_path / "fmus")]
        assert main(argv) == 2, argv
        line = _one_line_error(capsys.readouterr().err)
        assert str(bad) in line, line
    assert sorted(tmp_path.iterdir()) == before, "something was written"


@pytest.mark.parametrize("argv, named", [
    (["sweep", "paper", "--set", "controller.rho=3", "--workers", "-3"], "--workers"),
    (["run", "--stop-time", "nan"], "--stop-time"),
    (["run", "--stop-time", "-1"], "--stop-time"),
    (["run", "--stop-time", "1e12", "--no-recording"], "at most"),
    (["run", "--stop-time", "0.005", "--no-recording"], "shorter than one step"),
    (["run", "--stop-time", "0.015", "--no-recording"], "whole number of steps"),
])
def test_bad_option_values_are_refused_in_one_line(argv, named, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    try:
        code = main(argv)
    except SystemExit as exc:  # argparse's own refusal
        code = exc.code
    assert code == 2
    assert named in _one_line_error(capsys.readouterr().err)
    assert not any(tmp_path.iterdir())


def test_validate_refuses_a_non_zip_and_an_archive_that_escapes_its_folder(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    text = tmp_path / "text.fmu"
    text.write_text("not a zip")
    evil = tmp_path / "evil.fmu"
    with zipfile.ZipFile(evil, "w") as z:
        z.writestr("modelDescription.xml", "<fmiModelDescription/>")
        z.writestr("../escaped.txt", "x")
    for fmu, named in ((text, "not a readable zip"), (evil, "'../escaped.txt'")):
        assert main(["validate", str(fmu)]) == 1  # a broken archive fails validation like any other problem
        captured = capsys.readouterr()
        assert "Traceback" not in captured.err
        assert named in captured.out and "FAIL" in captured.out, captured.out
    assert not (tmp_path.parent / "escaped.txt").exists()


def test_installed_command_prints_one_line_and_exits_2(tmp_path):
    """The console entry point in a fresh interpreter, from a folder outside the repo."""
    bad = tmp_path / "bad.toml"
    bad.write_text("instances = 5\n")
    done = subprocess.run([sys.executable, "-c", "from orchestration.cli import main; raise SystemExit(main())",
                           "run", str(bad)], cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert done.returncode == 2
    assert "instances" in _one_line_error(done.stderr)


# --- hypothesis: any TOML shape, any option value ---------------------------------------------------

KEYS = ["name", "extends", "description", "stop_time", "step_size", "instances", "connect", "connection",
        "fmu", "parameters", "from", "to", "plant", "controller", "reference", "p1", "rho", "phi1"]


def _toml_value(value) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return "nan" if math.isnan(value) else ("inf" if value > 0 else "-inf") if math.isinf(value) else repr(value)
    if isinstance(value, (int, str)):
        return json.dumps(value)
    if isinstance(value, list):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    return "{" + ", ".join(f"{k} = {_toml_value(v)}" for k, v in value.items()) + "}"


SCALARS = st.one_of(st.booleans(), st.integers(-10**15, 10**15), st.floats(), st.sampled_from(
    ["paper", "plant", "controller.tau1", "plant.phi1", "ArmPlant", "", "x.y.z", "../x", "paper-ct"]))
VALUES = st.recursive(SCALARS, lambda inner: st.one_of(
    st.lists(inner, max_size=3), st.dictionaries(st.sampled_from(KEYS), inner, max_size=3)), max_leaves=8)


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow,
                                                                 HealthCheck.function_scoped_fixture])
@given(raw=st.dictionaries(st.sampled_from(KEYS), VALUES, max_size=5), base=st.booleans())
def test_any_scenario_file_loads_well_typed_or_is_refused_by_name(tmp_path, raw, base):
    if base:
        raw = {"extends": "paper", **raw}
    path = tmp_path / "any.toml"
    path.write_text("".join(f"{k} = {_toml_value(v)}\n" for k, v in raw.items()))
    try:
        scenario = load_scenario(str(path))
    except ScenarioError as exc:
        assert "\n" not in str(exc) and ("any" in str(exc) or "paper" in str(exc)), str(exc)
        return
    assert isinstance(scenario, Scenario) and scenario.instances
    assert 0 < scenario.steps <= MAX_STEPS and math.isfinite(scenario.stop_time)
    assert all(isinstance(i.fmu, str) for i in scenario.instances.values())
    assert all(isinstance(v, (int, float)) and not isinstance(v, bool)
               for i in scenario.instances.values() for v in i.parameters.values())


OPTION_TEXT = st.one_of(st.sampled_from(["-3", "0", "nan", "inf", "-inf", "1e12", "1e-12", "", "x", "0x10",
                                         "1e400", "-0", "true"]), st.text(max_size=8))


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(option=st.sampled_from(["--stop-time", "--workers"]), value=OPTION_TEXT)
def test_any_option_value_runs_nothing_or_is_refused_in_one_line(tmp_path, capsys, monkeypatch, option, value):
    """Values that are valid must stay small here: only invalid ones are generated for the run itself
    (a valid --stop-time is replaced by an invalid scenario so that nothing long runs)."""
    monkeypatch.chdir(tmp_path)
    bad = tmp_path / "bad.toml"
    bad.write_text("instances = 5\n")
    argv = (["sweep", str(bad), "--set", "controller.rho=3", option, value] if option == "--workers"
            else ["run", str(bad), option, value])
    try:
        code = main(argv)
    except SystemExit as exc:
        code = exc.code
    assert code == 2
    _one_line_error(capsys.readouterr().err)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.toml"]


@pytest.mark.parametrize("command", [["build", "--out", "{}"], ["run", "paper", "--no-recording", "--fmu-dir", "{}"],
                                     ["validate", "--fmu-dir", "{}"],
                                     ["sweep", "paper", "--set", "controller.rho=3,4", "--out", "{}"]])
def test_unusable_output_folder_is_refused_before_building(command, tmp_path, not_a_folder, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    before = sorted(tmp_path.iterdir())
    for bad in (not_a_folder, not_a_folder / "fmus", Path("/proc/sotc-cosim-test-fmus")):
        assert main([str(bad) if a == "{}" else a for a in command]) == 2
        assert str(bad) in _one_line_error(capsys.readouterr().err)
    assert sorted(tmp_path.iterdir()) == before


def test_version_is_printed(capsys):
    from importlib.metadata import version

    from orchestration.cli import main

    with pytest.raises(SystemExit) as stop:
        main(["--version"])
    assert stop.value.code == 0 and capsys.readouterr().out.strip() == f"sotc-cosim {version('sotc-cosim')}"


@pytest.mark.parametrize("scenario, old", [("paper-ct", "tau_max"), ("paper-lqr", "tau_max"), ("paper-otc", "tau_limit")])
def test_the_old_torque_limit_names_are_refused_naming_rho(scenario, old, tmp_path, fmu_dir, capsys, monkeypatch):
    """The torque limit is ``rho`` in every controller since 0.2.0 (CHANGELOG.md)."""
    monkeypatch.chdir(tmp_path)
    path = tmp_path / "old.toml"
    path.write_text(f'extends = "{scenario}"\n[instances.controller.parameters]\n{old} = 3.0\n')
    assert main(["run", str(path), "--no-recording", "--fmu-dir", str(fmu_dir)]) == 2
    line = _one_line_error(capsys.readouterr().err)
    assert f"'{old}' was renamed 'rho'" in line and "CHANGELOG.md" in line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["old.toml"]


def test_a_sweep_file_with_the_old_torque_limit_name_is_refused_naming_rho(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    path = tmp_path / "old.toml"
    path.write_text('name = "old"\nscenario = "paper-ct"\n[[axis]]\nname = "plant.phi1_0"\nvalues = [0.5, 0.6]\n'
                    '[controller_settings.CtController]\n"controller.tau_max" = 3.0\n')
    assert main(["sweep", str(path)]) == 2
    line = _one_line_error(capsys.readouterr().err)
    assert "'tau_max' was renamed 'rho'" in line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["old.toml"]


def test_a_reader_that_went_away_ends_the_command_quietly_with_141():
    """`sotc-cosim scenarios | head` once ended in "error: [Errno 32] Broken pipe" and exit 1: the reader of
    stdout going away is no error of the command. Here the pipe's read end is closed before the command
    writes, so its first line meets a closed pipe whatever the timing."""
    import os
    import subprocess
    import sys

    read, write = os.pipe()
    os.close(read)
    try:
        proc = subprocess.run([sys.executable, "-c", "from orchestration.cli import console; console()", "scenarios"],
                              stdout=write, stderr=subprocess.PIPE, text=True, timeout=120)
    finally:
        os.close(write)
    assert (proc.returncode, proc.stderr) == (141, "")
