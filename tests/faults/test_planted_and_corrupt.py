"""What someone else left behind, or a crash: a planted file in the FMU cache, a cache folder others
can write in, a points.jsonl with foreign and torn lines, FMUs whose code changed after the build,
archives that expand too far; and FMU parameters and states the FMUs cannot use."""
from __future__ import annotations

import hashlib
import json
import os
import zipfile
from pathlib import Path

import pytest
from fmpy.fmi1 import FMICallException

from support.cli import leftovers, one_line, run, warm_core_cache
from support.fmu_driver import DrivenFmu

from orchestration.outputs import private_root

SWEEP = ["sweep", "paper", "--set", "plant.phi1_0=0.4,0.5", "--stop-time", "1", "--workers", "1"]


def _cache(tmp_path: Path) -> Path:
    return private_root(tmp_path / "tmp") / "fmus"


def test_a_planted_cache_file_is_never_run(fmu_dir, tmp_path):
    first = run([*SWEEP, "--out", str(tmp_path / "a"), "--fmu-dir", str(fmu_dir)], tmp_path)
    assert first.returncode == 0, first.stderr
    cached = next(_cache(tmp_path).glob("*/SotcController.fmu"))
    assert (os.stat(_cache(tmp_path).parent).st_mode & 0o777) == 0o700
    cached.write_bytes((fmu_dir / "CtController.fmu").read_bytes())  # another FMU's code under its digest
    again = run([*SWEEP, "--out", str(tmp_path / "b"), "--fmu-dir", str(fmu_dir)], tmp_path)
    assert again.returncode == 0, again.stderr
    rows = [json.loads(line) for line in (tmp_path / "b" / "points.jsonl").read_text().splitlines()]
    assert [r["summary"]["controller"] for r in rows] == ["SotcController", "SotcController"]
    assert hashlib.sha256(cached.read_bytes()).hexdigest() == cached.parent.name  # written again, verified
    assert leftovers(tmp_path) == []


def test_a_cache_folder_others_can_write_in_is_refused(fmu_dir, tmp_path):
    root = _cache(tmp_path).parent
    root.mkdir(parents=True)
    root.chmod(0o777)
    proc = run([*SWEEP, "--out", str(tmp_path / "a"), "--fmu-dir", str(fmu_dir)], tmp_path)
    assert proc.returncode == 1
    assert "not a private folder of this user" in one_line(proc.stderr)


def test_resume_skips_foreign_and_torn_lines_and_reruns_those_points(fmu_dir, tmp_path):
    out = tmp_path / "s"
    assert run([*SWEEP, "--out", str(out), "--fmu-dir", str(fmu_dir)], tmp_path).returncode == 0
    jsonl = out / "points.jsonl"
    first, second = jsonl.read_text().splitlines()
    jsonl.write_text(first + "\n" + json.dumps({"hello": "world"}) + "\n" + second[: len(second) // 2])  # torn
    proc = run([*SWEEP, "--out", str(out), "--fmu-dir", str(fmu_dir)], tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert "skipped 2 line(s) that are not stored points (line 2, 3); those points run again" in proc.stderr
    assert "1 from before, 1 run now" in proc.stdout
    lines = jsonl.read_text().splitlines()
    parsed = [line for line in lines if line.startswith("{") and line.endswith("}")]
    assert len(lines) == 4 and len({json.loads(line).get("key") for line in parsed[-2:]}) >= 1
    assert json.loads(lines[-1])["key"] == json.loads(second)["key"]  # the rerun point starts its own line


def _copy_with(src: Path, dst: Path, change) -> Path:
    with zipfile.ZipFile(src) as a, zipfile.ZipFile(dst, "w") as b:
        for info in a.infolist():
            b.writestr(info, change(info.filename, a.read(info)))
    return dst


def _replaced(data: bytes, old: bytes, new: bytes) -> bytes:
    assert old in data, f"{old!r} is no longer in the file: the tampering must change something"
    return data.replace(old, new)


def test_validate_fails_an_fmu_whose_code_changed_after_the_build(fmu_dir, tmp_path):
    tampered = _copy_with(fmu_dir / "SotcController.fmu", tmp_path / "SotcController.fmu",
                          lambda name, data: _replaced(data, b"TANH1 = tanh(1.0)", b"TANH1 = 0.9")
                          if name.endswith("/sotc.py") else data)
    proc = run(["validate", str(tampered)], tmp_path)
    assert proc.returncode == 1
    assert "changed after the build" in proc.stdout


def test_validate_refuses_an_archive_that_expands_too_far_without_extracting(tmp_path):
    bomb = tmp_path / "bomb.fmu"
    with zipfile.ZipFile(bomb, "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr("resources/zeros.bin", b"\0" * (300 * 1024 * 1024))
    proc = run(["validate", str(bomb)], tmp_path)
    assert proc.returncode == 1
    assert "at most 268,435,456 bytes" in proc.stdout and "nothing was extracted" in proc.stdout


@pytest.mark.parametrize("params, name", [({"r_1": 5e-324}, "r_1"), ({"W0_3": 1e300}, "W0_3")])
def test_sotc_parameters_it_cannot_use_are_refused_at_initialization(params, name, fmu_paths, tmp_path):
    unit = DrivenFmu(fmu_paths["SotcController"], tmp_path / "u")
    try:
        with pytest.raises(FMICallException):
            unit.initialize(**params)
        assert f"'{name}'" in unit.logged()
    finally:
        unit.free()


@pytest.mark.parametrize("model", ["ArmPlant", "SotcController", "CtController", "ReferenceTrajectory"])
def test_a_restored_state_with_an_unknown_key_is_refused_naming_it(model, fmu_paths, tmp_path):
    unit = DrivenFmu(fmu_paths[model], tmp_path / "u")
    try:
        unit.initialize()
        state = json.loads(bytes(unit.fmu.serializeFMUState(unit.fmu.getFMUState())).decode())
        state["internal"]["planted"] = 1.0
        loaded = unit.fmu.deSerializeFMUstate(json.dumps(state).encode())
        with pytest.raises(FMICallException):
            unit.fmu.setFMUState(loaded)
        assert "internal" in unit.logged() and "planted" in unit.logged()
    finally:
        unit.free()


@pytest.mark.parametrize("field, value", [("next_record_t", True), ("prev_chi", [0.0, 1.0])])
def test_a_restored_sotc_state_of_the_wrong_form_is_refused_naming_the_field(field, value, fmu_paths, tmp_path):
    unit = DrivenFmu(fmu_paths["SotcController"], tmp_path / "u")
    try:
        unit.initialize()
        state = json.loads(bytes(unit.fmu.serializeFMUState(unit.fmu.getFMUState())).decode())
        state["internal"]["core"][field] = value
        loaded = unit.fmu.deSerializeFMUstate(json.dumps(state).encode())
        with pytest.raises(FMICallException):
            unit.fmu.setFMUState(loaded)
        assert field in unit.logged()
    finally:
        unit.free()


@pytest.mark.parametrize("damage", ["garbage", "truncated", "folder"])
def test_a_damaged_fmu_in_the_fmu_folder_is_built_again_or_refused(damage, fmu_dir, tmp_path):
    fmus = tmp_path / "fmus"
    fmus.mkdir()
    for f in fmu_dir.glob("*.fmu"):  # the session's FMUs (other tests build Python ones in a subfolder)
        (fmus / f.name).write_bytes(f.read_bytes())
    target = fmus / "ReferenceTrajectory.fmu"
    if damage == "folder":
        target.unlink()
        target.mkdir()
    else:
        target.write_bytes(b"garbage" if damage == "garbage" else (fmu_dir / target.name).read_bytes()[:3000])
    warm_core_cache(tmp_path)  # the session's build compiled them: the rebuild copies them
    proc = run(["run", "paper", "--stop-time", "0.5", "--no-recording", "--fmu-dir", str(fmus)], tmp_path)
    if damage == "folder":
        assert proc.returncode == 2
        assert "not a file where the FMU goes" in one_line(proc.stderr)
        assert not list(fmus.glob("*.part"))
    else:
        assert proc.returncode == 0, proc.stderr
        assert zipfile.is_zipfile(target)
