"""``sotc-cosim validate``: deliberately broken copies fail on the right check (every FMU of a build passing:
tests/shipped/test_shipped_cli.py, the command as it ships)."""
import shutil
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path

import pytest

from orchestration.cli import main
from orchestration.compliance.validate import validate_fmu_file, validate_fmus


def broken_copy(src: Path, dst: Path, edit) -> Path:
    """Copy an FMU, applying ``edit(root)`` to the ElementTree of its modelDescription.xml."""
    with zipfile.ZipFile(src) as zin, zipfile.ZipFile(dst, "w", zipfile.ZIP_DEFLATED) as zout:
        for item in zin.infolist():
            data = zin.read(item.filename)
            if item.filename == "modelDescription.xml":
                root = ET.fromstring(data)
                edit(root)
                data = ET.tostring(root, encoding="utf-8", xml_declaration=True)
            zout.writestr(item, data)
    return dst


def variable(root, name):
    return next(v for v in root.iter("ScalarVariable") if v.get("name") == name)


def output_unknown(root, name):
    index = [v.get("name") for v in root.iter("ScalarVariable")].index(name) + 1
    return next(u for u in root.find("ModelStructure/Outputs") if u.get("index") == str(index))


def _strip_unit(root):
    del variable(root, "tau1")[0].attrib["unit"]


def _drop_description(root):
    del variable(root, "tau2").attrib["description"]


def _step_size(root):
    root.find("DefaultExperiment").set("stepSize", "0.001")


def _unbounded_parameter(root):
    real = variable(root, "p1")[0]
    del real.attrib["min"], real.attrib["max"]


def _no_state_capability(root):
    root.find("CoSimulation").set("canSerializeFMUstate", "false")


def _input_without_start(root):
    del variable(root, "tau1")[0].attrib["start"]


def _false_dependency(root):  # phi1 is the state: it does not depend on tau1 at the same instant
    tau1 = [v.get("name") for v in root.iter("ScalarVariable")].index("tau1") + 1
    output_unknown(root, "phi1").set("dependencies", str(tau1))


@pytest.mark.parametrize("edit, check, needle", [
    (_strip_unit, "units", "'tau1'"),
    (_drop_description, "descriptions", "'tau2'"),
    (_step_size, "step", "0.001"),
    (_unbounded_parameter, "ranges", "'p1'"),
    (_no_state_capability, "state", "canSerializeFMUstate"),
    (_input_without_start, "starts", "'tau1'"),
    (_false_dependency, "dependencies", "'phi1'"),
])
def test_broken_plant_copy_fails_the_right_check(fmu_paths, tmp_path, edit, check, needle):
    broken = broken_copy(fmu_paths["ArmPlant"], tmp_path / "ArmPlant.fmu", edit)
    report = validate_fmu_file(broken)
    assert not report.ok
    assert any(needle in p for p in report.problems[check]), report.problems


def test_start_that_does_not_round_trip_is_caught(fmu_paths, tmp_path):
    """pythonfmu's own 16-digit starts: phase = pi/2 would come back one ulp off."""
    def sixteen_digits(root):
        real = variable(root, "phase")[0]
        real.set("start", f"{float(real.get('start')):.16g}")

    broken = broken_copy(fmu_paths["ReferenceTrajectory"], tmp_path / "ReferenceTrajectory.fmu", sixteen_digits)
    problems = validate_fmu_file(broken).problems["starts"]
    assert any("'phase'" in p for p in problems), problems


def test_hidden_feedthrough_is_caught_by_experiment(fmu_paths, tmp_path):
    """A controller whose torque claims no dependency on the measurement is caught by perturbation."""
    def hide(root):
        output_unknown(root, "tau1").set("dependencies", "")

    broken = broken_copy(fmu_paths["CtController"], tmp_path / "CtController.fmu", hide)
    problems = validate_fmu_file(broken).problems["dependencies"]
    assert any("'tau1' changes when input" in p for p in problems), problems


def test_one_script_module_name_for_two_bundles_fails_the_set(fmu_paths, tmp_path, capsys):
    copy = tmp_path / "copy" / "ArmPlant.fmu"
    copy.parent.mkdir()
    shutil.copy(fmu_paths["ArmPlant"], copy)
    assert validate_fmus([fmu_paths["ArmPlant"], copy]).set_problems == []  # a copy of one build is fine

    def edit_code(fmu: Path) -> None:
        with zipfile.ZipFile(fmu) as z:
            entries = {n: z.read(n) for n in z.namelist()}
        script = next(n for n in entries if n.startswith("resources/sotc_") and n.count("/") == 1)
        entries[script] += b"\n# another build under the same module name\n"
        with zipfile.ZipFile(fmu, "w") as z:
            for n, data in entries.items():
                z.writestr(n, data)

    other = tmp_path / "other" / "ArmPlant.fmu"
    other.parent.mkdir()
    shutil.copy(fmu_paths["ArmPlant"], other)
    edit_code(other)
    report = validate_fmus([fmu_paths["ArmPlant"], other])
    assert any("bundles other code" in p for p in report.set_problems), report.set_problems


def test_a_module_outside_the_bundle_fails_standalone(fmu_paths, tmp_path):
    fmu = tmp_path / "ArmPlant.fmu"
    shutil.copy(fmu_paths["ArmPlant"], fmu)
    with zipfile.ZipFile(fmu, "a") as z:
        z.writestr("resources/fmu_plant/dynamics.py", "import fmu_plant\n")
    problems = validate_fmu_file(fmu).problems["standalone"]
    assert any("lies outside" in p for p in problems) and any("imports 'fmu_plant'" in p for p in problems), problems


def test_validate_cli_exits_non_zero_on_a_broken_fmu(fmu_paths, tmp_path, capsys):

    broken = broken_copy(fmu_paths["ArmPlant"], tmp_path / "ArmPlant.fmu", _step_size)
    assert main(["validate", str(broken)]) == 1
    out = capsys.readouterr().out
    assert "FAIL" in out and "stepSize" in out
    assert main(["validate", str(fmu_paths["ReferenceTrajectory"])]) == 0


def test_a_pyc_that_is_not_its_sources_fails_standalone(fmu_paths, tmp_path):
    """The .pyc files lie outside the bundle's digest (derived from the sources after it); each must be the
    checked-hash bytecode of the .py beside it."""
    fmu = tmp_path / "ArmPlant.fmu"
    with zipfile.ZipFile(fmu_paths["ArmPlant"]) as zin, zipfile.ZipFile(fmu, "w", zipfile.ZIP_DEFLATED) as zout:
        pycs = sorted(n for n in zin.namelist() if n.endswith(".pyc"))
        for item in zin.infolist():
            data = zin.read(item.filename)
            zout.writestr(item, data if item.filename != pycs[0] else data[:8] + bytes(8) + data[16:])
    problems = validate_fmu_file(fmu).problems["standalone"]
    assert problems == [f"{pycs[0]} is not a checked-hash .pyc of the .py beside it: changed after the build"]
