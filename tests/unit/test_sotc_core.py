"""Unit tests of the pure SOTC core (fmu_controller.sotc*) and of the pure closed loop.

Equation numbers refer to Dien, Luy, Lai & Hai (2023), J. Computer Science and Cybernetics.
The three 100 s closed-loop runs are shared by module-scoped fixtures (about 3 s in all).
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import integrate, optimize
from support.sotc import (
    T,
    closed_loop_steps,
    out,
    outs,
    random_inputs,
    random_weights,
    rng,
    stacked_controller,
)

from fmu_controller import sotc_math as sm
from fmu_controller.saturation import accel_projection
from fmu_controller.sotc import SotcCore
from fmu_controller.sotc_stack import SWAP_MARGIN
from fmu_controller.sotc_zv import newton_zv, solve_tanh_system
from fmu_plant.dynamics import ArmParameters, inertia_matrix
from fmu_plant.trajectory import CircleTrajectory

# --- critic basis, eq. (27) and section 4 -----------------------------------------------------------------


def test_basis_gradient_matches_finite_differences():
    g = rng(1)
    h = 1e-6
    for _ in range(20):
        z, W, v = 2.0 * g.normal(size=4), g.normal(size=10), g.normal(size=4)
        E = np.eye(4)
        jac_fd = np.column_stack([(np.array(sm.basis(z + h * e)) - np.array(sm.basis(z - h * e))) / (2 * h) for e in E])
        jac = sm.basis_jacobian(z)
        assert np.allclose(jac, jac_fd, rtol=0, atol=1e-7)
        J = lambda zz: float(W @ np.array(sm.basis(zz)))  # noqa: E731
        grad_fd = [(J(z + h * e) - J(z - h * e)) / (2 * h) for e in E]
        assert np.allclose(sm.value_gradient(z, W), grad_fd, rtol=0, atol=1e-6)
        assert np.allclose(sm.basis_directional(z, v), jac @ v, rtol=0, atol=1e-12)
        grad = lambda zz: np.array(sm.value_gradient(zz, W))  # noqa: E731
        hess_fd = np.column_stack([(grad(z + h * e) - grad(z - h * e)) / (2 * h) for e in E])
        assert np.allclose(sm.value_hessian(W), hess_fd, rtol=0, atol=1e-6)
        S = sm.weights_to_matrix(W)
        assert math.isclose(z @ S @ z, J(z), rel_tol=1e-12, abs_tol=1e-12)
        assert np.allclose(sm.matrix_to_weights(S), W, rtol=0, atol=1e-15)


@pytest.mark.parametrize("n", [9, 11])
def test_value_gradient_refuses_weights_of_another_length(n):
    # compiled, the gradient reads its weights without bounds checks: the wrapper on sequences checks
    with pytest.raises(ValueError, match=f"W has {n} weights, the critic 10"):
        sm.value_gradient((0.1, 0.2, 0.3, 0.4), [1.0] * n)


@pytest.mark.parametrize("s, r", [(0.0, (1.0, 1.0, 1.0, 1.0)), (0.6, (1.0, 0.0, 1.0, 1.0)), (1e-200, (1e-200,) * 4),
                                  (0.6, (1.0, 1.0, -1.0, 1.0)), (float("nan"), (1.0,) * 4)])
def test_critic_constants_refuse_a_policy_denominator_that_is_not_positive(s, r):
    # compiled, policy_arguments divides by 2 s r_i without a zero test
    with pytest.raises(ValueError, match="must be positive"):
        sm.CriticConstants(s, r, (1.0,) * 4, (1.0, 1.0), (1.0, 1.0), False, True)


# --- saturated cost, eqs. (13)-(17) -------------------------------------------------------------------------


@pytest.mark.parametrize("s", [0.6, 4.0])
def test_omega_closed_form_matches_quadrature_of_eq13(s):
    r = [1.0, 0.5, 2.0, 3.0]
    for q in ([0.0, 0.1, -0.5, 0.9], [-0.999, 0.999999, 0.3, -0.01]):
        mu = [qi * s for qi in q]
        quad = sum(integrate.quad(lambda u, ri=ri: sm.omega_integrand(u, s, ri), 0.0, m, limit=200)[0]
                   for m, ri in zip(mu, r))
        assert sm.omega_of_mu(mu, s, r) == pytest.approx(quad, rel=1e-8, abs=1e-12)
        x = [-math.atanh(qi) for qi in q]  # mu = -s tanh(x), the form of (28)
        assert sm.omega_of_arg(x, s, r) == pytest.approx(quad, rel=1e-8, abs=1e-12)
    assert sm.omega_of_mu([s, 0.0, 0.0, 0.0], s, r) == math.inf  # the barrier of (13) at |mu| = s


def test_omega_stays_finite_where_tanh_rounds_to_one():
    s = 0.6
    for x in (20.0, -50.0, 1e3, 1e8):
        assert math.tanh(x) ** 2 == 1.0  # ln(1 - tanh^2 x) as printed in (17) would be -inf here
        value = sm.omega_term_of_arg(x, s, 2.0)
        assert math.isfinite(value)
        # x tanh x - ln cosh x -> ln 2, so Omega -> 2 s^2 r ln 2
        assert value == pytest.approx(2.0 * s * s * 2.0 * math.log(2.0), rel=1e-9)
    assert sm.omega_term_of_arg(0.0, s, 1.0) == 0.0
    assert sm.omega_term_of_arg(1e-3, s, 1.0) == pytest.approx(s * s * 1e-6, rel=1e-5)  # ~ r mu^2 near 0


def test_omega_reuses_the_policys_tanh_to_the_bit():
    """Omega takes tanh(x) from the policy (28): |tanh x| is tanh |x| to the bit, so the term is the one
    computed from |x| alone, on both sides of x = 0 and of the branch at |x| = 1."""
    from fmu_numerics.elementary import tanh
    for x in np.linspace(-1.5, 1.5, 301).tolist() + [-0.0, 1e-300, -0.999999999, 0.5]:
        a = abs(x)
        alone = a * tanh(a) - sm.log_cosh(a) if a < 1.0 else sm._x_tanh_minus_log_cosh(a, 0.0)
        assert sm._x_tanh_minus_log_cosh(x, tanh(x)) == alone
        assert sm.omega_term(x, tanh(x), 0.6, 2.0) == sm.omega_term_of_arg(-x, 0.6, 2.0)


# --- control law (28) --------------------------------------------------------------------------------------


@pytest.mark.parametrize("saturation_form", [0, 1])
def test_control_law_minimises_the_hamiltonian(saturation_form):
    """(28) = argmin over mu of H(z, mu, grad J_hat) of (19), for the controller's own z, W and g."""
    g = rng(3 + saturation_form)
    model = ArmParameters()
    checked = 0
    for trial in range(40):
        ctrl = SotcCore(saturation_form=saturation_form, **random_weights(g, 1.0))
        y, r = random_inputs(g, 0.7)
        ctrl.evaluate(1.0, y, r)  # t >= pe_duration: no probing
        s = ctrl.s
        z = outs(ctrl, "z1", "z2", "z3", "z4")
        mu_hat = outs(ctrl, "chi_vd_star1", "chi_vd_star2", "tau_star1", "tau_star2")
        if np.max(np.abs(mu_hat)) > s * (1.0 - 1e-6):
            continue  # tanh rounded to 1: mu_hat is on the barrier of (13) in floating point
        checked += 1
        gmat = np.eye(4)
        gmat[2:, 2:] = np.linalg.inv(inertia_matrix(y[1], model))
        grad_j = np.array(sm.value_gradient(z, ctrl.W))
        # H(mu) - (terms without mu) = Omega(mu) + grad J^T g mu
        H = lambda mu: sm.omega_of_mu(mu, s, ctrl.r) + grad_j @ gmat @ mu  # noqa: E731
        assert np.all(np.abs(mu_hat) < s)
        h0 = H(mu_hat)
        for _ in range(200):
            mu = mu_hat + g.normal(size=4) * g.choice([1e-4, 1e-2, 0.3]) * s
            if np.all(np.abs(mu) < s):
                assert H(mu) >= h0 - 1e-12
        box = [(-s * (1 - 1e-12), s * (1 - 1e-12))] * 4
        best = optimize.minimize(H, np.zeros(4), method="L-BFGS-B", bounds=box)
        assert h0 <= best.fun + 1e-9
    assert checked >= 15


# --- tuning laws (30)/(31) ---------------------------------------------------------------------------------


def _replayed_rows(ctrl: SotcCore, W: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """eta_i and r_i of the ``current`` CL replay, re-evaluated one stored sample at a time: eq. (28) at
    z_i with W, zdot_i of (6)/(7), eta_i = grad(zeta(z_i)) zdot_i, r_i = z_i^T Theta z_i + Omega of (17)."""
    st = ctrl.stack
    s, rr, th = ctrl.s, ctrl.r, ctrl.theta
    E, R = [], []
    rows = {k: np.array(v).reshape(st.P, -1)[:st.count] for k, v in st.rows.items()}
    for z, (i11, i12, i22), fe in zip(rows["z"], rows["dinv"], rows["fe"]):
        gJ = sm.value_gradient(z, W)
        x = [gJ[0] / (2 * s * rr[0]), gJ[1] / (2 * s * rr[1]),
             (i11 * gJ[2] + i12 * gJ[3]) / (2 * s * rr[2]), (i12 * gJ[2] + i22 * gJ[3]) / (2 * s * rr[3])]
        mu = [-s * math.tanh(v) for v in x]
        zdot = [-ctrl.lam1[0] * z[0] + mu[0] + z[2], -ctrl.lam1[1] * z[1] + mu[1] + z[3],
                fe[0] - ctrl.lam2[0] * z[2] - z[0] + i11 * mu[2] + i12 * mu[3],
                fe[1] - ctrl.lam2[1] * z[3] - z[1] + i12 * mu[2] + i22 * mu[3]]
        E.append(sm.basis_directional(z, zdot))
        R.append(sum(t * v * v for t, v in zip(th, z)) + sm.omega_of_arg(x, s, rr))
    return np.array(E), np.array(R)


@pytest.mark.parametrize("cl_replay", [0, 1], ids=["current", "stored"])
def test_tuning_law_direction_decreases_the_residuals(cl_replay):
    """At a sample the rate of (30) is -alpha1 grad Phi for
    Phi(W) = 1/2 w (eta^T W + r)^2 + 1/2 sum_i w_i (eta_i^T W + r_i)^2, w = 1/(eta^T eta + 1)^2,
    with (eta_i, r_i) the recorded samples (``stored``) or re-evaluated with the sample's W
    (``current``, the chosen reading; then Phi is the quadratic model of that sample)."""
    ctrl = stacked_controller(cl_replay=cl_replay)
    g = rng(5)
    checked = 0
    for _ in range(5):
        y, r = random_inputs(g, 0.3)
        ctrl.evaluate(0.6, y, r)
        if out(ctrl, "tuning_law") != 30:
            continue
        checked += 1
        pend = ctrl._pending
        eta, rew = np.array(pend["eta"]), pend["r"]
        W0 = np.array(ctrl.W)
        st = ctrl.stack
        E, R = ((np.array(st.rows["eta"]).reshape(st.P, -1), np.array(st.rew)) if cl_replay == 1
                else _replayed_rows(ctrl, W0))
        w = 1.0 / (1.0 + eta @ eta) ** 2
        wi = 1.0 / (1.0 + np.einsum("ij,ij->i", E, E)) ** 2
        phi = lambda W: 0.5 * w * (eta @ W + rew) ** 2 + 0.5 * np.sum(wi * (E @ W + R) ** 2)  # noqa: E731
        grad = np.array([(phi(W0 + 1e-6 * e) - phi(W0 - 1e-6 * e)) / 2e-6 for e in np.eye(10)])
        assert np.allclose(pend["wdot"], -ctrl.alpha1 * grad, rtol=1e-5, atol=1e-9)
        assert phi(W0 + 1e-4 * np.array(pend["wdot"])) < phi(W0)
        assert abs(eta @ (W0 + 1e-4 * np.array(pend["wdot"])) + rew) <= abs(eta @ W0 + rew)  # |e1| of (29) shrinks
        # one implicit step lowers Phi too (the learning state actually moves downhill)
        ctrl.advance(0.6, T)
        assert phi(np.array(ctrl.W)) < phi(W0)
        ctrl.set_state({**ctrl.get_state(), "W": W0.tolist(), "last_inputs": None})
    assert checked >= 3


def test_replayed_cl_terms_equal_a_per_sample_reevaluation():
    """The ``current`` replay = re-evaluating eta_i and r_i at each stored z_i with W; its lambda_min
    is numpy's to within n eps trace(M), or 0 where numpy's is below the swap margin (rank-deficient)."""
    ctrl = stacked_controller()
    W = (np.array(ctrl.W) + 0.1 * rng(6).normal(size=10)).tolist()
    ctrl.stack.terms(W)
    M, b = np.array(ctrl.stack.M), np.array(ctrl.stack.b)
    M = M.reshape(10, 10)
    E = np.array(ctrl.stack.E).reshape(ctrl.stack.P, 10)[:ctrl.stack.count]
    lmin = ctrl.stack.min_eig_at(W)
    E_ref, R_ref = _replayed_rows(ctrl, W)
    Xi = E_ref / ((1.0 + np.einsum("ij,ij->i", E_ref, E_ref)) ** 2)[:, None]
    M_ref, b_ref = Xi.T @ E_ref, Xi.T @ R_ref
    assert np.allclose(E, E_ref, rtol=1e-10, atol=1e-14)
    assert np.allclose(M, M_ref, rtol=1e-10, atol=1e-14)
    assert np.allclose(b, b_ref, rtol=1e-10, atol=1e-14)
    ref, rounding = np.linalg.eigvalsh(M_ref)[0], 10 * np.finfo(float).eps * np.trace(M_ref)
    assert abs(lmin - (ref if ref >= SWAP_MARGIN * np.trace(M_ref) else 0.0)) <= rounding


def test_implicit_weight_step_survives_where_explicit_euler_diverges():
    """Explicit Euler of (30)/(31) needs T alpha1 lambda_max(Gamma) < 2; a FIFO stack of 20 similar
    samples breaks it (lambda_max <= 21/4), the linearly implicit step does not."""
    results = {}
    for integrator in (0, 1):
        ctrl = SotcCore(cl_selection=2, weight_integrator=integrator)
        rec, _ = closed_loop_steps(ctrl, 1500)
        results[integrator] = max(np.linalg.norm(ctrl.W), np.max(np.abs(np.array(rec)[:, 10:12])))
    assert results[0] < 5.0  # implicit: weights and errors stay small
    assert results[1] > 10.0  # explicit Euler: weights blow up


# --- saturation, bound (5), actuator limit -------------------------------------------------------------------


@pytest.mark.parametrize("limit_handling,actuator_form", [(2, 0), (0, 0), (1, 0), (1, 1)])
def test_saturation_bounds_hold_for_extreme_weights_and_errors(limit_handling, actuator_form):
    g = rng(7 + (limit_handling + 1) % 3)
    for trial in range(30):
        W0 = random_weights(g, 10.0 ** g.uniform(-2, 6))
        ctrl = SotcCore(limit_handling=limit_handling, actuator_form=actuator_form, **W0)
        y, r = random_inputs(g, 10.0 ** g.uniform(-1, 3))
        t = float(g.choice([0.0, 0.3, 5.0]))  # with and without probing
        ctrl.evaluate(t, y, r)
        o = np.array(ctrl.outputs)
        assert np.all(np.isfinite(o))
        tau = o[:2]
        if actuator_form == 0:
            assert math.hypot(*tau) <= ctrl.rho
        else:
            assert np.all(np.abs(tau) <= ctrl.rho)
        assert np.all(np.abs(outs(ctrl, "tau_star1", "tau_star2", "chi_vd_star1", "chi_vd_star2")) <= ctrl.sigma)
        ta, ca = outs(ctrl, "tau_a1", "tau_a2"), outs(ctrl, "chi_vd_a1", "chi_vd_a2")
        if limit_handling == 1:
            assert np.all(np.abs(ta) <= ctrl.bound5) and np.all(np.abs(ca) <= ctrl.bound5)
        else:
            assert math.hypot(*ta) <= ctrl.bound5 and math.hypot(*ca) <= ctrl.bound5
        assert out(ctrl, "Omega") >= 0.0
        ctrl.advance(t, T)
        assert np.all(np.isfinite(ctrl.W))


def test_accel_projection_is_the_constrained_optimum():
    g = rng(8)
    for _ in range(50):
        D = inertia_matrix(g.uniform(0, 2 * math.pi), ArmParameters())
        t = g.normal(size=2) * 10.0 ** g.uniform(-1, 2)
        bound = 3.5
        t1, t2, active = accel_projection(t[0], t[1], bound, D[0, 0], D[0, 1], D[1, 1])
        tau = np.array([t1, t2])
        assert math.hypot(*tau) <= bound
        assert active == (np.linalg.norm(t) > bound)
        if not active:
            assert np.array_equal(tau, t)
            continue
        A = np.linalg.inv(D) @ np.linalg.inv(D)
        ang = np.linspace(0, 2 * np.pi, 20001)
        dev = bound * np.column_stack([np.cos(ang), np.sin(ang)]) - t  # the optimum lies on the circle
        brute = np.min(np.einsum("ni,ij,nj->n", dev, A, dev))
        assert (tau - t) @ A @ (tau - t) <= brute * (1 + 1e-6) + 1e-12
        assert math.hypot(*tau) == pytest.approx(bound, rel=1e-12)


# --- feedforward (4), error system (6) -----------------------------------------------------------------------


@pytest.mark.parametrize("weight_scale", [2.0, 10.0, 1000.0])
def test_zv_satisfies_its_implicit_definition(weight_scale):
    """z_v = dphi - chi_vd* - chi_vd^a although chi_vd* depends on z_v. With large random weights,
    Newton from z_v = c alone stalls on some samples (a fold of the residual); the guess-free
    fallback must still solve every one, and ``zv_residual`` must say so."""
    g = rng(9)
    newton_stalls = 0
    for chi_a_form in (0, 1):
        for _ in range(100):
            ctrl = SotcCore(chi_a_form=chi_a_form, **random_weights(g, weight_scale))
            y, r = random_inputs(g)
            ctrl.evaluate(1.0, y, r)
            zv = outs(ctrl, "z3", "z4")
            chi_star = outs(ctrl, "chi_vd_star1", "chi_vd_star2")
            if chi_a_form == 0:  # backstepping reading: chi_vd^a = dphi_d - Lambda1 z_phi, bounded before the solve
                chi_a = outs(ctrl, "chi_vd_a1", "chi_vd_a2")
                assert np.allclose(chi_a, np.array(r[2:4]) - outs(ctrl, "z1", "z2"))
                c, a = np.array(y[2:4]) - chi_a, 1.0
            else:  # as printed: chi_vd^a = dphi_d + Lambda1 z_v (Lambda1 = I), the bound (5) applied after
                chi_a = np.array(r[2:4]) + zv
                c, a = np.array(y[2:4]) - np.array(r[2:4]), 2.0
            residual = np.max(np.abs(zv - (np.array(y[2:4]) - chi_star - chi_a)))
            assert residual <= 1e-11
            assert 0.0 <= out(ctrl, "zv_residual") <= 1e-11
            assert np.allclose(outs(ctrl, "z1", "z2"), np.array(y[:2]) - np.array(r[:2]), atol=0)
            # plain Newton from z_v = c / a, the solver's first try
            hess = sm.value_hessian(ctrl.W)
            *_, f1, f2 = newton_zv(ctrl.constants, *outs(ctrl, "z1", "z2"), c[0], c[1], a, a, ctrl.W, hess[0][2],
                                   hess[0][3], hess[1][2], hess[1][3], c[0] / a, c[1] / a, False)
            newton_stalls += max(abs(f1), abs(f2)) > 1e-6
    if weight_scale >= 10.0:
        assert newton_stalls > 0  # the fallback was needed (and worked) on some samples


def test_tanh_system_solver_finds_a_solution_without_a_guess():
    """x = x0 + K tanh(x) always has a solution; solve_tanh_system must find one for any K, including
    decoupled and nearly decoupled systems and large couplings (the raw answer is bisection-accurate;
    the controller polishes it with Newton)."""
    g = rng(12)
    for scale in (0.1, 1.0, 10.0, 1e3, 1e6):
        for trial in range(60):
            x0 = g.normal(size=2) * scale * g.uniform()
            K = g.normal(size=(2, 2)) * scale
            if trial % 5 == 1:
                K[0, 1] = 0.0
            if trial % 5 == 2:
                K[1, 0] = K[0, 1] = 0.0
            if trial % 5 == 3:
                K[0, 1], K[1, 0] = 1e-13, -1e-14
            t1, t2 = solve_tanh_system(x0[0], x0[1], K[0, 0], K[0, 1], K[1, 0], K[1, 1])
            u = np.array([t1, t2])
            assert np.all(np.abs(u) <= 1.0)
            assert np.max(np.abs(u - np.tanh(x0 + K @ u))) <= 1e-6


def test_probing_enters_both_joint_torques_during_its_window():
    y, r = [0.5, -0.5, 0.0, 0.0], list(CircleTrajectory().sample(0.0)[:6])
    for t, active in ((0.3, True), (0.4, False)):
        ctrl = SotcCore()
        ctrl.evaluate(t, y, r)
        pe = sm.probing_signal(t, 0.5) if active else 0.0
        assert out(ctrl, "pe_active") == float(active)
        assert out(ctrl, "pe") == pe
        if not out(ctrl, "tau_limited"):
            tau = np.array(ctrl.outputs[:2])
            parts = outs(ctrl, "tau_star1", "tau_star2") + outs(ctrl, "tau_a1", "tau_a2")
            assert np.allclose(tau - parts, [pe, pe], atol=1e-14)
    by_hand = 0.5 * (math.sin(1) ** 2 * math.cos(1) + math.sin(2) ** 2 * math.cos(0.1) + math.sin(1.2) ** 2 * math.cos(0.5)
                     + math.sin(1) ** 5 + math.sin(1.12) ** 2 + math.cos(2.4) * math.sin(2.4) ** 3)
    assert sm.probing_signal(1.0) == pytest.approx(by_hand, rel=1e-15)


def test_chain_rule_dchi_matches_the_recorded_chi_vd(paper_run):
    """tau^a of (4) needs dchi_vd/dt; the analytic chain rule must agree with central differences of
    the chi_vd the controller actually produced (after the transient, where (5) is inactive)."""
    _, res = paper_run
    chi = np.column_stack([res.out("chi_vd_star1") + res.out("chi_vd_a1"),
                           res.out("chi_vd_star2") + res.out("chi_vd_a2")])
    central = (chi[2:] - chi[:-2]) / (2 * T)
    used = np.column_stack([res.out("dchi_vd1"), res.out("dchi_vd2")])[1:-1]
    late = res.t[1:-1] >= 3.0
    rms_err = np.sqrt(np.mean((used[late] - central[late]) ** 2, axis=0))
    rms = np.sqrt(np.mean(central[late] ** 2, axis=0))
    assert np.all(rms_err < 0.01 * rms)


# --- parameters -----------------------------------------------------------------------------------------------


def test_evaluate_gives_numpy_no_floating_point_warning_so_its_fmu_enters_no_errstate():
    """``SILENT_FLOATING_POINT``: the FMU calls evaluate without ``np.errstate``, so no input, however
    absurd, may make numpy warn (on the host's stderr); an exception is the FMU's to refuse, as before,
    but inputs up to 1e30 are evaluated to finite outputs."""
    assert SotcCore.SILENT_FLOATING_POINT
    g, ctrl = rng(11), stacked_controller()
    outcomes = []
    with np.errstate(all="raise"):  # a warning would be a FloatingPointError here
        for scale in (1.0, 1e3, 1e8, 1e30, 1e154, 1e300):
            for _ in range(5):
                y, r = random_inputs(g, scale)
                try:
                    ctrl.evaluate(0.7, y, r)
                except FloatingPointError:
                    raise
                except (ArithmeticError, ValueError):  # the FMU refuses these (fmu_controller.slave._evaluate)
                    outcomes.append((scale, "refused"))
                    continue
                outcomes.append((scale, "finite" if all(map(math.isfinite, ctrl.outputs)) else "not finite"))
    assert all(what == "finite" for scale, what in outcomes if scale <= 1e30), outcomes
