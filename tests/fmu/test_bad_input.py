"""Regression tests for the bad-input audit, one per example it reported (FMU level; the CLI and
scenario-file examples are in test_cli_errors.py, the property tests in test_fmu_properties.py)."""
import json
import math
import subprocess
import sys
import textwrap

import numpy as np
import pytest
from fmpy.fmi1 import FMICallException
from scipy.integrate import solve_ivp
from support import child_env
from support.fmu_driver import DrivenFmu

from fmu_plant.dynamics import (
    ArmParameters,
    IntegrationError,
    forward_dynamics,
    integrate,
    rk4_step,
)

T = 0.01
HANG_SECONDS = 20  # the audit saw minutes; a refused or working call takes well under a second


def _plant_state(plant: DrivenFmu) -> dict:
    state = plant.fmu.getFMUState()
    blob = plant.fmu.serializeFMUState(state)
    plant.fmu.freeFMUState(state)
    return json.loads(blob)


def _load(unit: DrivenFmu, state: dict) -> None:
    loaded = unit.fmu.deSerializeFMUstate(json.dumps(state).encode())
    try:
        unit.fmu.setFMUState(loaded)
    finally:
        unit.fmu.freeFMUState(loaded)


@pytest.mark.parametrize("field, value, named", [
    (("values", "substeps"), 10**9, "substeps"),   # ran doStep for minutes
    (("values", "substeps"), -5, "substeps"),      # doStep returned OK without moving the plant
    (("clock",), ["garbage", None, 1], "clock"),   # doStep returned Discard after moving the plant
    (("clock",), [0.0, 7, 0.01], "clock"),         # a clock that disagrees with the time
    (("values", "dphi1"), math.nan, "dphi1"),      # a non-finite plant state
])
def test_hostile_plant_state_is_refused_by_field_and_nothing_applied(fmu_paths, tmp_path, field, value, named):
    plant = DrivenFmu(fmu_paths["ArmPlant"], tmp_path / "plant")
    try:
        plant.initialize()
        plant.set(tau1=1.0, tau2=-0.5)
        for k in range(3):
            plant.fmu.doStep(k * T, T)
        good = _plant_state(plant)
        hostile = json.loads(json.dumps(good))
        target = hostile
        for key in field[:-1]:
            target = target[key]
        target[field[-1]] = value
        plant.messages.clear()
        with pytest.raises(FMICallException):
            _load(plant, hostile)
        assert any(s >= 3 and f"'{named}'" in m for s, m in plant.messages), plant.logged()
        assert json.dumps(_plant_state(plant)) == json.dumps(good), "a refused state changed the instance"
        plant.fmu.doStep(3 * T, T)  # and the instance goes on from where it was
    finally:
        plant.free()


def test_reference_rate_outside_what_the_maths_supports_is_refused(fmu_paths, tmp_path):
    """rate = 1e200 gave NaN accelerations with status OK; now the declared range stops it at init,
    and every output is checked where it is computed."""
    ref = DrivenFmu(fmu_paths["ReferenceTrajectory"], tmp_path / "ref")
    try:
        with pytest.raises(FMICallException):
            ref.initialize(rate=1e200)
        assert any(s >= 3 and "'rate'" in m for s, m in ref.messages), ref.logged()
        ref.fmu.reset()
        ref.initialize(rate=1e3)  # the corner of the declared range works
        for k in range(10):
            ref.fmu.doStep(k * T, T)
            assert all(math.isfinite(v) for v in ref.get(*ref.names("output")))
    finally:
        ref.free()


def _radau(state, tau, dt, p):
    def f(t, x):
        a = forward_dynamics(x[1], x[2], x[3], tau[0], tau[1], p)
        return [x[2], x[3], a[0], a[1]]
    return solve_ivp(f, (0.0, dt), state, method="Radau", rtol=1e-11, atol=1e-13).y[:, -1]


@pytest.mark.parametrize("b", [300.0, 1000.0])
def test_stiff_viscous_friction_is_integrated_stably_and_accurately(b):
    """b2 = 300 took dphi2 from 1 to 2298 rad/s in one step of fixed 4-substep RK4; ``integrate``
    takes the substeps the stiffness asks for."""
    p = ArmParameters(b1=b, b2=b)
    start = (0.5, -0.5, 0.0, 1.0)
    assert not abs(rk4_step(start, 0.0, 0.0, T, 4, p)[3]) < 10.0  # the old integrator blows up here (or NaN)
    x, ref = start, np.array(start)
    for _ in range(20):
        x = integrate(x, 0.0, 0.0, T, 4, p)
        ref = _radau(ref, (0.0, 0.0), T, p)
    assert abs(x[3]) < 1.0  # pure damping only slows the joint
    assert np.max(np.abs(np.array(x) - ref)) < 1e-6


def test_blow_up_or_too_stiff_step_is_refused_by_the_core():
    p = ArmParameters()
    with pytest.raises(IntegrationError, match="too stiff"):
        integrate((0.0, 0.0, 0.0, 0.0), 1e15, 0.0, T, 4, p)


def test_plant_fmu_with_b2_at_its_max_steps_ok_and_physically(fmu_paths, tmp_path):
    plant = DrivenFmu(fmu_paths["ArmPlant"], tmp_path / "plant")
    try:
        plant.initialize(b2=1000.0, dphi2_0=1.0)
        for k in range(10):
            plant.fmu.doStep(k * T, T)
        assert 0.0 <= plant.get("dphi2")[0] < 1.0
    finally:
        plant.free()


HANG_CHILD = textwrap.dedent("""
    import sys
    from fmpy.fmi1 import FMICallException
    from support.fmu_driver import DrivenFmu
    u = DrivenFmu(sys.argv[1], sys.argv[2])
    try:
        u.initialize(sigma=float(sys.argv[3]), rho=float(sys.argv[4]))
    except FMICallException:
        print("refused:", u.logged())
        raise SystemExit(0)
    u.set(phi1=0.5, phi2=-0.5, phi1_d=1.0, phi2_d=0.3, dphi1_d=0.1, dphi2_d=0.1)
    try:
        print("read:", repr([float(v) for v in u.get("tau1", "tau2")]))
    except FMICallException:
        print("read refused:", u.logged())
    u.free()
""")


@pytest.mark.parametrize("sigma, rho, outcome", [(1e-6, 2e-6, "read:"), (1e-300, 2e-300, "refused:")])
def test_sotc_with_tiny_sigma_and_rho_works_or_is_refused_in_bounded_time(fmu_paths, tmp_path, sigma, rho, outcome):
    """sigma and rho tiny: the first output read walked the bound (5) projection down one ulp at a time.
    At the bottom of their declared ranges the torques are read, within rho; below them (1e-300 was in range
    then) the initialization is refused naming sigma. Run in a child process so a hang cannot stall the suite."""
    try:
        done = subprocess.run(
            [sys.executable, "-c", HANG_CHILD, str(fmu_paths["SotcController"]), str(tmp_path / "sotc"),
             repr(sigma), repr(rho)], capture_output=True, text=True, timeout=HANG_SECONDS, env=child_env())
    except subprocess.TimeoutExpired:
        pytest.fail(f"no answer within {HANG_SECONDS} s")
    assert done.returncode == 0, done.stderr
    said = [line for line in done.stdout.splitlines() if line.startswith(("refused:", "read:", "read refused:"))]
    assert len(said) == 1 and said[0].startswith(outcome), done.stdout
    if outcome == "refused:":
        assert "'sigma'" in said[0], done.stdout
    else:
        tau = json.loads(said[0][len(outcome):])
        assert all(map(math.isfinite, tau)) and math.hypot(*tau) <= rho, tau


def test_a_failed_runs_summary_shows_no_metric_from_diverged_samples(fmu_dir, tmp_path, monkeypatch):
    """The audit's failed run printed an MSE of 8e103. A CT loop with absurd gains (torque 1e8 N.m)
    makes the plant refuse a step: the run fails, and its summary carries no metric."""
    from orchestration.cli import main

    monkeypatch.chdir(tmp_path)
    (tmp_path / "diverging.toml").write_text(
        'extends = "paper-ct"\nname = "diverging"\nstop_time = 2.0\n'
        "[instances.controller.parameters]\nkp = 1e6\nkd = 1e4\nrho = 1e9\n")
    summary = tmp_path / "s.json"
    assert main(["run", "diverging.toml", "--no-recording", "--summary", str(summary),
                 "--fmu-dir", str(fmu_dir)]) == 1
    s = json.loads(summary.read_text())
    assert s["status"] == "failed" and "refused" in s["error"] and "plant" in s["error"]
    assert not {"mse", "max_abs_error_last_half", "max_norm_tau", "max_abs_tau"} & set(s)
