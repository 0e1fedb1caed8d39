"""Disturbance torques and measurement noise: the pure core, and the two FMUs in the
paper-perturbed loop (zero perturbation reproduces the paper's loop bit for bit)."""
import math

import numpy as np
import pytest

from fmu_plant.perturbation import NOISE_BLOCK, NoiseSequence, disturbance_torque
from orchestration.run.master import run
from orchestration.run.scenario import load_scenario


def test_disturbance_is_a_step_plus_a_sinusoid():
    assert disturbance_torque(0.5, 1.0, -2.0, 1.0, 0.0, 0.0, 1.0) == (0.0, 0.0)  # before the step
    d1, d2 = disturbance_torque(2.0, 1.0, -2.0, 1.0, 0.5, 0.25, 3.0)
    assert d1 == pytest.approx(1.0 + 0.5 * math.sin(6.0)) and d2 == pytest.approx(-2.0 + 0.25 * math.sin(6.0))


def test_noise_depends_on_seed_and_sample_only():
    a, b = NoiseSequence(7), NoiseSequence(7)
    forward = {k: a.at(k).copy() for k in (0, 1, NOISE_BLOCK + 3, 2)}
    backward = {k: b.at(k).copy() for k in (2, NOISE_BLOCK + 3, 1, 0)}  # another order, the same draws
    assert all(np.array_equal(forward[k], backward[k]) for k in forward)
    assert not np.array_equal(NoiseSequence(8).at(0), a.at(0))
    draws = np.array([a.at(k) for k in range(3 * NOISE_BLOCK)])
    assert abs(draws.mean()) < 0.05 and abs(draws.std() - 1.0) < 0.05
    with pytest.raises(ValueError, match="seed"):
        NoiseSequence(-1)


def test_a_row_of_draws_is_at_as_python_floats_in_any_order_of_samples():
    noise, twin = NoiseSequence(7), NoiseSequence(7)
    for k in (3, NOISE_BLOCK + 1, 2, 2 * NOISE_BLOCK, NOISE_BLOCK - 1, 0):  # blocks left and loaded again
        row = noise.row(k)
        assert all(type(x) is float for x in row) and np.array_equal(np.array(row), twin.at(k))
        noise.at(k + NOISE_BLOCK)  # another block loaded through at: the next row is made again


def test_zero_perturbation_is_the_paper_loop_and_the_fmus_apply_their_formulas(fmu_paths):
    paper = run(load_scenario("paper").with_stop_time(1.0), fmu_paths)
    base = load_scenario("paper-perturbed").with_stop_time(1.0)
    same = run(base, fmu_paths)
    assert not same.failed
    for v in ("phi1", "phi2", "dphi1", "dphi2"):
        assert np.array_equal(same.outputs["plant"][v], paper.outputs["plant"][v])
    pert = run(base.with_parameters({"noise.std_phi": 0.01, "noise.std_dphi": 0.1, "noise.seed": 5,
                                     "disturbance.step1": 0.5, "disturbance.sin2": 0.3, "disturbance.omega": 2.0}),
               fmu_paths)
    assert not pert.failed, pert.error
    noise = NoiseSequence(5)
    draws = np.array([noise.at(k) for k in range(pert.samples)])
    for i, (v, std) in enumerate((("phi1", 0.01), ("phi2", 0.01), ("dphi1", 0.1), ("dphi2", 0.1))):
        measured = pert.outputs["noise"][f"{v}_m"]
        assert np.allclose(measured - pert.outputs["plant"][v], std * draws[:, i], atol=1e-12)
    t = pert.time
    assert np.allclose(pert.outputs["disturbance"]["d1"], 0.5)
    assert np.allclose(pert.outputs["disturbance"]["d2"], 0.3 * np.sin(2.0 * t))
    assert not np.array_equal(pert.outputs["plant"]["phi1"], paper.outputs["plant"]["phi1"])
