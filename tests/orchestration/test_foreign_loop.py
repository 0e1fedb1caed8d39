"""The benchmark's loop (orchestration.study.foreign_loop): a controller FMU from any tool against the arm and
reference cores in-process equals `sotc-cosim run` of the scenario with that FMU as its controller, bit for bit,
run after run of one loaded FMU (reset between them), and falls back to a new instance where the reset fails.
The example of examples/pd_controller (plain C, FMI 2.0) is built once for the module."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from fmpy.fmi1 import FMICallException
from support.example_controller import PORTS, built_fmu

from fmu_plant.dynamics import ArmParameters
from fmu_plant.trajectory import CircleTrajectory
from orchestration.run.master import run
from orchestration.run.scenario import load_scenario
from orchestration.study.foreign_loop import ForeignLoop
from orchestration.study.pure_loop import Perturbation, metrics

STOP = 2.0
# Kp 10, Kd 3, its own bound 10 N.m: the actuator cuts; Kp 60, Kd 15 within 4 N.m: another run
GAINS = ({"Kp": 10.0, "Kd": 3.0, "umax": 10.0}, {"Kp": 60.0, "Kd": 15.0, "umax": 4.0})
# a point of the held-out kind: another arm, a disturbance, measurement noise (tests/fmu/test_pure_loop_perturbed.py)
PLANT = {"p1": 3.473 * 1.15, "p2": 0.196 * 0.85, "p3": 0.242 * 1.1, "f1": 8.45 * 0.9, "f2": 2.35 * 1.2}
NOISE = {"std_phi": 3e-4, "std_dphi": 3e-3, "seed": 11}
DISTURBANCE = {"step1": 0.3, "step2": -0.2, "step_time": 1.0, "sin1": 0.1, "sin2": 0.25, "omega": 2.0}


@pytest.fixture(scope="module")
def example(tmp_path_factory) -> Path:
    return built_fmu(tmp_path_factory.mktemp("pd"))


def _master_run(fmu: Path, parameters: dict, folder: Path, fmu_paths, extends: str = "paper", overrides=None,
                ports: dict = PORTS):
    """`sotc-cosim run`'s master on ``extends`` with the example as its controller (docs/benchmark.md)."""
    text = (f'extends = "{extends}"\nname = "mine"\nstop_time = {STOP}\n[instances.controller]\nfmu = "{fmu}"\n'
            "ports = { " + ", ".join(f'{k} = "{v}"' for k, v in ports.items()) + " }\n"
            "parameters = { " + ", ".join(f"{k} = {v!r}" for k, v in parameters.items()) + " }\n")
    (folder / "mine.toml").write_text(text)
    result = run(load_scenario(str(folder / "mine.toml")).with_parameters(overrides or {}), fmu_paths)
    assert not result.failed, result.error
    return result


def _assert_equal(mine, fmu) -> None:
    """The loop's samples are the master's, bit for bit: the arm's states, the torques written and got, the cuts."""
    plant, ctrl = fmu.outputs["plant"], fmu.outputs["controller"]
    assert np.array_equal(mine.t, fmu.time)
    assert np.array_equal(mine.y, np.column_stack([plant[k] for k in ("phi1", "phi2", "dphi1", "dphi2")]))
    assert mine.names == ("tau1", "tau2", "u1", "u2", "torque_cut")
    for name in mine.names:
        assert np.array_equal(mine.out(name), ctrl[name]), name
    assert mine.cuts == int(np.count_nonzero(ctrl["torque_cut"]))


def test_runs_of_one_loaded_fmu_equal_the_master_bit_for_bit(example, tmp_path, fmu_paths):
    with ForeignLoop(example, PORTS) as loop:
        runs = [loop.run(p, stop_time=STOP) for p in GAINS]
        assert loop.logs == []  # the example logs nothing on a good run
        perturbed = loop.run(GAINS[1], stop_time=STOP, arm=ArmParameters(**PLANT), phi0=(-1.0, 1.5),
                             perturbation=Perturbation(**DISTURBANCE, **NOISE))
        assert loop.reinstantiated == 0
    for parameters, mine in zip(GAINS, runs):
        _assert_equal(mine, _master_run(example, parameters, tmp_path, fmu_paths))
    assert runs[0].cuts > 0 and runs[1].cuts == 0  # the actuator acted in one and not the other
    assert not np.array_equal(runs[0].y, runs[1].y)
    assert metrics(runs[0])["max_tau_norm"] <= 4.0
    overrides = {**{f"plant.{k}": v for k, v in PLANT.items()}, **{f"noise.{k}": v for k, v in NOISE.items()},
                 **{f"disturbance.{k}": v for k, v in DISTURBANCE.items()}, "plant.phi1_0": -1.0, "plant.phi2_0": 1.5}
    _assert_equal(perturbed, _master_run(example, GAINS[1], tmp_path, fmu_paths, "paper-perturbed", overrides))


def test_inputs_gathered_from_several_places_of_the_samples_equal_the_master(example, tmp_path, fmu_paths):
    """Without the measured velocities mapped, the FMU's inputs are no single run of the samples' buffer: the loop
    sets them through the master's own ``_Inputs.push``, which gathers them (its dq1 dq2 keep their start values)."""
    ports = {k: v for k, v in PORTS.items() if k not in ("dphi1", "dphi2")}
    with ForeignLoop(example, ports) as loop:
        assert loop.calls[1] == ()  # the gathering push takes no arguments: the raw set would
        mine = loop.run(GAINS[1], stop_time=STOP)
    _assert_equal(mine, _master_run(example, GAINS[1], tmp_path, fmu_paths, ports=ports))


def test_a_run_without_samples_has_the_same_metrics_and_cuts_bit_for_bit(example):
    """A trial's run (``samples=False``) keeps no record of the FMU's own outputs; what ``pure_loop.metrics`` and the
    cut count read is the full run's, sample for sample: a run where the actuator cuts, one where it does not, and
    a perturbed point (noise: the measurement is not the state)."""
    points = [(GAINS[0], {}), (GAINS[1], {}),
              (GAINS[1], {"arm": ArmParameters(**PLANT), "perturbation": Perturbation(**DISTURBANCE, **NOISE)})]
    cuts = []
    with ForeignLoop(example, PORTS) as loop:
        for parameters, point in points:
            full = loop.run(parameters, stop_time=STOP, **point)
            cuts.append(full.cuts)
            lean = loop.run(parameters, stop_time=STOP, samples=False, **point)
            assert lean.names == ("tau1", "tau2", "torque_cut") and lean.cuts == full.cuts
            assert np.array_equal(lean.t, full.t) and np.array_equal(lean.y, full.y)
            assert np.array_equal(lean.ref, full.ref)
            for name in lean.names:
                assert np.array_equal(lean.out(name), full.out(name)), name
            for late_from in (50.0, 1.0):
                assert metrics(lean, late_from) == metrics(full, late_from)
    assert cuts[0] > 0 and cuts[1] == 0 and loop.reinstantiated == 0


def test_the_reference_is_taken_once_per_trajectory_step_and_length(example):
    """The loop keeps the reference's samples of its last trajectory, step and length for the runs that share them:
    each run still gets its own trajectory's samples, in arrays of its own."""
    other = CircleTrajectory(radius=0.4)
    with ForeignLoop(example, PORTS) as loop:
        first = loop.run(GAINS[1], stop_time=0.5)
        first.ref[0, 0] = 99.0  # a run's arrays are its own: the next run's reference is not touched
        runs = [(loop.run(GAINS[1], stop_time=0.5), CircleTrajectory()),
                (loop.run(GAINS[1], stop_time=0.5, trajectory=other), other),
                (loop.run(GAINS[1], stop_time=0.3, step=0.005), CircleTrajectory()),
                (loop.run(GAINS[1], stop_time=0.5), CircleTrajectory())]
    for run, trajectory in runs:
        assert np.array_equal(run.ref, [trajectory.sample(t) for t in run.t])
    assert not np.array_equal(runs[0][0].y, runs[1][0].y)


def test_a_failed_reset_instantiates_the_fmu_again(example, monkeypatch):
    with ForeignLoop(example, PORTS) as loop:
        first = loop.run(GAINS[0], stop_time=0.5)
        old = loop.ported

        def refused():
            raise FMICallException(function="fmi2Reset", status=3)

        monkeypatch.setattr(old.fmu, "reset", refused)
        again = loop.run(GAINS[0], stop_time=0.5)
        assert loop.reinstantiated == 1 and loop.ported is not old and not old.instantiated
        assert np.array_equal(again.y, first.y) and np.array_equal(again.outputs, first.outputs)


def test_an_fmi3_controller_runs_as_its_fmi2_twin(example, tmp_path):
    """The same C as FMI 3.0 (``tests/support/fmi3_pd``: the contract's own names, no map) gives the example's
    runs bit for bit, reset between parameter sets as well (fmi3Reset)."""
    from support import fmi3_pd

    with ForeignLoop(fmi3_pd.build(tmp_path)) as loop3, ForeignLoop(example, PORTS) as loop2:
        for parameters in GAINS:
            mine, twin = loop3.run(parameters, stop_time=1.0), loop2.run(parameters, stop_time=1.0)
            assert mine.names == ("tau1", "tau2", "tau1_fmu", "tau2_fmu", "torque_cut")
            assert np.array_equal(mine.y, twin.y) and np.array_equal(mine.outputs, twin.outputs)
            assert mine.cuts == twin.cuts
        assert loop3.reinstantiated == 0
