"""FMI 3.0 as a user gets it: the installed console script, run from a folder outside the repository
(``tests/support/shipped.py``): build --fmi 3, run it, its Model Exchange arm in fmpy, validate,
cross-check and export-ssp, a sweep."""
from __future__ import annotations

import json
import subprocess
import zipfile
from pathlib import Path
from xml.etree import ElementTree

import pytest

from orchestration.fmu_build.build import FMU_SOURCES


def _ok(proc: subprocess.CompletedProcess) -> None:
    assert proc.returncode == 0, f"exit {proc.returncode}\n{proc.stdout}\n{proc.stderr}"
    assert "Traceback" not in proc.stderr, proc.stderr


def _cli(shipped, *args: str, cwd: Path, **env: str) -> subprocess.CompletedProcess:
    return subprocess.run([str(shipped.script), *args], cwd=cwd, env=shipped.env(**env), capture_output=True,
                          text=True, timeout=1800)


@pytest.fixture(scope="module")
def fmi3_dir(shipped) -> Path:
    """``sotc-cosim build --fmi 3 --out D``, cores in Python; ``compiled_paper`` below is the compiled FMI 3 build."""
    out = shipped.root / "fmus3"
    proc = _cli(shipped, "build", "--fmi", "3", "--out", str(out), cwd=shipped.workdir("build3"), SOTC_COSIM_COMPILE="0")
    _ok(proc)
    return out


PAPER = ("ArmPlant", "ReferenceTrajectory", "SotcController")  # the `paper` run's FMUs


@pytest.fixture(scope="module")
def compiled_paper(shipped, shipped_fmu_dir) -> Path:
    """The `paper` run's FMUs as a default FMI 3 build makes them, cores compiled where the host can: taken from
    the private cache the FMI 2 build (``shipped_fmu_dir``) filled, as a user's second build takes them."""
    out = shipped.root / "fmus3-compiled"
    _ok(_cli(shipped, "build", "--fmi", "3", "--out", str(out), *PAPER, cwd=shipped.workdir("build3c")))
    return out


@pytest.fixture(scope="module")
def compiled_arm(compiled_paper) -> Path:
    return compiled_paper / "ArmPlant.fmu"


def _description(fmu: Path) -> ElementTree.Element:
    return ElementTree.fromstring(zipfile.ZipFile(fmu).read("modelDescription.xml"))


def test_build_fmi3_gives_every_fmu_as_fmi_3_with_arrays(fmi3_dir):
    built = sorted(p.stem for p in fmi3_dir.glob("*.fmu"))
    assert built == sorted(FMU_SOURCES)
    assert {_description(fmi3_dir / f"{m}.fmu").get("fmiVersion") for m in built} == {"3.0"}
    w = _description(fmi3_dir / "SotcController.fmu").find("ModelVariables/Float64[@name='W']")
    assert w is not None and [d.get("start") for d in w.iter("Dimension")] == ["10"]


@pytest.mark.slow
def test_run_paper_fmi3_gives_the_fmi2_mse(shipped, shipped_fmu_dir, compiled_paper):
    """The acceptance run: the FMI 3 MSE equals the FMI 2 one computed by the same code (1e-12 relative), both
    builds as a user gets them by default (the Python FMI 3 build runs 2 s bit for bit against FMI 2 in
    tests/fmu/test_fmi3.py, and in the sweep, validate and Model Exchange tests here; 100 s of it took 15 s)."""
    work = shipped.workdir("run3")
    for fmi, folder in (("2", shipped_fmu_dir), ("3", compiled_paper)):
        _ok(_cli(shipped, "run", "paper", "--fmi", fmi, "--fmu-dir", str(folder), "--summary", f"s{fmi}.json",
                 "--no-recording", cwd=work))
    fmi2, fmi3 = (json.loads((work / f"s{fmi}.json").read_text()) for fmi in "23")
    assert fmi3["status"] == fmi2["status"] == "ok" and fmi3["samples"] == fmi2["samples"] == 10001
    assert fmi3["mse"] == pytest.approx(fmi2["mse"], rel=1e-12, abs=0.0)


ME_RUN = """
import sys, fmpy, numpy as np
fmu, kw = sys.argv[1], dict(stop_time=2.0, output_interval=0.01, start_values={"dphi1_0": 1.0, "dphi2_0": -1.0},
                            output=["phi", "dphi"])
me = fmpy.simulate_fmu(fmu, fmi_type="ModelExchange", relative_tolerance=1e-10, **kw)
cs = fmpy.simulate_fmu(fmu, fmi_type="CoSimulation", **kw)
assert me["time"][-1] == cs["time"][-1] == 2.0
print(float(np.max(np.abs(np.array(me[-1]["phi"]) - np.array(cs[-1]["phi"])))))
"""


@pytest.mark.parametrize("build", ["python", "compiled"])
def test_model_exchange_arm_ends_within_1e_6_rad_of_the_cosimulation_arm(shipped, fmi3_dir, compiled_arm, build):
    """Two seconds of the arm, initial speed [1, -1], zero torque: fmpy's CVODE on the Model Exchange
    interface (relative tolerance 1e-10) against the co-simulation interface's RK4, in a host that
    has no sotc-cosim module importable (the FMU stands alone)."""
    fmu = fmi3_dir / "ArmPlant.fmu" if build == "python" else compiled_arm
    proc = shipped.python_code(ME_RUN, str(fmu), cwd=shipped.workdir("me"), block_project=True)
    _ok(proc)
    gap = float(proc.stdout.split()[-1])
    assert 0.0 < gap < 1e-6, gap


def test_validate_passes_the_fmi3_fmus(shipped, fmi3_dir, compiled_arm):
    work = shipped.workdir("validate3")
    proc = shipped.cli("validate", *map(str, sorted(fmi3_dir.glob("*.fmu"))), str(compiled_arm), cwd=work)
    _ok(proc)
    assert "all FMUs pass" in proc.stdout
    passed = [line.split()[0] for line in proc.stdout.splitlines() if line.endswith(" pass") and "  " in line]
    assert sorted(passed) == sorted([*FMU_SOURCES, "ArmPlant"]), proc.stdout


def test_cross_check_writes_the_fmi3_layout_and_export_ssp_says_why_not(shipped, fmi3_dir):
    work = shipped.workdir("cross-check3")
    proc = shipped.cli("cross-check", "--fmi", "3", "--out", "xc", "--stop-time", "0.5", "--fmu-dir", str(fmi3_dir),
                       "SotcController", cwd=work)
    _ok(proc)
    folder = Path(work, proc.stdout.split()[0])
    assert folder.relative_to(work / "xc").parts[:3] == ("fmus", "3.0", "cs")
    header = (folder / "SotcController_ref.csv").read_text().splitlines()[0]
    assert '"W1"' in header and '"W10"' in header and '"tau2"' in header  # arrays as their FMI 2 scalars
    proc = shipped.cli("export-ssp", "--fmi", "3", "--out", "x.ssp", "--fmu-dir", str(fmi3_dir), cwd=work)
    assert proc.returncode == 2 and "SSP 1.x" in proc.stderr and len(proc.stderr.splitlines()) == 1, proc.stderr
    assert not (work / "x.ssp").exists()


SWEEP = """
name = "fmi3"
scenario = "paper"
stop_time = 0.5
[[axis]]
name = "controller.alpha1"
values = [40.0, 50.0]
"""


def test_a_sweep_runs_the_fmi3_fmus(shipped, fmi3_dir):
    work = shipped.workdir("sweep3")
    (work / "fmi3.toml").write_text(SWEEP)
    proc = shipped.cli("sweep", "fmi3.toml", "--fmi", "3", "--workers", "1", "--fmu-dir", str(fmi3_dir), cwd=work)
    _ok(proc)
    rows = [json.loads(line) for line in (work / "recordings" / "fmi3" / "points.jsonl").read_text().splitlines()]
    assert len(rows) == 2 and all(r["status"] == "ok" for r in rows), rows


def test_the_installed_build_puts_the_size_checking_binary_in_front_of_pythonfmu3s(fmi3_dir):
    """The wheel carries the shim's C source, and a build from it compiles the shim where it can."""
    from orchestration.fmu_build import packaging, shim

    why = packaging.shim_unavailable()
    if why:
        pytest.skip(why)
    names = zipfile.ZipFile(fmi3_dir / "ArmPlant.fmu").namelist()
    assert f"binaries/{shim.platform_folder()}/ArmPlant{shim.INNER_SUFFIX}.so" in names, names
    assert f"resources/{shim.SIZES_FILE}" in names, names
