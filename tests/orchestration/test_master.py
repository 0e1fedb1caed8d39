"""The fmpy master: closed loop through the FMUs, call order, failures, scenario errors."""
import json
import math
from pathlib import Path

import numpy as np
import pytest

from orchestration.cli import main
from orchestration.run.master import run
from orchestration.run.scenario import ScenarioError, load_scenario


def test_paper_ct_tracks_the_circle_within_the_torque_bound(fmu_dir, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # the installed command works from any folder
    summary_file = tmp_path / "s.json"
    assert main(["run", "paper-ct", "--summary", str(summary_file), "--fmu-dir", str(fmu_dir)]) == 0
    s = json.loads(summary_file.read_text())
    assert s["scenario"] == "paper-ct" and s["controller"] == "CtController"
    assert s["steps"] == 10000 and s["step_size"] == 0.01 and s["stop_time"] == 100.0
    assert s["max_norm_tau"] <= 4.0
    assert max(s["max_abs_error_last_half"]) < 0.02
    for key in ("mse", "max_abs_tau", "wall_time_s"):
        assert key in s


def test_torque_at_t_is_computed_from_the_measurement_at_t(fmu_paths):
    """Re-evaluate the CT law offline on the recorded samples: it must give the recorded torque
    for the same sample (no one-step delay anywhere in the loop)."""
    from fmu_controller.computed_torque import CtCore

    result = run(load_scenario("paper-ct").with_stop_time(2.0), fmu_paths)
    core = CtCore()
    p, r, c = result.outputs["plant"], result.outputs["reference"], result.outputs["controller"]
    for k in (0, 1, 57, 150, 200):
        y = [p[n][k] for n in ("phi1", "phi2", "dphi1", "dphi2")]
        ref = [r[n][k] for n in ("phi1_d", "phi2_d", "dphi1_d", "dphi2_d", "ddphi1_d", "ddphi2_d")]
        core.evaluate(result.time[k], y, ref)
        assert core.outputs[:2] == [c["tau1"][k], c["tau2"][k]]
    assert np.array_equal(result.time, np.arange(201) * 0.01)


def _scenario_file(tmp_path: Path, extra: str) -> Path:
    path = tmp_path / "sc.toml"
    path.write_text('extends = "paper-ct"\nname = "custom"\nstop_time = 1.0\n' + extra)
    return path


def test_invalid_parameter_fails_the_run_with_the_reason_and_frees_everything(fmu_paths, tmp_path):
    sc = load_scenario(str(_scenario_file(tmp_path, "[instances.plant]\nparameters = { p1 = -1.0 }\n")))
    result = run(sc, fmu_paths)
    assert result.failed and result.samples == 0
    assert "'p1'" in result.error
    # the next run in the same process is unaffected
    ok = run(load_scenario("paper-ct").with_stop_time(0.5), fmu_paths)
    assert not ok.failed and ok.samples == 51


def test_a_failed_run_does_not_stop_the_others(fmu_dir, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)  # its recordings go to tmp_path/recordings
    # every value inside its declared range, but p3 = 1 makes D(phi) singular: the plant FMU refuses it
    bad = _scenario_file(tmp_path, "[instances.plant]\nparameters = { p3 = 1.0 }\n")
    code = main(["run", str(bad), "paper-ct", "--stop-time", "0.5", "--fmu-dir", str(fmu_dir)])
    out, err = capsys.readouterr()
    assert code == 1
    assert "custom: FAILED" in err and "'p3'" in err
    assert "paper-ct" in out and "ok" in out.split("paper-ct", 1)[1].splitlines()[0]
    # a value outside its declared range is refused before anything runs: one line, exit 2
    outside = _scenario_file(tmp_path, "[instances.controller]\nparameters = { kp = -5.0 }\n")
    assert main(["run", str(outside), "paper-ct", "--stop-time", "0.5", "--fmu-dir", str(fmu_dir)]) == 2
    out, err = capsys.readouterr()
    assert err.count("\n") == 1 and "'kp' = -5.0 is outside its valid range" in err and out == ""


@pytest.mark.parametrize(
    "extra, message",
    [
        ("[instances.plant]\nparameters = { nosuch = 1.0 }\n", "nosuch"),
        ('[[connection]]\nfrom = "plant.nope"\nto = "controller.phi1"\n', "nope"),
        ('[[connection]]\nfrom = "plant.phi1"\nto = "controller.phi1"\n', "fed twice"),
        ("[instances.extra]\nfmu = \"NoSuchModel\"\n", "NoSuchModel"),
    ],
)
def test_scenario_errors_name_the_culprit(fmu_paths, tmp_path, extra, message):
    with pytest.raises(ScenarioError, match=message):
        run(load_scenario(str(_scenario_file(tmp_path, extra))), fmu_paths)


def test_stop_time_must_be_whole_steps():
    with pytest.raises(ScenarioError, match="whole number of steps"):
        load_scenario("paper-ct").with_stop_time(1.005)
    assert math.isclose(load_scenario("paper-ct").with_stop_time(3.0).steps, 300)


def test_results_carry_every_parameter_the_fmus_ran_with(fmu_paths):
    result = run(load_scenario("paper-ct").with_stop_time(0.1), fmu_paths)
    assert result.parameters["controller"]["kp"] == 25.0  # a default the scenario does not set
    assert result.parameters["plant"]["phi2_0"] == -0.5 and result.parameters["plant"]["substeps"] == 4
    assert result.parameters["reference"]["phase"] == math.pi / 2


def test_fmu_messages_are_stamped_with_their_sample(fmu_paths, tmp_path):
    from orchestration.run.master import _Clock, _LogSink

    bad = run(load_scenario(str(_scenario_file(tmp_path, "[instances.plant]\nparameters = { p1 = -1.0 }\n"))), fmu_paths)
    assert bad.failed and [r.sample for r in bad.logs if "'p1'" in r.message] == [-1]  # set-up
    clock, logs = _Clock(), []
    sink = _LogSink("plant", logs, clock)
    clock.sample = 7
    sink.append((2, "discarded"))
    assert (logs[0].instance, logs[0].status, logs[0].sample) == ("plant", "DISCARD", 7)


def test_an_fmu_that_cannot_be_loaded_fails_its_run_only(fmu_paths, tmp_path):
    import zipfile

    broken = tmp_path / "ArmPlant.fmu"
    with zipfile.ZipFile(fmu_paths["ArmPlant"]) as src, zipfile.ZipFile(broken, "w") as dst:
        for item in src.infolist():
            if not item.filename.startswith("binaries/"):
                dst.writestr(item, src.read(item))
    result = run(load_scenario("paper-ct").with_stop_time(0.1), {**fmu_paths, "ArmPlant": broken})
    assert result.failed and result.samples == 0 and "set-up" in result.error
    assert not run(load_scenario("paper-ct").with_stop_time(0.1), fmu_paths).failed
