"""Hostile files and paths through the installed console script: a TOML that is too deep, not UTF-8
or too large, and an output or lock path that is a dangling link, a folder or a link, give one line
naming the file or the option and exit 2, with nothing built, created or printed on stdout."""
from __future__ import annotations

import os

import pytest

from support.cli import one_line, run

HOSTILE_TOML = {
    "nested-arrays": "a = " + "[" * 100_000 + "]" * 100_000 + "\n",
    "nested-tables": "a = " + "{b = " * 20_000 + "1" + "}" * 20_000 + "\n",
    "not-utf8": b'name = "\xff\xfe"\n',
    "too-large": "# padding\n" * 200_000,
    # tomllib is quadratic in a key's dotted parts: these took hours (20,000 parts: 63 s)
    "dotted-key": "a" + ".a" * 200_000 + " = 1\n",
    "dotted-header": "[t" + ".t" * 200_000 + "]\n",
    "spaced-dotted-key": "a" + " . a" * 100_000 + " = 1\n",
}


def _write(path, content) -> None:
    path.write_bytes(content if isinstance(content, bytes) else content.encode())


def _nothing_but(tmp_path, *names: str) -> None:
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(["tmp", *names])
    assert list((tmp_path / "tmp").iterdir()) == []


@pytest.mark.parametrize("command", ["run", "sweep"])
@pytest.mark.parametrize("kind", list(HOSTILE_TOML))
def test_a_hostile_toml_gives_one_line_naming_the_file(kind, command, tmp_path):
    path = tmp_path / f"{kind}.toml"
    _write(path, HOSTILE_TOML[kind])
    proc = run([command, path.name, "--fmu-dir", "fmus"], tmp_path)
    assert proc.returncode == 2, proc.stderr[-500:]
    line = one_line(proc.stderr)
    assert path.name in line and proc.stdout == ""
    _nothing_but(tmp_path, path.name)


@pytest.mark.parametrize("args, said", [(["run", "fifo.toml"], "not a TOML scenario file"),
                                        (["check-controller", "x.fmu", "--ports", "fifo.toml"], "not a regular file")],
                         ids=["scenario", "port map"])
def test_a_fifo_for_a_toml_gives_one_line_instead_of_waiting_for_a_writer(args, said, tmp_path):
    """Reading a FIFO blocks until something writes into it (a device may never end): refused before reading
    (a port map blocked check-controller until a signal)."""
    os.mkfifo(tmp_path / "fifo.toml")
    proc = run(args, tmp_path, timeout=60)
    assert proc.returncode == 2 and said in one_line(proc.stderr) and "fifo.toml" in proc.stderr, proc.stderr[-500:]
    _nothing_but(tmp_path, "fifo.toml")


def _dangling(tmp_path, name: str):
    (tmp_path / name).symlink_to(tmp_path / "nowhere" / name)
    return name


PATH_CASES = {
    "sweep --out dangling link": (["sweep", "paper", "--set", "controller.rho=3,4", "--out", "{link}"], "--out"),
    "reproduce --out dangling link": (["reproduce", "--out", "{link}"], "--out"),
    "run --recording dangling link": (["run", "--recording", "{link}"], "--recording"),
    "run --summary dangling link": (["run", "--no-recording", "--summary", "{link}"], "--summary"),
    "export-ssp --out dangling link": (["export-ssp", "--out", "{link}"], "--out"),
    "build --out dangling link": (["build", "--out", "{link}"], "--out"),
    "run --recording lock is a folder": (["run", "--recording", "r.rrd"], "--recording"),
    "run --recording lock is a dangling link": (["run", "--recording", "s.rrd"], "--recording"),
    "sweep --out lock is a folder": (["sweep", "paper", "--set", "controller.rho=3,4", "--out", "sw"], "--out"),
}


@pytest.mark.parametrize("case", list(PATH_CASES))
def test_a_hostile_output_path_gives_one_line_naming_the_option(case, tmp_path):
    args, option = PATH_CASES[case]
    made = [_dangling(tmp_path, "link")]
    (tmp_path / ".r.rrd.lock").mkdir()
    made.append(".r.rrd.lock")
    os.symlink(tmp_path / "nowhere.lock", tmp_path / ".s.rrd.lock")
    made.append(".s.rrd.lock")
    (tmp_path / "sw" / ".sotc-cosim.lock").mkdir(parents=True)
    made.append("sw")
    proc = run([a.replace("{link}", "link") for a in args] + ([] if args[0] == "build" else ["--fmu-dir", "fmus"]),
               tmp_path)
    assert proc.returncode == 2, (proc.stdout, proc.stderr)
    line = one_line(proc.stderr)
    assert line.startswith(f"sotc-cosim: error: {option} "), line
    assert proc.stdout == ""
    _nothing_but(tmp_path, *made)


def test_a_malformed_scheduler_is_refused_before_anything(tmp_path):
    proc = run(["sweep", "robustness", "--scheduler", "notanaddress", "--fmu-dir", "fmus"], tmp_path)
    assert proc.returncode == 2
    assert "--scheduler notanaddress" in one_line(proc.stderr)
    assert proc.stdout == ""  # no "41 to run on notanaddress"
    _nothing_but(tmp_path)  # no results folder, no FMU folder, no cache folder in TMPDIR


def test_a_run_too_long_is_refused_without_claiming_samples_are_held_in_memory(tmp_path):
    proc = run(["run", "--stop-time", "1e9", "--fmu-dir", "fmus"], tmp_path)
    assert proc.returncode == 2
    line = one_line(proc.stderr)
    assert "at most 1,000,000" in line and "run and sweep stream" in line and "held in memory" not in line
    _nothing_but(tmp_path)
