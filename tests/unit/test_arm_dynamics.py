"""The arm core: eq. (46) structure, kinematics (48)/(49), parameter validation."""
import math

import numpy as np
import pytest

from fmi_slave.parameters import ParameterError
from fmu_plant.dynamics import (
    ArmParameters,
    coriolis_matrix,
    forward_dynamics,
    inertia_entries,
    inertia_matrix,
    inverse_dynamics,
)
from fmu_plant.kinematics import arm_points, inverse_kinematics

RNG = np.random.default_rng(7)
P = ArmParameters()


def test_paper_values_are_the_defaults():
    assert (P.p1, P.p2, P.p3, P.f1, P.f2, P.l1, P.l2) == (3.473, 0.196, 0.242, 8.45, 2.35, 1.0, 1.0)


@pytest.mark.parametrize("trial", range(20))
def test_dD_dt_minus_2H_is_skew_symmetric(trial):
    phi2, dphi1, dphi2 = RNG.uniform(-math.pi, math.pi), *RNG.uniform(-3, 3, 2)
    h = 1e-6
    # dD/dt along the motion = dD/dphi2 * dphi2, by central differences of D
    dD = (inertia_matrix(phi2 + h, P) - inertia_matrix(phi2 - h, P)) / (2 * h) * dphi2
    N = dD - 2 * coriolis_matrix(phi2, dphi1, dphi2, P)
    assert np.allclose(N, -N.T, atol=1e-8)
    assert abs(N[0, 1]) > 0 or abs(math.sin(phi2)) < 1e-9  # not trivially zero


def test_inertia_is_positive_definite_everywhere():
    for phi2 in np.linspace(-math.pi, math.pi, 181):
        assert np.all(np.linalg.eigvalsh(inertia_matrix(phi2, P)) > 0)


@pytest.mark.parametrize("trial", range(10))
def test_forward_and_inverse_dynamics_are_inverse(trial):
    phi2, w1, w2, t1, t2 = RNG.uniform(-3, 3, 5)
    a1, a2 = forward_dynamics(phi2, w1, w2, t1, t2, P)
    assert np.allclose(inverse_dynamics(phi2, w1, w2, a1, a2, P), (t1, t2), atol=1e-12)


@pytest.mark.parametrize("trial", range(20))
def test_forward_of_inverse_kinematics_is_identity(trial):
    r = RNG.uniform(0.1, 1.95)
    ang = RNG.uniform(-math.pi, math.pi)
    x, y = r * math.cos(ang), r * math.sin(ang)
    phi1, phi2 = inverse_kinematics(x, y, 1.0, 1.0)
    assert np.allclose(arm_points(phi1, phi2, 1.0, 1.0)[2:], (x, y), atol=1e-12)
    assert phi2 >= 0.0  # the branch eq. (48) selects


def test_inverse_kinematics_refuses_unreachable_points():
    with pytest.raises(ValueError, match="out of reach"):
        inverse_kinematics(2.5, 0.0, 1.0, 1.0)


@pytest.mark.parametrize(
    "changes, name",
    [({"p1": 0.0}, "p1"), ({"p2": -1.0}, "p2"), ({"l1": 0.0}, "l1"), ({"f1": math.nan}, "f1"),
     ({"p3": 0.9}, "p3"), ({"l2": math.inf}, "l2")],
)
def test_invalid_parameters_are_refused_naming_the_parameter(changes, name):
    with pytest.raises(ParameterError) as info:
        ArmParameters(**changes)
    assert info.value.name == name and f"'{name}'" in str(info.value)


def test_singular_inertia_condition_is_exact():
    # p2 (p1 - p2) = p3^2 exactly: det D = 0 at phi2 = 0, so it must be refused
    p1, p2 = 1.0, 0.5
    with pytest.raises(ParameterError, match="singular"):
        ArmParameters(p1=p1, p2=p2, p3=math.sqrt(p2 * (p1 - p2)))
    d11, d12, d22 = inertia_entries(0.0, ArmParameters(p1=p1, p2=p2, p3=0.99 * math.sqrt(p2 * (p1 - p2))))
    assert d11 * d22 - d12**2 > 0
