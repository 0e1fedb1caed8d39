"""Requests refused up front in one line, exit 2, nothing written or built: the command line itself
(``--version extra``, ``--bogus``), a file that is not a TOML scenario or sweep, an output name too
long for the file system, a file output in a folder that does not exist, and an existing file that is
not of the output's kind (replaced only with ``--force``)."""
from __future__ import annotations

import json
import zipfile
from pathlib import Path

import pytest

from orchestration.cli import main

FOREIGN = b"127.0.0.1 localhost\n"  # a file of someone else's, e.g. /etc/hosts


def _refused(argv: list[str], capsys) -> str:
    """``main(argv)`` exits 2 with one line on stderr (argparse's refusals raise SystemExit); that line."""
    try:
        code = main(argv)
    except SystemExit as exc:
        code = exc.code
    err = capsys.readouterr().err
    lines = [line for line in err.splitlines() if line.strip()]
    assert code == 2 and len(lines) == 1 and "Traceback" not in err, (code, err)
    return lines[0]


def test_version_with_another_argument_is_a_usage_error(capsys):
    line = _refused(["--version", "extra"], capsys)
    assert "--version" in line and "extra" in line


def test_an_unknown_option_without_a_command_is_named(capsys):
    line = _refused(["--bogus"], capsys)
    assert "--bogus" in line, line  # it said "the following arguments are required: command"
    assert "command" in _refused([], capsys)


@pytest.mark.parametrize("command, what", [(["sweep"], "sweep"), (["run"], "scenario")])
def test_a_file_that_is_not_toml_is_named_as_such(command, what, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    passwd = tmp_path / "passwd"
    passwd.write_text("root:x:0:0:root:/root:/bin/bash\n")
    line = _refused([*command, str(passwd)], capsys)
    assert f"not a TOML {what} file" in line and str(passwd) in line, line  # it said "no sweep '...'"
    assert f"is a folder, not a TOML {what} file" in _refused([*command, str(tmp_path)], capsys)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["passwd"]


@pytest.mark.parametrize("length", [300, 250])
def test_an_output_name_too_long_is_refused_before_anything_runs(length, tmp_path, monkeypatch, capsys):
    """300 characters: ENAMETOOLONG, exit 1; 250: the run went through and the rename of its temporary
    file (14 characters longer) failed after it, exit 1."""
    monkeypatch.chdir(tmp_path)
    name = "r" * (length - 4) + ".rrd"
    for option in ("--recording", "--summary"):
        line = _refused(["run", "paper", option, name, "--fmu-dir", "fmus", "--stop-time", "0.01"], capsys)
        assert option in line and "too long" in line and f"{length} characters" in line, line
    assert not any(tmp_path.iterdir())  # no FMU built, nothing written


@pytest.mark.parametrize("argv", [["run", "paper", "--recording", "{}", "--fmu-dir", "fmus"],
                                  ["run", "paper", "--summary", "{}", "--fmu-dir", "fmus"],
                                  ["compare", "paper", "--recording", "{}", "--fmu-dir", "fmus"],
                                  ["export-ssp", "paper", "--out", "{}", "--fmu-dir", "fmus"],
                                  ["tune", "CT", "--out", "{}"]])
def test_a_file_output_in_a_missing_folder_is_refused(argv, tmp_path, monkeypatch, capsys):
    """A mistyped folder was made without a word (``--recording /nonexistent/dir/x.rrd``)."""
    monkeypatch.chdir(tmp_path)
    target = tmp_path / "no-such-dir" / "deeper" / "out.x"
    line = _refused([str(target) if a == "{}" else a for a in argv], capsys)
    assert "does not exist" in line and str(target.parent) in line, line
    assert not any(tmp_path.iterdir())


def test_a_file_output_under_recordings_gets_its_folder(tmp_path, fmu_dir, monkeypatch, capsys):
    """recordings/, the default place of every output, is made as needed (as for the defaults)."""
    monkeypatch.chdir(tmp_path)
    argv = ["run", "paper", "--stop-time", "0.02", "--fmu-dir", str(fmu_dir)]
    assert main([*argv, "--recording", "recordings/mine/r.rrd", "--summary", "recordings/s.json"]) == 0
    assert (tmp_path / "recordings" / "mine" / "r.rrd").is_file() and (tmp_path / "recordings" / "s.json").is_file()


def _ssp(path: Path) -> Path:
    with zipfile.ZipFile(path, "w") as z:
        z.writestr("SystemStructure.ssd", "<ssd/>")
    return path


OWN = {  # option -> a file of its own kind (replaced without --force)
    "--recording": lambda p: p.write_bytes(b"RRF2" + bytes(12)),
    "--summary": lambda p: p.write_text(json.dumps({"scenario": "paper", "status": "ok"})),
    "--out": _ssp,
}
COMMANDS = {"--recording": ["run", "paper", "--recording", "{}"], "--summary": ["run", "paper", "--summary", "{}"],
            "--out": ["export-ssp", "paper", "--out", "{}"]}


@pytest.mark.parametrize("option", list(COMMANDS))
def test_an_existing_file_of_another_kind_is_kept_unless_forced(option, tmp_path, monkeypatch, capsys):
    """export-ssp --out replaced any file with a zip (a system file among them), exit 0."""
    monkeypatch.chdir(tmp_path)
    target = tmp_path / "hosts"
    target.write_bytes(FOREIGN)
    argv = [str(target) if a == "{}" else a for a in COMMANDS[option]] + ["--fmu-dir", "fmus"]
    line = _refused(argv, capsys)
    assert option in line and "--force" in line and "exists and is not" in line, line
    assert target.read_bytes() == FOREIGN and sorted(p.name for p in tmp_path.iterdir()) == ["hosts"]


@pytest.mark.parametrize("option", list(COMMANDS))
def test_an_output_of_its_own_kind_or_forced_is_replaced(option, tmp_path, fmu_dir, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    own = tmp_path / "own.x"
    OWN[option](own)
    foreign = tmp_path / "foreign.x"
    foreign.write_bytes(FOREIGN)
    for target, extra in ((own, []), (foreign, ["--force"])):
        argv = [str(target) if a == "{}" else a for a in COMMANDS[option]] + ["--fmu-dir", str(fmu_dir), *extra]
        argv += ["--stop-time", "0.02"] if argv[0] == "run" else []
        assert main(argv) == 0, capsys.readouterr().err
        assert target.read_bytes()[:4] != FOREIGN[:4]  # written


def test_tune_keeps_a_foreign_store_or_journal(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    tune = ["tune", "CT", "--budget", "1", "--polish", "0", "--seeds", "0", "--handlings", "accel", "--workers", "1"]
    (tmp_path / "s.json").write_bytes(FOREIGN)
    line = _refused([*tune, "--out", "s.json"], capsys)
    assert "--out s.json: exists and is not a tune store" in line and "--force" in line, line
    (tmp_path / "t.json.journal").write_bytes(FOREIGN)
    line = _refused([*tune, "--out", "t.json"], capsys)
    assert "--out's journal t.json.journal: exists and is not an Optuna journal" in line, line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.json", "t.json.journal"]
    assert (tmp_path / "t.json.journal").read_bytes() == FOREIGN



def test_a_file_output_may_go_into_the_output_folder_the_command_makes(tmp_path):
    """reproduce --out DIR --recording DIR/r.rrd: DIR is made by reproduce itself, so the recording's folder
    need not exist yet (the before-stop smoke run was refused); anywhere else a missing folder still is."""
    from orchestration.paths import OutputPathError, check_output_file

    out = tmp_path / "out"
    assert check_output_file(out / "r.rrd", "--recording", within=out) == out / "r.rrd"
    assert not any(tmp_path.iterdir())  # nothing made by the check
    for path, within in ((out / "r.rrd", None), (tmp_path / "other" / "r.rrd", out)):
        with pytest.raises(OutputPathError, match="does not exist"):
            check_output_file(path, "--recording", within=within)
