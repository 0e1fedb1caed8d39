"""The plant's step as ``fmu_plant.dynamics`` documents it: ``integrate`` is ``rk4_step`` with max(the substeps
asked, ``substeps_needed``) substeps, refuses a step that needs more than MAX_SUBSTEPS, a non-finite result and
one whose sqrt(2 E) grows beyond what the torque allows; ``substeps_needed`` is its docstring's bound; the
parameter checks say what they refuse. The checks on the result are reached through the interpreted module
(``support.interpreted``) with its RK4 replaced, which works in either build."""
from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest
from support.interpreted import interpreted

from fmi_slave.parameters import ParameterError
from fmu_plant import dynamics as dyn

T = 0.01
P = dyn.ArmParameters()


def bound_of_the_docstring(phi2, dphi1, dphi2, dt, p, tau_norm=0.0) -> int:
    """substeps_needed's docstring: n = ceil(dt (damping + position) / SUBSTEP_STIFFNESS), capped at MAX + 1."""
    k, w, p3 = p.inv_inertia, abs(dphi1) + abs(dphi2), p.p3
    friction = max(p.f1 + p.b1, p.f2 + p.b2)
    damping = k * (friction + 4.0 * p3 * w)
    bias = friction + max(p.b1, p.b2) * w + 3.0 * p3 * w * w
    position = math.sqrt(2.0 * p3 * k * k * (tau_norm + bias) + 3.0 * p3 * k * w * w)
    n = dt * (damping + position) / dyn.SUBSTEP_STIFFNESS
    return min(math.ceil(n), dyn.MAX_SUBSTEPS + 1)


ARMS = [P, dyn.ArmParameters(b1=3.0, b2=7.0, f1=1.0, f2=20.0), dyn.ArmParameters(p3=0.1, b1=9.0)]
STATES = [(0.5, -0.5, 0.0, 0.0), (1.0, 2.0, 30.0, -40.0), (0.1, -3.0, -5.0, 200.0), (0.0, 0.7, 1e3, 1.0),
          (0.0, 0.3, 1e4, -1e4)]  # the last needs more than MAX_SUBSTEPS


@pytest.mark.parametrize("p", ARMS)
@pytest.mark.parametrize("state", STATES)
def test_substeps_needed_is_its_documented_bound(p, state):
    for tau_norm in (0.0, 4.0, 1e4):
        assert dyn.substeps_needed(*state[1:], T, p, tau_norm) == bound_of_the_docstring(*state[1:], T, p, tau_norm)
    assert dyn.substeps_needed(*state[1:], T, p) == bound_of_the_docstring(*state[1:], T, p)


@pytest.mark.parametrize("p", ARMS)
@pytest.mark.parametrize("state", STATES[:3])
@pytest.mark.parametrize("tau, least", [((1.5, -0.7), 4), ((3.0, 2.0), 1), ((-0.2, 0.1), 40)])
def test_integrate_is_rk4_with_the_substeps_the_stiffness_asks(p, state, tau, least):
    n = max(least, dyn.substeps_needed(*state[1:], T, p, math.hypot(*tau)))
    assert dyn.integrate(state, *tau, T, least, p) == dyn.rk4_step(state, *tau, T, n, p)


def test_integrate_takes_at_most_max_substeps():
    state = (0.5, -0.5, 0.3, 0.1)
    assert dyn.integrate(state, 1.0, 1.0, T, dyn.MAX_SUBSTEPS, P) == dyn.rk4_step(state, 1.0, 1.0, T,
                                                                                    dyn.MAX_SUBSTEPS, P)
    with pytest.raises(dyn.IntegrationError) as info:
        dyn.integrate((0.0, 0.0, 1.0, -2.0), 1e15, 0.0, T, 4, P)
    assert str(info.value) == (f"the arm at dphi = (1, -2) rad/s with |tau| = 1e+15 N.m is too stiff for a 0.01 s step: "
                               f"it needs more than {dyn.MAX_SUBSTEPS} RK4 substeps (shorten the communication step)")


@pytest.fixture
def dynamics_py(monkeypatch):
    """The interpreted dynamics module, whose rk4_step a test may replace."""
    (module,) = interpreted("fmu_plant.dynamics")
    return module


@pytest.mark.parametrize("k", range(4))
def test_a_non_finite_result_is_refused(dynamics_py, monkeypatch, k):
    result = [0.5, -0.5, 0.0, 0.0]
    result[k] = math.nan if k % 2 else math.inf
    monkeypatch.setattr(dynamics_py, "rk4_step", lambda *args: tuple(result))
    p = dynamics_py.ArmParameters()
    with pytest.raises(dynamics_py.IntegrationError, match="^the integration gave a non-finite state$"):
        dynamics_py.integrate((0.5, -0.5, 0.0, 0.0), 0.0, 0.0, T, 4, p)


def test_a_step_whose_energy_grows_beyond_the_torques_is_refused(dynamics_py, monkeypatch):
    """sqrt(2 E) may grow by dt ||tau|| sqrt(||D^-1||), 5 % and 1e-9 more; just beyond is a blow-up."""
    p = dynamics_py.ArmParameters()
    start, tau = (0.5, -0.5, 0.3, -0.2), (1.5, 2.0)
    before = math.sqrt(2.0 * dynamics_py.kinetic_energy(start[1], start[2], start[3], p))
    allowed = (before + T * math.hypot(*tau) * math.sqrt(p.inv_inertia)) * 1.05 + 1e-9

    def scaled(speed):  # the start's velocity scaled to sqrt(2 E) = speed
        k = speed / before
        return start[0], start[1], start[2] * k, start[3] * k

    for speed, refused in ((allowed * (1 - 1e-12), False), (allowed * (1 + 1e-12), True)):
        new = scaled(speed)
        monkeypatch.setattr(dynamics_py, "rk4_step", lambda *args, new=new: new)
        if refused:
            with pytest.raises(dynamics_py.IntegrationError, match="blew up: sqrt"):
                dynamics_py.integrate(start, *tau, T, 4, p)
        else:
            assert dynamics_py.integrate(start, *tau, T, 4, p) == new


def test_parameter_checks_say_what_they_refuse():
    with pytest.raises(ParameterError) as info:
        dyn.ArmParameters(p1=1.0, p2=0.5, p3=0.6)
    assert str(info.value) == ("parameter 'p3': p2 (p1 - p2) = 0.25 must exceed p3^2 = 0.36, otherwise D(phi) is "
                               "singular for some phi (valid range: p3 < sqrt(p2 (p1 - p2)))")
    with pytest.raises(ParameterError) as info:
        dyn.ArmParameters(p1=2.0, p2=1.0, p3=math.sqrt(1.0 - 1e-7))
    assert str(info.value) == ("parameter 'p2': D(phi) is nearly singular: its smallest eigenvalue can be 2e-08 kg.m2, "
                               "below 1e-06 (raise p2, or p1 - p2, or lower p3)")
    for changes, name in (({"f2": 900.0}, "f2"), ({"b1": 900.0}, "b1"), ({"f1": 900.0, "b1": 1.0}, "b1"),
                          ({"f1": 900.0, "f2": 900.0}, "f1"), ({"f1": 900.0, "f2": 500.0, "b2": 450.0}, "b2")):
        with pytest.raises(ParameterError) as info:
            dyn.ArmParameters(p1=0.5, p2=0.05, p3=0.14, **changes)
        assert info.value.name == name and "makes the arm too stiff" in str(info.value), changes
        joint = name[1]
        assert f"lower f{joint}/b{joint}" in str(info.value)
    inv = dyn.ArmParameters(p1=0.5, p2=0.05, p3=0.14).inv_inertia
    with pytest.raises(ParameterError) as info:
        dyn.ArmParameters(p1=0.5, p2=0.05, p3=0.14, f1=900.0, b1=1.0)
    assert f"friction 901 N.m.s/rad against inertia down to {1.0 / inv:.3g} kg.m2 makes" in str(info.value)
    p = dyn.ArmParameters(p1=2.0, p2=0.5, p3=0.3, f1=1.0, f2=2.0, b1=3.0, b2=4.0)
    assert p.coefficients == (2.0, 0.5, 0.3, 1.0, 2.0, 3.0, 4.0)
    assert p.inv_inertia == pytest.approx((2.0 + 0.5 + 0.6) / (0.5 * 1.5 - 0.09), rel=1e-15)


def test_from_mapping_builds_the_parameters_and_names_an_unknown_one():
    assert dyn.ArmParameters.from_mapping({"p1": 4.0, "b2": 0.5}) == dyn.ArmParameters(p1=4.0, b2=0.5)
    with pytest.raises(ParameterError) as info:
        dyn.ArmParameters.from_mapping({"p1": 4.0, "mass": 1.0})
    assert info.value.name == "mass"
    assert str(info.value) == "parameter 'mass': unknown arm parameter; known: b1, b2, f1, f2, l1, l2, p1, p2, p3"


@pytest.mark.parametrize("phi2", [0.0, 0.7, -2.5, 3.1])
def test_solve_inertia_inverts_d(phi2):
    d11, d12, d22 = dyn.inertia_entries(phi2, P)
    r = np.array([1.3, -0.4])
    expected = np.linalg.solve(np.array([[d11, d12], [d12, d22]]), r)
    assert dyn.solve_inertia(phi2, *r, P) == pytest.approx(expected, rel=1e-13)


def test_an_arm_whose_step_at_rest_needs_exactly_max_substeps_is_accepted():
    """The construction's check is substeps_needed at rest (dphi = 0) against MAX_SUBSTEPS, inclusive."""
    base = dict(p1=0.5, p2=0.05, p3=0.14)
    inv = dyn.ArmParameters(**base).inv_inertia

    def needed(f1):
        arm = SimpleNamespace(coefficients=(0.5, 0.05, 0.14, f1, 2.35, 0.0, 0.0), inv_inertia=inv, p3=0.14)
        return dyn.substeps_needed(0.0, 0.0, 0.0, T, arm, 0.0)  # at rest, no torque

    lo, hi = 0.0, 1000.0  # needed(lo) <= MAX_SUBSTEPS < needed(hi)
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if needed(mid) <= dyn.MAX_SUBSTEPS else (lo, mid)
    assert needed(lo) == dyn.MAX_SUBSTEPS and needed(hi) == dyn.MAX_SUBSTEPS + 1
    dyn.ArmParameters(**base, f1=lo)
    with pytest.raises(ParameterError, match="too stiff"):
        dyn.ArmParameters(**base, f1=hi)


def test_a_step_whose_energy_reaches_exactly_the_allowed_growth_is_accepted(dynamics_py, monkeypatch):
    """The check is ``speed_after <= allowed``: at equality the step stands (a mutant with ``<`` refuses it).
    The velocities were searched ulp by ulp so that sqrt(2 E) is ``allowed`` to the bit; the test asserts that."""
    p = dynamics_py.ArmParameters()
    start, tau = (0.5, -0.5, 0.3, -0.2), (1.5, 2.0)
    before = math.sqrt(2.0 * dynamics_py.kinetic_energy(start[1], start[2], start[3], p))
    allowed = (before + T * math.hypot(*tau) * math.sqrt(p.inv_inertia)) * 1.05 + 1e-9
    new = (start[0], start[1], 0.35274878714628755, -0.23516585809752502)
    assert math.sqrt(2.0 * dynamics_py.kinetic_energy(new[1], new[2], new[3], p)) == allowed
    monkeypatch.setattr(dynamics_py, "rk4_step", lambda *args: new)
    assert dynamics_py.integrate(start, *tau, T, 4, p) == new


def test_an_arm_whose_inverse_inertia_bound_is_exactly_the_limit_is_accepted():
    """``inv <= MAX_INVERSE_INERTIA``: p3 so small that it rounds away, p1 and p2 chosen so that
    (p1 + p2) / (p2 (p1 - p2)) is 1e6 to the bit; the next smaller p1 crosses it and is refused."""
    p1, p2, small = 5.999999800000079e-06, 2.0000002e-06, dict(p3=1e-300, f1=1e-9, f2=1e-9)
    assert dyn.ArmParameters(p1=p1, p2=p2, **small).inv_inertia == dyn.MAX_INVERSE_INERTIA
    with pytest.raises(ParameterError, match="nearly singular"):
        dyn.ArmParameters(p1=math.nextafter(p1, 0.0), p2=p2, **small)
