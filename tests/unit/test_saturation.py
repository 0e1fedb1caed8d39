"""The torque-limit module shared by every controller: each handling, bounded loops, tiny bounds."""
import math
from fractions import Fraction

import numpy as np
import pytest

from fmi_slave.parameters import ParameterError
from fmu_numerics import elementary as el
from fmu_controller.computed_torque import CtCore
from fmu_controller.lqr import LqrCore
from fmu_controller.otc import OtcCore
from fmu_controller.saturation import (
    LIMIT_HANDLINGS,
    SHRINK_STEPS,
    limit_torque,
    saturate_norm,
    shrink_into_disc,
)
from fmu_controller.sotc import SotcCore

D = (3.957, 0.438, 0.196)  # inertia entries (D11, D12, D22) at phi2 = 0 (paper's constants)


def _norms(c1: float, c2: float) -> list[float]:
    """Every way a host computes ||tau||: numpy's and C's hypot, np.linalg.norm, the plain formula, Python's."""
    return [float(np.hypot(c1, c2)), float(np.linalg.norm([c1, c2])), math.sqrt(c1 * c1 + c2 * c2), math.hypot(c1, c2)]


@pytest.mark.parametrize("code", range(3))
def test_every_limited_torque_is_within_rho_by_every_norm_a_host_computes(code):
    """Property: random directions and magnitudes just above, far above and at exact multiples of rho
    (and rho itself drawn over decades): every norm of the result is <= rho in floating point. Before
    the exact disc test, numpy's hypot reported 4.000000000000001 for LQR under radial."""
    g = np.random.default_rng(100 + code)
    over = 0
    for i in range(30_000):
        rho = 4.0 if i % 2 else float(10 ** g.uniform(-3, 3))
        ang = g.uniform(0, 2 * np.pi)
        mag = (rho * (1 + g.uniform(0, 1e-9)), rho * g.uniform(1, 100), rho * int(g.integers(1, 60)), rho)[i % 4]
        c1, c2, _ = limit_torque(code, mag * math.cos(ang), mag * math.sin(ang), rho, *D)
        over += any(n > rho for n in _norms(c1, c2))
    assert over == 0


@pytest.mark.parametrize("code", range(3))
def test_every_handling_lands_in_the_disc_and_leaves_small_vectors_alone(code):
    g = np.random.default_rng(code)
    for _ in range(200):
        t1, t2 = g.normal(0, 10, 2)
        bound = float(10 ** g.uniform(-3, 2))
        c1, c2, changed = limit_torque(code, t1, t2, bound, *D)
        assert math.hypot(c1, c2) <= bound
        assert changed == (math.hypot(t1, t2) > bound or (code == 1 and max(abs(t1), abs(t2)) > bound))
    assert limit_torque(code, 0.3, -0.2, 4.0, *D) == (0.3, -0.2, False)
    assert limit_torque(3, 30.0, -20.0, 4.0, *D) == (30.0, -20.0, False)  # none


def test_the_handlings_differ_where_the_paper_is_silent():
    """At the SOTC's t = 0 feedforward (-6.84, 2.06) N.m and bound 3.543 the three readings of (5)
    deliver three different torques: radial keeps the direction, per joint clips joint 1 only
    before the cap, the D^-2 metric shifts budget to the light joint 2."""
    raw, b = (-6.84, 2.06), 4.0 - 0.6 * math.tanh(1.0)
    radial = limit_torque(0, *raw, b, *D)[:2]
    joint = limit_torque(1, *raw, b, *D)[:2]
    accel = limit_torque(2, *raw, b, *D)[:2]
    assert radial[0] / radial[1] == pytest.approx(raw[0] / raw[1])
    assert abs(accel[1]) > abs(joint[1]) > abs(radial[1])


def _first_fit(v1: float, v2: float, bound: float) -> tuple[float, float]:
    """``shrink_into_disc`` by its docstring: v if it lies in the disc, else k v for the first k = 1 - 2^(i - 53),
    i = 0 .. SHRINK_STEPS - 1, that does; in the disc: exactly (fractions) and by both rounded norms."""
    def fits(a: float, b: float) -> bool:
        exact = Fraction(a) ** 2 + Fraction(b) ** 2 <= Fraction(bound) ** 2
        return exact and el.hypot(a, b) <= bound and math.sqrt(a * a + b * b) <= bound

    if fits(v1, v2):
        return v1, v2
    for i in range(SHRINK_STEPS):
        k = 1.0 - math.ldexp(1.0, i - 53)
        if fits(v1 * k, v2 * k):
            return v1 * k, v2 * k
    raise AssertionError(f"no candidate fits: SHRINK_STEPS = {SHRINK_STEPS} must reach k = 0")


@pytest.mark.parametrize("v", [(3e-310, 4e-310), (1e-320, -1e-320), (5e-324, 5e-324), (3.0, 4.0), (1e300, 1e300)])
@pytest.mark.parametrize("bound", [0.0, 5e-324, 1e-310, 2.5, 4.999999999999999])
def test_shrink_into_disc_ends_within_its_step_bound_for_subnormal_vectors(v, bound):
    """The one-ulp walk this replaced could not move a subnormal product and never returned; the result is
    the documented one: k v for the first candidate k = 1 - 2^(i - 53), i < SHRINK_STEPS, whose k v is in
    the disc (the last candidate is 0)."""
    s1, s2 = shrink_into_disc(*v, bound)
    assert (s1, s2) == _first_fit(*v, bound)
    assert math.hypot(s1, s2) <= bound or (s1, s2) == (0.0, 0.0)
    n1, n2, _, _ = saturate_norm(*v, bound)
    assert math.hypot(n1, n2) <= bound


def test_sotc_refuses_a_sigma_or_rho_too_small_to_represent_its_law():
    for sigma, rho, name in [(1e-300, 2e-300, "sigma"), (5e-311, 1e-310, "sigma"), (1e-6, 1e-7, "rho")]:
        with pytest.raises(ParameterError, match=name):
            SotcCore(sigma=sigma, rho=rho)


@pytest.mark.parametrize("sigma,rho", [(1e-6, 2e-6), (1e-6, 1.0000001e-6), (0.6, 0.600000001), (999.0, 1000.0)])
@pytest.mark.parametrize("code", range(4))
def test_sotc_with_tiny_admissible_sigma_and_rho_returns_within_the_limit(sigma, rho, code):
    """Found by the bad-input audit: sigma and rho tiny but inside their ranges made the bound (5) loop run for ever."""
    ctrl = SotcCore(sigma=sigma, rho=rho, limit_handling=code)
    y, r = (0.5, -0.5, 0.0, 0.0), (0.4, 1.2, 0.3, -0.3, 0.1, 0.2)
    for k in range(3):
        ctrl.evaluate(k * 0.01, y, r)
        tau = ctrl.outputs[:2]
        assert all(math.isfinite(v) for v in ctrl.outputs)
        if code != 3:
            assert math.hypot(*tau) <= rho
            ta = ctrl.outputs[4:6]
            assert (max(map(abs, ta)) if code == 1 else math.hypot(*ta)) <= ctrl.bound5
        ctrl.advance(k * 0.01, 0.01)


@pytest.mark.parametrize("core,default", [(SotcCore, 2), (CtCore, 0), (LqrCore, 0), (OtcCore, 3)])
def test_every_controller_declares_limit_handling_as_an_integer_code(core, default):
    spec = {s.name: s for s in core.PARAMETER_SPECS}["limit_handling"]
    assert spec.integer and spec.default == default and (spec.low, spec.high) == (0, len(LIMIT_HANDLINGS) - 1)
    for i, name in enumerate(LIMIT_HANDLINGS):
        assert f"{i} = " in spec.description
    with pytest.raises(ParameterError, match="limit_handling"):
        core(limit_handling=1.5)
    with pytest.raises(ParameterError, match="limit_handling"):
        core(limit_handling=4)


@pytest.mark.parametrize("core", [CtCore, LqrCore, OtcCore])
def test_baselines_honour_the_limit_under_every_handling(core):
    y, r = (2.5, -2.0, 3.0, -3.0), (0.4, 1.2, 0.3, -0.3, 0.1, 0.2)
    norms = {}
    for code in range(4):
        c = core(limit_handling=code)
        c.evaluate(0.0, y, r)
        norms[code] = math.hypot(*c.outputs[:2])
    assert max(norms[0], norms[1], norms[2]) <= 4.0 + 1e-12 < norms[3]


@pytest.mark.parametrize("model,default", [("SotcController", 2), ("CtController", 0), ("LqrController", 0),
                                           ("OtcController", 3)])
def test_each_controller_fmu_declares_limit_handling_as_an_fmi_integer(fmu_paths, model, default):
    from fmpy import read_model_description

    var = {v.name: v for v in read_model_description(str(fmu_paths[model])).modelVariables}["limit_handling"]
    assert (var.type, var.causality, int(var.start)) == ("Integer", "parameter", default)
    assert (int(var.min), int(var.max)) == (0, len(LIMIT_HANDLINGS) - 1)
    assert all(f"{i} = " in var.description for i in range(len(LIMIT_HANDLINGS)))
