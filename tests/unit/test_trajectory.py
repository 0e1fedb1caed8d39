"""The reference of eqs. (47)/(48): analytic derivatives against finite differences."""
import math

import numpy as np
import pytest

from fmi_slave.parameters import ParameterError
from fmu_plant.kinematics import arm_points
from fmu_plant.trajectory import CircleTrajectory

TRAJ = CircleTrajectory()


@pytest.mark.parametrize("t", [0.0, 1.3, 5.0, 12.7, 40.0, 99.9])
def test_derivatives_match_finite_differences(t):
    h = 1e-5
    s = np.array(TRAJ.sample(t))
    plus, minus = np.array(TRAJ.sample(t + h)), np.array(TRAJ.sample(t - h))
    central = (plus - minus) / (2 * h)
    assert np.allclose(central[0:2], s[2:4], atol=1e-8)  # d phi_d / dt
    assert np.allclose(central[2:4], s[4:6], atol=1e-7)  # d dphi_d / dt


@pytest.mark.parametrize("t", [0.0, 3.0, 7.5])
def test_joint_reference_reaches_the_desired_point(t):
    phi1, phi2, *_, x, y = TRAJ.sample(t)
    assert np.allclose(arm_points(phi1, phi2, 1.0, 1.0)[2:], (x, y), atol=1e-12)
    assert math.isclose(x, 1 + 0.5 * math.sin(0.5 * t + math.pi / 2), abs_tol=1e-15)
    assert math.isclose(y, 1 + 0.5 * math.cos(0.5 * t + math.pi / 2), abs_tol=1e-15)


def test_unreachable_circle_is_refused():
    with pytest.raises(ParameterError, match="radius"):
        CircleTrajectory(radius=0.9)
