"""The built FMUs as standalone components in a host that has fmpy and numpy but not sotc-cosim
(``shipped.BLOCK_PROJECT`` makes the project's packages, pythonfmu included, unimportable): any
mix of our FMUs, in any order, from any build, in one process, each running its own code."""
from __future__ import annotations

import html
import json
import math
import subprocess
import zipfile
from pathlib import Path

import pytest

from orchestration.fmu_build.build import FMU_SOURCES

pytestmark = pytest.mark.slow  # the installed wheel in a fresh virtualenv: minutes

MODELS = list(FMU_SOURCES)
DRIVER = """
import json, math, shutil, sys, tempfile
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave

def run_fmu(path, steps=5, keep=False, name="instance"):
    '''instantiate, initialise, step, read every Real output; free and delete the folder (unless keep;
    a failure deletes it too)'''
    md = read_model_description(path)
    folder = extract(path, unzipdir=tempfile.mkdtemp())
    try:
        fmu = FMU2Slave(guid=md.guid, unzipDirectory=folder, modelIdentifier=md.coSimulation.modelIdentifier,
                        instanceName=name)
        fmu.instantiate(loggingOn=True)
        fmu.setupExperiment(startTime=0.0)
        fmu.enterInitializationMode()
        fmu.exitInitializationMode()
        outs = [v for v in md.modelVariables if v.causality == "output" and v.type == "Real"]
        for k in range(steps):
            fmu.doStep(currentCommunicationPoint=k * 0.01, communicationStepSize=0.01)
        values = dict(zip([v.name for v in outs], fmu.getReal([v.valueReference for v in outs])))
    except BaseException:
        shutil.rmtree(folder, ignore_errors=True)
        raise
    if keep:
        return values, (fmu, folder)
    close((fmu, folder))
    return values

def close(handle):
    fmu, folder = handle
    fmu.terminate()
    fmu.freeInstance()
    shutil.rmtree(folder)
"""


def _json_run(shipped, code: str, *args: str) -> object:
    proc = shipped.python_code(DRIVER + code, *args, cwd=shipped.workdir("fmus"), block_project=True, timeout=300)
    assert proc.returncode == 0, f"exit {proc.returncode}\n{proc.stdout[-3000:]}\n{proc.stderr[-3000:]}"
    return json.loads(proc.stdout.strip().splitlines()[-1])


def _paths(fmu_dir: Path) -> list[str]:
    return [str(fmu_dir / f"{m}.fmu") for m in MODELS]


def test_every_fmu_through_simulate_fmu_one_after_another(shipped, shipped_fmu_dir):
    code = """
import fmpy, numpy as np
out = {}
for path in sys.argv[1:]:
    res = fmpy.simulate_fmu(path, stop_time=0.1, step_size=0.01)
    out[path] = bool(all(np.isfinite(res[n]).all() for n in res.dtype.names))
print(json.dumps(out))
"""
    finite = _json_run(shipped, code, *_paths(shipped_fmu_dir))
    assert finite == dict.fromkeys(_paths(shipped_fmu_dir), True)


def test_every_fmu_instantiated_at_once(shipped, shipped_fmu_dir):
    code = """
handles, values = [], {}
for path in sys.argv[1:]:
    v, h = run_fmu(path, keep=True)
    values[path], handles = v, handles + [h]
for h in handles:
    close(h)
print(json.dumps(values))
"""
    together = _json_run(shipped, code, *_paths(shipped_fmu_dir))
    alone = {p: _json_run(shipped, "print(json.dumps(run_fmu(sys.argv[1])))", p) for p in _paths(shipped_fmu_dir)}
    assert together == alone


@pytest.mark.parametrize("first", MODELS)
def test_every_ordered_pair_in_one_process(shipped, shipped_fmu_dir, first):
    """A (instantiate, step, free, delete its folder), then B, for every B, in one fresh process; every
    run of an FMU gives the numbers that FMU gives alone."""
    code = """
a, others = sys.argv[1], sys.argv[2:]
runs = []
for b in others:
    runs.append([a, run_fmu(a)])
    runs.append([b, run_fmu(b)])
print(json.dumps(runs))
"""
    a = str(shipped_fmu_dir / f"{first}.fmu")
    runs = _json_run(shipped, code, a, *_paths(shipped_fmu_dir))
    assert len(runs) == 2 * len(MODELS)
    reference = {}
    for path, values in runs:
        assert all(math.isfinite(v) for v in values.values()), (path, values)
        assert reference.setdefault(path, values) == values, f"{path} gave other numbers after another FMU ran"


def _variant_build(shipped, tmp_path: Path) -> Path:
    """ArmPlant built from different sources: the end effector X moved by +1 m in the kinematics."""
    src = tmp_path / "variant-src"
    import shutil

    shutil.copytree(shipped.src, src)
    kin = src / "fmu_plant" / "kinematics.py"
    text = kin.read_text()
    old = "    return ex, ey, ex + l2 * ca, ey + l2 * sa"
    assert old in text
    kin.write_text(text.replace(old, "    return ex, ey, 1.0 + ex + l2 * ca, ey + l2 * sa"))
    out = tmp_path / "variant-fmus"
    env = shipped.env(PYTHONPATH=str(src))
    proc = subprocess.run([str(shipped.python), "-m", "orchestration.fmu_build.build", "--out", str(out), "ArmPlant"],
                          cwd=src, env=env, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    return out / "ArmPlant.fmu"


def test_two_builds_of_one_fmu_each_run_their_own_code(shipped, shipped_fmu_dir, tmp_path):
    original, variant = str(shipped_fmu_dir / "ArmPlant.fmu"), str(_variant_build(shipped, tmp_path))
    code = """
orig, var = sys.argv[1], sys.argv[2]
seq = [run_fmu(orig), run_fmu(var), run_fmu(orig), run_fmu(var)]
(a, ha), (b, hb) = run_fmu(var, keep=True), run_fmu(orig, keep=True)
close(ha); close(hb)
print(json.dumps({"sequence": seq, "together": [b, a]}))
"""
    result = _json_run(shipped, code, original, variant)
    runs = result["sequence"] + result["together"]
    for o, v in zip(runs[0::2], runs[1::2]):
        assert v["ee_x"] - o["ee_x"] == pytest.approx(1.0, abs=1e-12)
        assert v["phi1"] == o["phi1"] and v["ee_y"] == o["ee_y"]
    # the variant in a fresh process first gives the same numbers as after the original ran
    first = _json_run(shipped, "print(json.dumps([run_fmu(sys.argv[2]), run_fmu(sys.argv[1])]))", original, variant)
    assert first == [runs[1], runs[0]]


def test_instantiating_leaves_sys_path_as_it_was(shipped, shipped_fmu_dir):
    """Three rounds over every FMU: an entry left by any instance, or by a second instance of one FMU, shows
    (20 rounds took 14 s of the suite and could show nothing more)."""
    code = """
before = list(sys.path)
for _ in range(3):
    for path in sys.argv[1:]:
        run_fmu(path, steps=1)
print(json.dumps([before, sys.path]))
"""
    before, after = _json_run(shipped, code, *_paths(shipped_fmu_dir))
    assert after == before


def _with_requirement(fmu: Path, dest: Path, requirement: str) -> Path:
    """A copy of ``fmu`` whose generated host check asks for ``requirement``."""
    with zipfile.ZipFile(fmu) as z:
        entries = {n: z.read(n) for n in z.namelist()}
    stem = entries["resources/slavemodule.txt"].decode().strip()
    script = f"resources/{stem}.py"
    text = entries[script].decode()
    start = text.index("\nrequire_host_packages(") + 1
    end = text.index("\n", start)
    entries[script] = (text[:start] + f"require_host_packages({fmu.stem!r}, ({requirement!r},))" + text[end:]).encode()
    with zipfile.ZipFile(dest, "w") as z:
        for n, data in entries.items():
            z.writestr(n, data)
    return dest


@pytest.mark.parametrize("requirement, said", [
    ("nosuchpackage>=1.0", "the package 'nosuchpackage' (nosuchpackage>=1.0) is not installed"),
    ("numpy>=99", "outside the range numpy>=99"),
])
def test_a_host_without_a_required_package_is_told_which(shipped, shipped_fmu_dir, tmp_path, requirement, said):
    fmu = _with_requirement(shipped_fmu_dir / "ArmPlant.fmu", tmp_path / "ArmPlant.fmu", requirement)
    tmp = tmp_path / "tmp"
    tmp.mkdir()
    proc = shipped.python_code(DRIVER + "run_fmu(sys.argv[1])", str(fmu), cwd=shipped.workdir("deps"),
                               block_project=True, env={"TMPDIR": str(tmp)})
    assert proc.returncode != 0
    assert said in proc.stdout + proc.stderr, proc.stdout + proc.stderr
    assert "pip install" in proc.stdout + proc.stderr
    assert not any(tmp.iterdir())  # the FMU it could not run is not left unpacked (a tmpXXXXXXXX per run was)


def test_each_fmu_says_what_its_host_needs(shipped_fmu_dir):
    for model in MODELS:
        with zipfile.ZipFile(shipped_fmu_dir / f"{model}.fmu") as z:
            requirements = z.read("resources/requirements.txt").decode().split()
            page = html.unescape(z.read("documentation/index.html").decode())
            md = z.read("modelDescription.xml").decode()
        # numpy at most (the Riccati solutions of OTC/LQR need no scipy); the reference needs nothing
        expected = [] if model == "ReferenceTrajectory" else ["numpy"]
        assert [r.split("<")[0].split(">")[0] for r in requirements] == expected, (model, requirements)
        assert all(r in page for r in requirements) and "CPython 3.11" in page
        # the page says what the list holds: packages to install, or none at all
        assert ("imports no package beyond Python's standard library" in page) == (not requirements), model
        names = [line.split('name="')[1].split('"')[0] for line in md.splitlines() if "<ScalarVariable" in line]
        assert names and all(f"<td>{n}</td>" in page for n in names), model
