"""``fmu_controller.saturation`` against what each function is defined to return, computed apart: the disc
test in exact rational arithmetic, the acceleration-metric projection as the minimum of its objective over
the circle found by search, the box clip and its flag entry by entry, and each limit handling's code."""
from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
import pytest
from scipy.optimize import minimize_scalar

from fmu_controller import saturation as sat
from fmu_plant.dynamics import ArmParameters, inertia_entries


def exactly_in(v1: float, v2: float, bound: float) -> bool:
    return Fraction(v1) ** 2 + Fraction(v2) ** 2 <= Fraction(bound) ** 2


BEFORE_4 = math.nextafter(4.0, 0.0)
DISC_CASES = [  # (v1, v2, bound): inside and outside by the last bit, huge and subnormal parts
    (3.0, 4.0, 5.0), (3.0, 4.0, math.nextafter(5.0, 0.0)), (BEFORE_4, 1e-9, 4.0), (4.0, 1e-9, 4.0),
    (1.0, 5e-324, 1.0), (BEFORE_4, 5e-324, 4.0), (0.6, 0.8, 1.0), (-2.5, 0.0, 2.5), (2.0, -2.0, 2.8284271247461903),
    (2.0, 2.0, 2.82842712474619), (1e-170, 1e-170, 1.5e-170), (5e-324, 5e-324, 5e-324), (0.0, 0.0, 0.0),
    (1e300, 1e300, 1.5e300), (0.1, 0.2, 0.3),
]


@pytest.mark.parametrize("v1, v2, bound", DISC_CASES)
def test_in_disc_is_the_exact_test(v1, v2, bound):
    expected = exactly_in(v1, v2, bound)
    assert sat.in_disc(v1, v2, bound) == expected
    assert sat.in_disc(v1, v2, bound, math.hypot(v1, v2)) == expected  # the caller's hypot


@pytest.mark.parametrize("v1, v2, bound", DISC_CASES)
def test_saturate_norm_keeps_the_direction_and_lands_in_the_disc(v1, v2, bound):
    s1, s2, norm, changed = sat.saturate_norm(v1, v2, bound)
    assert norm == sat.hypot(v1, v2)
    assert changed == (not exactly_in(v1, v2, bound)) and exactly_in(s1, s2, bound)
    if not changed:
        assert (s1, s2) == (v1, v2)
    elif bound > 0.0 and math.hypot(v1, v2) < 1e300:  # on the circle, within rounding, same direction
        assert math.hypot(s1, s2) == pytest.approx(bound, rel=1e-15)
        assert s1 * v2 == pytest.approx(s2 * v1, rel=1e-12, abs=1e-300)


def test_shrink_takes_the_first_candidate_that_fits():
    """1.75 + 1 ulp: k = 1 - 2^-53 brings it to 1.75 exactly (k = 1 - 2^-52 would give 1.75 - 1 ulp)."""
    assert sat.shrink_into_disc(math.nextafter(1.75, 2.0), 0.0, 1.75) == (1.75, 0.0)


@pytest.mark.parametrize("v, bound, expected", [
    ((0.5, -0.5), 1.0, (0.5, -0.5, False)), ((3.0, 0.5), 1.0, (1.0, 0.5, True)), ((0.5, -3.0), 1.0, (0.5, -1.0, True)),
    ((3.0, -3.0), 1.0, (1.0, -1.0, True)), ((1.0, -1.0), 1.0, (1.0, -1.0, False)), ((-0.0, 2.0), 2.0, (-0.0, 2.0, False)),
])
def test_clip_box_clips_each_entry_and_says_if_any_changed(v, bound, expected):
    assert sat.clip_box(*v, bound) == expected


@pytest.mark.parametrize("code", range(4))
def test_limit_without_metric_follows_its_code(code):
    inside, outside, bound = (0.3, -0.4), (3.0, 0.5), 1.0
    assert sat.limit_without_metric(*inside, bound, code) == (*inside, False)
    got = sat.limit_without_metric(*outside, bound, code)
    expected = {sat.JOINT: sat.clip_box(*outside, bound), sat.NONE: (*outside, False)}.get(
        code, (*sat.saturate_norm(*outside, bound)[:2], True))
    assert got == expected


@pytest.mark.parametrize("code", range(4))
def test_limit_torque_follows_its_code(code):
    d = inertia_entries(0.4, ArmParameters())
    t, bound = (3.0, 0.5), 1.0
    got = sat.limit_torque(code, *t, bound, *d)
    if code == sat.RADIAL:
        assert got == (*sat.saturate_norm(*t, bound)[:2], True)
    elif code == sat.JOINT:
        assert got == (*sat.saturate_norm(*sat.clip_box(*t, bound)[:2], bound)[:2], True)
    elif code == sat.ACCEL:
        assert got == sat.accel_projection(*t, bound, *d)
    else:
        assert got == (*t, False)
    assert sat.limit_torque(sat.JOINT, 0.9, 0.9, bound, *d) == (*sat.saturate_norm(0.9, 0.9, bound)[:2], True)
    assert sat.limit_torque(code, 0.3, 0.2, bound, *d) == (0.3, 0.2, False)


def least_cost_on_the_circle(cost, bound) -> float:
    """min over ||tau|| = bound of ``cost``, by a search over the angle (the minimum over the disc of a convex
    objective whose unconstrained minimum lies outside it is on the circle)."""
    def on_circle(a):
        return cost(bound * np.array([math.cos(a), math.sin(a)]))

    grid = np.linspace(-math.pi, math.pi, 4001)
    best = grid[int(np.argmin([on_circle(a) for a in grid]))]
    step = grid[1] - grid[0]
    return minimize_scalar(on_circle, bounds=(best - step, best + step), method="bounded",
                           options={"xatol": 1e-13}).fun


def projections(seed: int, n: int):
    """The paper's arm, and a heavy one (its multiplier is small: D^-2 ~ 1e-6)."""
    rng = np.random.default_rng(seed)
    for k in range(n):
        p = ArmParameters() if k % 3 else ArmParameters(p1=900.0, p2=100.0, p3=50.0)
        d = inertia_entries(float(rng.uniform(-math.pi, math.pi)), p)
        angle, scale = rng.uniform(-math.pi, math.pi), 10 ** rng.uniform(0.05, 2.0)
        bound = float(10 ** rng.uniform(-2.0, 1.0))
        yield (scale * bound * math.cos(angle), scale * bound * math.sin(angle)), bound, d


@pytest.mark.parametrize("t, bound, d", list(projections(54, 24)))
def test_accel_projection_is_the_closest_torque_in_the_acceleration_metric(t, bound, d):
    """argmin (tau - t)^T D^-2 (tau - t) over ||tau|| <= bound: in the disc, on its circle, the objective's
    gradient pointing into the disc along tau (the KKT conditions, sufficient for this convex problem), and no
    point of the circle cheaper (a search over the angle)."""
    tau1, tau2, changed = sat.accel_projection(*t, bound, *d)
    tau = np.array([tau1, tau2])
    assert changed and exactly_in(tau1, tau2, bound)
    assert math.hypot(tau1, tau2) == pytest.approx(bound, rel=1e-14)
    dinv2 = np.linalg.matrix_power(np.linalg.inv(np.array([[d[0], d[1]], [d[1], d[2]]])), 2)
    pull = dinv2 @ (np.array(t) - tau)  # minus the objective's gradient / 2: must be lambda tau, lambda >= 0
    assert pull @ tau > 0.0
    assert abs(pull[0] * tau[1] - pull[1] * tau[0]) <= 1e-12 * np.linalg.norm(pull) * bound

    def cost(v):
        e = v - np.array(t)
        return float(e @ dinv2 @ e)

    assert cost(tau) <= least_cost_on_the_circle(cost, bound) * (1.0 + 1e-12)


def test_accel_projection_leaves_a_torque_in_the_disc_alone_and_a_zero_bound_at_zero():
    d = inertia_entries(1.0, ArmParameters())
    assert sat.accel_projection(0.3, -0.2, 1.0, *d) == (0.3, -0.2, False)
    assert sat.accel_projection(3.0, -2.0, 0.0, *d) == (0.0, -0.0, True)
    assert sat.accel_projection(3.0, 2.0, 5e-324, *d)[:2] == (0.0, 0.0)
    # a multiplier too large to represent (D^-2 overflows): the disc is taken as its centre
    assert sat.accel_projection(1.8, 1.5, 1.0, 1e-160, 0.0, 1e-160) == (0.0, 0.0, True)


def test_limit_handling_spec_is_the_integer_code_of_the_handlings():
    spec = sat.limit_handling_spec(2, "the torque")
    assert (spec.name, spec.default, spec.integer, spec.low, spec.high) == ("limit_handling", 2, True, 0, 3)
    assert spec.description.startswith(sat.LIMIT_HANDLING_TEXT)
    assert "applies to the torque (default 2 = accel)" in spec.description
