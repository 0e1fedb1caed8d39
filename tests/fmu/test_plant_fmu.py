"""The ArmPlant FMU through fmpy: accuracy against DOP853, refusals, and bad inputs."""
import math

import numpy as np
import pytest
from fmpy.fmi1 import FMICallException
from support.fmu_driver import DrivenFmu

from fmu_plant.kinematics import arm_points
from orchestration.bench.design import dop853_zoh
from orchestration.bench.design import excitation_torque as torque_profile

T = 0.01


def test_plant_fmu_matches_dop853_over_10_s(fmu_paths, tmp_path):
    plant = DrivenFmu(fmu_paths["ArmPlant"], tmp_path / "plant")
    plant.initialize()
    states = [plant.get("phi1", "phi2", "dphi1", "dphi2")]
    for k in range(1000):
        plant.set(tau1=torque_profile(k * T)[0], tau2=torque_profile(k * T)[1])
        plant.fmu.doStep(k * T, T)
        states.append(plant.get("phi1", "phi2", "dphi1", "dphi2"))
    ee = plant.get("ee_x", "ee_y")
    plant.free()
    states = np.array(states)
    reference = dop853_zoh((0.5, -0.5, 0.0, 0.0), torque_profile, 1000)
    assert np.ptp(states[:, 0]) > 0.3 and np.ptp(states[:, 1]) > 0.3  # the profile really moves the arm
    assert np.max(np.abs(states[:, :2] - reference[:, :2])) < 1e-6
    assert np.allclose(ee, arm_points(states[-1, 0], states[-1, 1], 1.0, 1.0)[2:], atol=1e-12)


@pytest.mark.parametrize(
    "params, name",
    [({"p1": 0.0}, "p1"), ({"l2": -1.0}, "l2"), ({"p3": 1.0}, "p3"), ({"f2": math.nan}, "f2"),
     ({"phi1_0": math.inf}, "phi1_0"), ({"substeps": 0}, "substeps")],
)
def test_invalid_parameters_are_refused_at_initialization(fmu_paths, tmp_path, params, name):
    plant = DrivenFmu(fmu_paths["ArmPlant"], tmp_path / "plant")
    plant.set(**params)
    plant.fmu.setupExperiment(startTime=0.0)
    plant.fmu.enterInitializationMode()
    with pytest.raises(FMICallException) as info:
        plant.fmu.exitInitializationMode()
    assert info.value.status >= 3  # fmi2Error or fmi2Fatal (pythonfmu maps exceptions to Fatal)
    errors = [m for s, m in plant.messages if s == 3]
    assert any(f"'{name}'" in m and "range" in m for m in errors), plant.logged()
    plant.free()


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_nonfinite_torque_fails_the_step_and_keeps_the_state(fmu_paths, tmp_path, bad):
    plant = DrivenFmu(fmu_paths["ArmPlant"], tmp_path / "plant")
    plant.initialize()
    plant.set(tau1=1.0, tau2=-1.0)
    plant.fmu.doStep(0.0, T)
    before = plant.get("phi1", "phi2", "dphi1", "dphi2", "ee_x", "ee_y")
    plant.set(tau2=bad)
    with pytest.raises(FMICallException) as info:
        plant.fmu.doStep(T, T)
    assert info.value.status == 2  # fmi2Discard
    assert "tau2" in plant.logged()
    assert plant.get("phi1", "phi2", "dphi1", "dphi2", "ee_x", "ee_y") == before
    plant.set(tau2=-1.0)  # the instance stays usable: the same step now succeeds
    plant.fmu.doStep(T, T)
    assert plant.get("phi1")[0] != before[0]
    plant.free()


@pytest.mark.parametrize("step", [0.0, -0.01, math.nan])
def test_nonpositive_step_size_is_refused(fmu_paths, tmp_path, step):
    plant = DrivenFmu(fmu_paths["ArmPlant"], tmp_path / "plant")
    plant.initialize()
    with pytest.raises(FMICallException):
        plant.fmu.doStep(0.0, step)
    assert "step size" in plant.logged()
    plant.free()


