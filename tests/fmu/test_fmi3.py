"""The FMI 3.0 FMUs are the FMI 2.0 wrappers presented through fmi3_slave: the same refusals, the
same input checks, the same all-or-nothing FMU states, and the same numbers, with FMUs of both
versions side by side in this one process (both exporters' binaries loaded at once)."""
from __future__ import annotations

import math
import zipfile
from pathlib import Path
from xml.etree import ElementTree

import numpy as np
import pytest
from fmpy.fmi1 import FMICallException

from orchestration.run.fmi3_direct import FmuInstance3
from orchestration.run.fmi_direct import FmuInstance
from orchestration.run.master import run
from orchestration.run.scenario import ScenarioError, load_scenario

SECONDS = 2.0


@pytest.fixture
def instances():
    """Instances made by a test, freed even when it fails."""
    made = []
    yield made
    for instance in made:
        instance.free()


def _open(cls, path: Path, made: list):
    made.append(cls(path, "t"))
    return made[-1]


def test_arrays_types_and_interfaces(fmi3_paths):
    root = ElementTree.fromstring(zipfile.ZipFile(fmi3_paths["SotcController"]).read("modelDescription.xml"))
    assert root.get("fmiVersion") == "3.0"
    dims = {v.get("name"): [d.get("start") for d in v.iter("Dimension")] for v in root.find("ModelVariables")}
    assert dims["W"] == ["10"] and dims["z"] == ["4"] and dims["tau"] == ["2"] and dims["phi"] == ["2"]
    assert root.find("ModelVariables/Int32[@name='limit_handling']") is not None  # an FMI 2 Integer is an Int32
    arm = ElementTree.fromstring(zipfile.ZipFile(fmi3_paths["ArmPlant"]).read("modelDescription.xml"))
    assert arm.find("ModelExchange") is not None and arm.find("CoSimulation") is not None
    assert arm.find("ModelVariables/Float64[@name='phi']").get("unit") == "rad"
    assert root.get("version") and root.get("description")  # the FMI 2 class's
    page = zipfile.ZipFile(fmi3_paths["SotcController"]).read("documentation/index.html").decode()
    assert "FMI 3.0 co-simulation FMU" in page and "<td>W</td><td>Float64[10]</td>" in page


def test_a_parameter_is_refused_with_the_fmi2_message(fmu_paths, fmi3_paths, instances):
    messages = []
    for cls, paths in ((FmuInstance, fmu_paths), (FmuInstance3, fmi3_paths)):
        instance = _open(cls, paths["ArmPlant"], instances)
        with pytest.raises(FMICallException):
            instance.initialize(p1=-1.0)
        messages.append(next(m for _, m in instance.messages if "p1" in m))
    assert "parameter 'p1': -1 is outside the valid range (0, 1000]" in messages[0]
    assert messages[1] == messages[0].replace("fmi2ExitInitializationMode", "fmi3ExitInitializationMode")


def test_a_non_finite_input_is_discarded_and_the_state_kept(fmi3_paths, instances):
    arm = _open(FmuInstance3, fmi3_paths["ArmPlant"], instances)
    arm.initialize()
    before = arm.get("phi1", "phi2", "dphi1", "dphi2")
    arm.set(tau1=math.nan)
    with pytest.raises(FMICallException):  # fmi3Discard
        arm.fmu.doStep(0.0, 0.01)
    assert any("input 'tau1' is nan" in m for _, m in arm.messages), arm.logged()
    assert arm.get("phi1", "phi2", "dphi1", "dphi2") == before
    arm.set(tau1=0.0)
    arm.fmu.doStep(0.0, 0.01)  # the same instance steps on once the input is finite


def _closed_loop(paths: dict[str, Path], seconds: float = SECONDS, scenario: str = "paper"):
    result = run(load_scenario(scenario).with_stop_time(seconds), paths)
    assert not result.failed, result.error
    return result


def test_fmi2_and_fmi3_fmus_side_by_side_give_the_fmi2_run_bit_for_bit(fmu_paths, fmi3_paths):
    """The FMI 3 plant and controller with the FMI 2 reference, in one run (both binaries loaded in
    this process), then everything FMI 3: every output of every sample equals the FMI 2 run."""
    fmi2 = _closed_loop(fmu_paths)
    mixed = _closed_loop({**fmu_paths, "ArmPlant": fmi3_paths["ArmPlant"], "SotcController": fmi3_paths["SotcController"]})
    fmi3 = _closed_loop(fmi3_paths)
    for other in (mixed, fmi3):
        assert other.outputs.keys() == fmi2.outputs.keys()
        for instance, outputs in fmi2.outputs.items():
            assert list(other.outputs[instance]) == list(outputs)  # the same scalar series, in order
            for name, values in outputs.items():
                assert np.array_equal(other.outputs[instance][name], values, equal_nan=True), (instance, name)


def test_fmu_state_replays_and_a_corrupt_state_changes_nothing(fmi3_paths, instances):
    ctl = _open(FmuInstance3, fmi3_paths["SotcController"], instances)
    ctl.initialize()
    fmu3 = ctl._fmu3
    drive = {"phi1": 0.4, "phi2": -0.3, "phi1_d": 0.5, "phi2_d": -0.5}
    names = ctl.names("output")

    def steps(k0: int, n: int) -> list[list[float]]:
        rows = []
        for k in range(k0, k0 + n):
            ctl.set(**{name: value + 0.01 * k for name, value in drive.items()})
            rows.append(ctl.get(*names))
            ctl.fmu.doStep(k * 0.01, 0.01)
        return rows

    steps(0, 20)
    state = fmu3.getFMUState()
    saved = fmu3.serializeFMUState(state)
    first = steps(20, 15)
    fmu3.setFMUState(state)
    assert steps(20, 15) == first
    fmu3.setFMUState(fmu3.deserializeFMUState(saved))
    assert steps(20, 15) == first
    now = ctl.get(*names)
    corrupt = saved.replace(b'"mode"', b'"mood"')
    with pytest.raises(FMICallException):
        fmu3.setFMUState(fmu3.deserializeFMUState(corrupt))
    assert any("must have exactly the fields" in m for _, m in ctl.messages), ctl.logged()
    assert ctl.get(*names) == now  # refused all or nothing: the instance is as it was
    fmu3.freeFMUState(state)


def test_the_model_exchange_arm_in_the_loop_stays_within_1e_6_of_rk4(fmi3_paths, tmp_path):
    scenario = tmp_path / "paper-me.toml"
    scenario.write_text('extends = "paper"\nname = "paper-me"\n[instances.plant]\ninterface = "ModelExchange"\n')
    rk4 = _closed_loop(fmi3_paths)
    exchange = _closed_loop(fmi3_paths, scenario=str(scenario))
    for name in ("phi1", "phi2"):
        gap = np.max(np.abs(exchange.outputs["plant"][name] - rk4.outputs["plant"][name]))
        assert 0.0 < gap < 1e-6, (name, gap)  # another integrator, the same dynamics


def test_model_exchange_needs_an_fmi3_fmu(fmu_paths, tmp_path):
    scenario = tmp_path / "paper-me.toml"
    scenario.write_text('extends = "paper"\nname = "paper-me"\n[instances.plant]\ninterface = "ModelExchange"\n')
    with pytest.raises(ScenarioError, match="needs an FMI 3.0 FMU.*--fmi 3"):
        run(load_scenario(str(scenario)).with_stop_time(0.1), fmu_paths)


def test_compare_and_reproduce_run_the_fmi3_fmus(fmi3_paths, tmp_path, capsys):
    """The batch commands with --fmi 3 (shortened): every run ok, the outputs written."""
    from orchestration.cli import main
    from orchestration.fmu_build.compiled import switched

    folder = str(next(iter(fmi3_paths.values())).parent)
    with switched(False):  # the fixture's build: nothing is rebuilt
        assert main(["compare", "paper", "paper-ct", "--fmi", "3", "--stop-time", "0.2", "--fmu-dir", folder,
                     "--recording", str(tmp_path / "c.rrd")]) == 0
        assert main(["reproduce", "--fmi", "3", "--stop-time", "0.1", "--fmu-dir", folder, "--out", str(tmp_path),
                     "--recording", str(tmp_path / "r.rrd")]) == 0
    assert (tmp_path / "c.rrd").stat().st_size > 0 and (tmp_path / "table1.csv").is_file()
    assert "FAILED" not in capsys.readouterr().err
