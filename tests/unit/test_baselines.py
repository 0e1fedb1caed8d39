"""Tests of the baseline controller cores: computed torque (CtCore), LQR (LqrCore), OTC (OtcCore).

Closed-loop checks use the pure sampled loop ``orchestration.study.pure_loop.simulate`` (the FMU
master's call order without FMUs); the numbers in docs/baselines.md come from `sotc-cosim reproduce`.
"""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

from fmi_slave.parameters import ParameterError
from fmu_controller.computed_torque import CtCore
from fmu_numerics.elementary import hypot
from fmu_controller.lqr import LqrCore, error_system, lqr_gain
from fmu_controller.otc import OtcCore
from fmu_controller.saturation import clip_box, saturate_norm
from fmu_controller.sotc_math import (
    basis,
    basis_jacobian,
    matrix_to_weights,
    probing_signal,
)
from fmu_plant.dynamics import forward_dynamics, inertia_matrix, inverse_dynamics
from fmu_plant.trajectory import CircleTrajectory
from orchestration.run.metrics import tracking_metrics
from orchestration.study.pure_loop import simulate

STOP_TIME = 100.0  # s, the paper's run


def _random_point(rng: np.random.Generator) -> tuple[list[float], list[float]]:
    y = [rng.uniform(-3, 3), rng.uniform(-3, 3), rng.uniform(-2, 2), rng.uniform(-2, 2)]
    r = [rng.uniform(-3, 3), rng.uniform(-3, 3), rng.uniform(-2, 2), rng.uniform(-2, 2),
         rng.uniform(-1, 1), rng.uniform(-1, 1)]
    return y, r


# --- LQR --------------------------------------------------------------------------------------


@pytest.mark.parametrize("q, r", [(1.0, 1.0), (4.0, 0.5), (1.0, 100.0)])
def test_lqr_gain_solves_riccati(q, r):
    k, p = lqr_gain(q, r)
    a, b = error_system()
    theta, rm = q * np.eye(4), r * np.eye(2)
    residual = a.T @ p + p @ a - p @ b @ np.linalg.solve(rm, b.T @ p) + theta
    assert np.max(np.abs(residual)) < 1e-9 * max(1.0, np.max(np.abs(p)))
    np.testing.assert_allclose(k, np.linalg.solve(rm, b.T @ p), rtol=1e-12, atol=1e-12)
    assert np.all(np.linalg.eigvalsh(p) > 0)
    assert np.all(np.linalg.eigvals(a - b @ k).real < 0)
    # decoupled double integrators: K = [kp I, kd I] with kp = sqrt(q/r), kd = sqrt(2 kp + q/r)
    kp, kd = math.sqrt(q / r), math.sqrt(2 * math.sqrt(q / r) + q / r)
    np.testing.assert_allclose(k, np.hstack([kp * np.eye(2), kd * np.eye(2)]), rtol=1e-9, atol=1e-12)


def test_lqr_gain_matches_python_control():
    control = pytest.importorskip("control")
    a, b = error_system()
    k_ref, _, _ = control.lqr(a, b, np.eye(4), 2.0 * np.eye(2))
    k, _ = lqr_gain(1.0, 2.0)
    np.testing.assert_allclose(k, np.asarray(k_ref), rtol=1e-8, atol=1e-10)


def test_lqr_core_uses_gain_and_linearises():
    core = LqrCore(q=1.0, r=1.0, rho=1e9)
    model = core.model
    rng = np.random.default_rng(1)
    for _ in range(20):
        y, r = _random_point(rng)
        core.evaluate(0.0, y, r)
        tau1, tau2, _, sat, v1, v2 = core.outputs
        assert sat == 0.0
        x = np.array([y[0] - r[0], y[1] - r[1], y[2] - r[2], y[3] - r[3]])
        np.testing.assert_allclose([v1, v2], -core.gain @ x, rtol=1e-12, atol=1e-12)
        acc = forward_dynamics(y[1], y[2], y[3], tau1, tau2, model)
        np.testing.assert_allclose(acc, [r[4] + v1, r[5] + v2], rtol=1e-9, atol=1e-9)


# --- computed torque --------------------------------------------------------------------------


def test_computed_torque_linearises_exactly():
    """Unsaturated CT with the true model: e_ddot + kd e_dot + kp e = 0 for every state."""
    kp, kd = 16.0, 8.0
    core = CtCore(kp=kp, kd=kd, rho=1e9)
    rng = np.random.default_rng(0)
    for _ in range(50):
        y, r = _random_point(rng)
        core.evaluate(0.0, y, r)
        tau1, tau2, norm, sat = core.outputs[:4]
        assert sat == 0.0 and norm == pytest.approx(math.hypot(tau1, tau2))
        acc = forward_dynamics(y[1], y[2], y[3], tau1, tau2, core.model)
        e = np.array([y[0] - r[0], y[1] - r[1]])
        de = np.array([y[2] - r[2], y[3] - r[3]])
        dde = np.array(acc) - np.array(r[4:6])
        np.testing.assert_allclose(dde + kd * de + kp * e, 0.0, atol=1e-9)


@pytest.mark.parametrize("core_cls", [CtCore, LqrCore])
def test_saturation_bounds_the_norm_and_keeps_direction(core_cls):
    unsat = core_cls(rho=1e12)
    core = core_cls()  # rho = 4
    extreme = [
        ([50.0, -50.0, 100.0, -100.0], [0, 0, 0, 0, 0, 0]),
        ([0.0, 3.0, 1e3, 1e3], [1.0, 0.0, -1e3, 0.0, 1e4, -1e4]),
        ([1e6, -1e6, 0.0, 0.0], [0, 0, 0, 0, 0, 0]),
    ]
    for y, r in extreme:
        core.evaluate(0.0, y, r)
        unsat.evaluate(0.0, y, r)
        tau = np.array(core.outputs[:2])
        raw = np.array(unsat.outputs[:2])
        assert np.linalg.norm(tau) <= 4.0 * (1 + 1e-12)
        assert np.linalg.norm(tau) == pytest.approx(4.0, rel=1e-12)
        assert core.outputs[3] == 1.0
        assert core.outputs[2] == pytest.approx(np.linalg.norm(raw), rel=1e-12)
        np.testing.assert_allclose(tau, raw * 4.0 / np.linalg.norm(raw), rtol=1e-12)


def test_saturate_norm_passes_small_vectors():
    assert saturate_norm(1.0, 2.0, 4.0) == (1.0, 2.0, hypot(1.0, 2.0), False)
    t1, t2, n, sat = saturate_norm(30.0, -40.0, 4.0)
    assert (t1, t2, n, sat) == (pytest.approx(2.4), pytest.approx(-3.2), 50.0, True)


def test_saturation_holds_exactly_in_floating_point():
    """The shared bounds (CT/LQR eq. (CT-4), the SOTC's bound (5) and actuator limit): the radial one
    keeps the direction and lands on the circle with hypot(tau) <= bound exactly; the box clips."""
    rng = np.random.default_rng(11)
    for _ in range(5000):
        v1, v2 = rng.normal(size=2) * 10.0 ** rng.uniform(-3, 6)
        bound = 10.0 ** rng.uniform(-2, 3)
        t1, t2, norm, sat = saturate_norm(v1, v2, bound)
        assert norm == hypot(v1, v2) and sat == (norm > bound)  # the cores' own hypot
        assert math.hypot(t1, t2) <= bound
        if sat:
            assert math.hypot(t1, t2) == pytest.approx(bound, rel=1e-15)
            assert abs(t1 * v2 - t2 * v1) <= 1e-15 * bound * norm  # same direction
        else:
            assert (t1, t2) == (v1, v2)
        c1, c2, changed = clip_box(v1, v2, bound)
        assert (c1, c2) == (np.clip(v1, -bound, bound), np.clip(v2, -bound, bound))
        assert changed == (max(abs(v1), abs(v2)) > bound)


@pytest.mark.parametrize(
    "cls, params, name",
    [
        (CtCore, {"kp": -1.0}, "kp"),
        (CtCore, {"kd": 0.0}, "kd"),
        (CtCore, {"rho": float("nan")}, "rho"),
        (CtCore, {"gain": 1.0}, "gain"),
        (LqrCore, {"r": 0.0}, "r"),
        (LqrCore, {"q": -2.0}, "q"),
        (OtcCore, {"lambda1": 0.0}, "lambda1"),
        (OtcCore, {"r2": -1.0}, "r2"),
        (OtcCore, {"alpha_c": -0.1}, "alpha_c"),
        (OtcCore, {"init_weights": 0.5}, "init_weights"),
        (OtcCore, {"init_weights": 2.0}, "init_weights"),
    ],
)
def test_invalid_parameters_are_refused_by_name(cls, params, name):
    with pytest.raises(ParameterError) as info:
        cls(**params)
    assert info.value.name == name
    assert name in str(info.value)


# --- OTC --------------------------------------------------------------------------------------


def test_otc_critic_weights_represent_the_quadratic_form():
    """The OTC's critic uses the SOTC's basis (sotc_math): matrix_to_weights(P)' sigma(z) = z' P z."""
    rng = np.random.default_rng(3)
    m = rng.normal(size=(4, 4))
    p = m @ m.T
    w = matrix_to_weights(p)
    for _ in range(5):
        z = rng.normal(size=4)
        assert w @ basis(z) == pytest.approx(z @ p @ z, rel=1e-12)


def _otc_point(core: OtcCore, phi2: float, seed: int = 4):
    rng = np.random.default_rng(seed)
    y = [0.3, phi2, 0.2, -0.1]
    r = [0.3 + rng.normal(scale=0.05), phi2 + rng.normal(scale=0.05), rng.normal(scale=0.2),
         rng.normal(scale=0.2), rng.normal(scale=0.1), rng.normal(scale=0.1)]
    return y, r


def test_otc_error_system_is_affine_in_u():
    """tau = tau_a + u gives z2_dot = D^-1 u on the true model, eqs. (OTC-4)-(OTC-5)."""
    core = OtcCore(probe_amplitude=0.0)
    for phi2 in (-0.5, 0.9, 2.0):
        y, r = _otc_point(core, phi2)
        core.evaluate(1.0, y, r)
        out = dict(zip(core.output_names(), core.outputs))
        u = np.array([out["u1"], out["u2"]])
        tau = np.array([out["tau1"], out["tau2"]])
        np.testing.assert_allclose(tau, [out["tau_a1"] + u[0], out["tau_a2"] + u[1]], atol=1e-12)
        acc = np.array(forward_dynamics(y[1], y[2], y[3], tau[0], tau[1], core.model))
        lam = np.array([200.0, 50.0])
        alpha_dot = np.array(r[4:6]) - lam * (np.array(y[2:4]) - np.array(r[2:4]))
        d = inertia_matrix(y[1], core.model)
        np.testing.assert_allclose(acc - alpha_dot, np.linalg.solve(d, u), atol=1e-9)


def test_otc_riccati_initial_weights_solve_the_frozen_hjb():
    """At phi2 = init_phi2 the initial critic is the exact value of the linear problem: the
    Hamiltonian residual vanishes and the actor is the LQR u = -R^-1 g' P z."""
    core = OtcCore(probe_amplitude=0.0, init_phi2=0.7)
    p = core.frozen_riccati(0.7)
    np.testing.assert_allclose(core.wc, matrix_to_weights(p))
    np.testing.assert_allclose(core.wa, core.wc)
    y, r = _otc_point(core, 0.7)
    core.evaluate(0.0, y, r)
    out = dict(zip(core.output_names(), core.outputs))
    assert abs(out["bellman_residual"]) < 1e-9 * max(1.0, out["cost_rate"])
    lam = np.array([200.0, 50.0])
    e = np.array(y[:2]) - np.array(r[:2])
    z = np.concatenate([e, np.array(y[2:4]) - np.array(r[2:4]) + lam * e])
    g = np.zeros((4, 2))
    g[2:, :] = np.linalg.inv(inertia_matrix(0.7, core.model))
    u = -np.linalg.solve(np.diag([20.0, 100.0]), g.T @ p @ z)
    np.testing.assert_allclose([out["u1"], out["u2"]], u, rtol=1e-9, atol=1e-12)
    assert out["value"] == pytest.approx(z @ p @ z, rel=1e-12)


def test_otc_matches_its_matrix_form():
    """The scalar evaluate/advance equal (OTC-3)..(OTC-10) written with matrices."""
    core = OtcCore(alpha_s=0.5)
    rng = np.random.default_rng(7)
    core.wa = core.wa + 0.01 * rng.normal(size=10)
    checked_stab = 0
    for t in (0.1, 0.2, 1.0, 3.0):
        y, r = _random_point(rng)
        core.evaluate(t, y, r)
        out = dict(zip(core.output_names(), core.outputs))
        lam, rd = np.array([200.0, 50.0]), np.array([20.0, 100.0])
        e, de = np.array(y[:2]) - np.array(r[:2]), np.array(y[2:4]) - np.array(r[2:4])
        z = np.concatenate([e, de + lam * e])
        d = inertia_matrix(y[1], core.model)
        g = np.zeros((4, 2))
        g[2:, :] = np.linalg.inv(d)
        grad = basis_jacobian(z)
        u = -0.5 * (g.T @ grad.T @ core.wa) / rd
        z_dot = np.concatenate([-lam * z[:2] + z[2:], np.zeros(2)]) + g @ u
        omega = grad @ z_dot
        cost = z @ z + u @ (rd * u)
        tau_a = d @ (np.array(r[4:6]) - lam * de) + np.array(inverse_dynamics(y[1], y[2], y[3], 0.0, 0.0, core.model))
        probe = probing_signal(t, 0.5) if t < 0.4 else 0.0
        np.testing.assert_allclose([out["u1"], out["u2"]], u, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose([out["tau_a1"], out["tau_a2"]], tau_a, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose([out["tau1"], out["tau2"]], tau_a + u + probe, rtol=1e-12, atol=1e-12)
        assert out["cost_rate"] == pytest.approx(cost, rel=1e-12)
        assert out["bellman_residual"] == pytest.approx(omega @ core.wc + cost, rel=1e-9, abs=1e-9 * abs(cost))
        assert out["value"] == pytest.approx(core.wc @ basis(z), rel=1e-12)
        assert out["wc_norm"] == pytest.approx(np.linalg.norm(core.wc)) and out["wa_norm"] == pytest.approx(np.linalg.norm(core.wa))
        wc0, wa0, dt = core.wc.copy(), core.wa.copy(), 0.01
        ww = omega @ omega
        wc1 = wc0 - omega * ((omega @ wc0 + cost) * (1.0 - math.exp(-0.5 * ww / (ww + 1.0) ** 2 * dt)) / ww)
        wa1 = wc1 + (wa0 - wc1) * math.exp(-5.0 * dt)
        if z @ z_dot > 0.0:
            checked_stab += 1
            wa1 = wa1 + 0.5 * 0.5 * dt * (grad @ (g @ ((g.T @ z) / rd)))
        core.advance(t, dt)
        np.testing.assert_allclose(core.wc, wc1, rtol=1e-12, atol=1e-15)
        np.testing.assert_allclose(core.wa, wa1, rtol=1e-12, atol=1e-15)
    assert checked_stab >= 1  # the stabilising term of (OTC-9) was exercised


def test_otc_evaluate_is_pure_and_state_round_trips():
    core = OtcCore()
    y, r = _otc_point(core, 1.2)
    core.evaluate(0.1, y, r)
    first = list(core.outputs)
    core.evaluate(0.1, y, r)
    assert core.outputs == first
    before = core.get_state()
    core.advance(0.1, 0.01)
    after = core.get_state()
    assert after != before
    json.dumps(after)  # JSON-serialisable
    fresh = OtcCore()
    fresh.set_state(json.loads(json.dumps(after)))
    fresh.evaluate(0.2, y, r)
    core.evaluate(0.2, y, r)
    assert fresh.outputs == core.outputs
    with pytest.raises(ParameterError):
        fresh.set_state({"wc": [0.0] * 3, "wa": [0.0] * 10})


def test_otc_critic_step_reduces_the_residual():
    """One advance moves Wc along omega and shrinks the Hamiltonian residual, eq. (OTC-8)."""
    core = OtcCore(probe_amplitude=0.0, alpha_c=50.0, alpha_a=0.0, alpha_s=0.0, init_phi2=-0.5)
    y, r = _otc_point(core, 1.8)  # away from init_phi2: residual is not zero
    core.evaluate(0.0, y, r)
    delta0 = core.outputs[core.output_names().index("bellman_residual")]
    wa0 = core.wa.copy()
    core.advance(0.0, 0.01)
    core.evaluate(0.0, y, r)
    delta1 = core.outputs[core.output_names().index("bellman_residual")]
    assert abs(delta0) > 1e-6
    assert abs(delta1) < abs(delta0)
    assert np.sign(delta1) == np.sign(delta0)  # exact decay, no overshoot
    np.testing.assert_allclose(core.wa, wa0)  # alpha_a = alpha_s = 0: actor untouched


def test_otc_is_not_saturated():
    """The OTC has no torque bound: at the paper's initial state it commands far more than 4 N.m
    and flags it."""
    core = OtcCore()
    traj = CircleTrajectory()
    core.evaluate(0.0, (0.5, -0.5, 0.0, 0.0), traj.sample(0.0)[:6])
    out = dict(zip(core.output_names(), core.outputs))
    assert out["tau_norm"] > 4.0 and out["over_limit"] == 1.0


# --- closed loop on the paper's scenario ------------------------------------------------------


def test_computed_torque_tracks_the_paper_path_within_the_bound():
    run = simulate(CtCore())
    m = tracking_metrics(run.t, run.error, run.tau, 4.0, stop_time=STOP_TIME)
    assert max(m["max_abs_error_after_50s"]) < 0.02
    assert m["max_tau_norm"] <= 4.0 + 1e-9
    assert m["samples_over_limit"] == 0


def test_lqr_closed_loop_is_bounded_and_converges():
    run = simulate(LqrCore())
    m = tracking_metrics(run.t, run.error, run.tau, 4.0, stop_time=STOP_TIME)
    assert m["max_tau_norm"] <= 4.0 + 1e-9
    assert max(m["max_abs_error_after_50s"]) < 0.05


def test_otc_closed_loop_runs_and_exceeds_the_bound():
    run = simulate(OtcCore(), stop_time=20.0)
    m = tracking_metrics(run.t, run.error, run.tau, 4.0)
    assert m["samples_over_limit"] > 0  # unsaturated by design
    assert np.all(np.isfinite(run.outputs))
    # joint 1 converges with a ~14 s time constant from 0.36 rad; joint 2 is still disturbed by it
    assert max(abs(v) for v in run.error[-1]) < 0.5
    assert abs(run.error[-1][0]) < abs(run.error[0][0])


@pytest.mark.parametrize("core_cls, old", [(CtCore, "tau_max"), (LqrCore, "tau_max"), (OtcCore, "tau_limit")])
def test_a_core_refuses_the_old_torque_limit_name_and_names_rho(core_cls, old):
    with pytest.raises(ParameterError, match=f"{old}.*renamed 'rho'"):
        core_cls(**{old: 3.0})
    assert core_cls(rho=3.0).params["rho"] == 3.0
