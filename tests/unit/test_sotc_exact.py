"""The SOTC's closed forms against their definitions, computed apart from ``fmu_controller.sotc_math``: the
saturated cost (17) against the integral (13) by mpmath's quadrature (40 digits), its pieces x tanh x - ln cosh x
and ln cosh x against mpmath, and the tanh law (28) against its definition with grad zeta from sympy's
derivative of the paper's basis (section 4) and D^-1 of eq. (46) inverted exactly."""
from __future__ import annotations

import math
import re

import numpy as np
import pytest

mp = pytest.importorskip("mpmath")
sp = pytest.importorskip("sympy")

from fmu_controller import sotc_math as sm  # noqa: E402
from fmu_controller.sotc import SotcCore  # noqa: E402
from fmu_plant.dynamics import ArmParameters  # noqa: E402

mp.mp.dps = 40
EPS = 2.0**-52


def omega13(mu: float, s: float, r: float):
    """Eq. (13) for one component: 2 s r int_0^mu atanh(u / s) du, by quadrature (split where atanh is steep)."""
    nodes = [0, mu / 2, mu * 0.99, mu] if abs(mu) > 0.5 * s else [0, mu]
    return 2 * mp.mpf(s) * r * mp.quad(lambda u: mp.atanh(u / s), nodes)


Q = [0.0, 1e-9, -3e-5, 0.1, -0.5, 0.9, -0.999, 0.999999, 0.7310585786300049]
S_AND_R = [(0.6, (1.0, 0.5, 2.0, 3.0)), (4.0, (1.0, 1.0, 1.0, 1.0)), (1e-3, (7.0, 0.2, 1.0, 40.0)),
           (50.0, (0.01, 1.0, 2.5, 1.0))]


@pytest.mark.parametrize("s, r", S_AND_R)
def test_the_saturated_cost_17_is_the_integral_13(s, r):
    for k in range(0, len(Q), 2):
        q = (Q[k % len(Q)], Q[(k + 3) % len(Q)], Q[(k + 5) % len(Q)], Q[(k + 7) % len(Q)])
        mu = [qi * s for qi in q]
        exact = sum(omega13(m, s, ri) for m, ri in zip(mu, r))
        # omega_of_mu (the optimum's cost) cancels two large terms near the barrier: looser than the x form
        assert sm.omega_of_mu(mu, s, r) == pytest.approx(float(exact), rel=1e-10, abs=1e-300)
        # the same cost written in the argument x of mu = -s tanh x (28): x exact, then rounded
        x = [float(-mp.atanh(mp.mpf(qi))) for qi in q]
        exact_x = sum(omega13(float(-s * mp.tanh(xi)), s, ri) for xi, ri in zip(x, r))
        terms = [sm.omega_term_of_arg(xi, s, ri) for xi, ri in zip(x, r)]
        assert math.fsum(terms) == pytest.approx(float(exact_x), rel=1e-13, abs=1e-300)
        assert sm.omega_of_arg(x, s, r) == pytest.approx(float(exact_x), rel=1e-13, abs=1e-300)
    assert sm.omega_of_mu([s, 0.0, 0.0, 0.0], s, r) == math.inf  # the barrier of (13) at |mu| = s
    assert sm.omega_of_mu([0.0, -s * 1.0000001, 0.0, 0.0], s, r) == math.inf


def x_grid() -> list[float]:
    """0, tiny to huge magnitudes (every decade), and both sides of the branch at |x| = 1, with their negatives."""
    mags = [10.0 ** e for e in range(-300, 4, 7)] + [0.5, 0.999999, 1.0, 1.000001, 2.0, 3.7, 9.0, 17.0, 19.5, 30.0]
    near = [math.nextafter(1.0, 0.0), math.nextafter(1.0, 2.0)]
    return [0.0] + [v for m in mags + near for v in (m, -m)]


@pytest.mark.parametrize("x", x_grid())
def test_x_tanh_x_minus_ln_cosh_x_and_ln_cosh_x_against_mpmath(x):
    with mp.workdps(700):  # cosh x = 1 + x^2/2 + ... keeps x^2 down to x = 1e-300
        X = mp.mpf(x)
        log_cosh = mp.log(mp.cosh(X))
        exact = X * mp.tanh(X) - log_cosh
    got = sm._x_tanh_minus_log_cosh(x, float(mp.tanh(X)))
    assert abs(got - float(exact)) <= 8 * EPS * float(exact) + 1e-320, (x, got, float(exact))
    assert abs(sm.log_cosh(x) - float(log_cosh)) <= 4 * EPS * float(log_cosh) + 1e-320, (x, float(log_cosh))
    s, r = 0.6, 2.5
    assert sm.omega_term_of_arg(x, s, r) == pytest.approx(float(2 * s * s * r * exact), rel=1e-14, abs=1e-320)


def test_each_omega_component_has_its_own_weight():
    """omega4: R = diag(r1..r4), each component weighed by its own r_i (x and t of the same component)."""
    x, s = (0.3, -1.7, 0.01, 5.0), 0.6
    t = tuple(float(mp.tanh(v)) for v in x)
    for k in range(4):
        r = [0.0] * 4
        r[k] = 1.0
        exact = float(2 * s * s * (mp.mpf(x[k]) * mp.tanh(x[k]) - mp.log(mp.cosh(x[k]))))
        assert sm.omega4(*x, *t, s, *r) == pytest.approx(exact, rel=1e-14)


# --- the tanh law (28) -------------------------------------------------------------------------------------------

Z = sp.symbols("z1:5", real=True)
W_SYM = sp.symbols("w1:11", real=True)
# zeta(z) of section 4, as the paper lists it
ZETA = [Z[0] ** 2, Z[0] * Z[1], Z[0] * Z[2], Z[0] * Z[3], Z[1] ** 2, Z[1] * Z[2], Z[1] * Z[3], Z[2] ** 2,
        Z[2] * Z[3], Z[3] ** 2]
J = sum(w * zeta for w, zeta in zip(W_SYM, ZETA))
GRAD = sp.lambdify((Z, W_SYM), [J.diff(zi) for zi in Z], "mpmath")
HESSIAN = sp.lambdify((Z, W_SYM), sp.hessian(J, Z).tolist(), "mpmath")
ZETA_NUM = sp.lambdify((Z,), ZETA, "mpmath")
V = sp.symbols("v1:5", real=True)
DIRECTIONAL = sp.lambdify((Z, V), [sum(sp.diff(zeta, zi) * vi for zi, vi in zip(Z, V)) for zeta in ZETA], "mpmath")


def inverse_inertia(phi2: float, p: ArmParameters) -> mp.matrix:
    """D(phi)^-1 of eq. (46), inverted in 40 digits (mpmath's cos)."""
    c = mp.cos(phi2)
    D = mp.matrix([[p.p1 + 2 * p.p3 * c, p.p2 + p.p3 * c], [p.p2 + p.p3 * c, p.p2]])
    return D ** -1


def tanh_law(z, W, s, r, dinv) -> list:
    """mu = -s tanh(x), x = R^-1 g^T grad(zeta)^T W / (2 s), g = diag(I, D^-1): eq. (28) as printed."""
    grad = GRAD(z, W)
    gt = [grad[0], grad[1], dinv[0, 0] * grad[2] + dinv[1, 0] * grad[3], dinv[0, 1] * grad[2] + dinv[1, 1] * grad[3]]
    return [g / (2 * mp.mpf(s) * ri) for g, ri in zip(gt, r)]


def draws(seed: int, n: int):
    rng = np.random.default_rng(seed)
    for _ in range(n):
        yield rng.normal(size=4).tolist(), rng.normal(size=10).tolist(), float(rng.uniform(-3.0, 3.0))


@pytest.mark.parametrize("z, W, phi2", list(draws(28, 12)))
def test_the_critic_basis_its_derivatives_and_the_policy_arguments(z, W, phi2):
    p = ArmParameters()
    assert sm.basis(z) == pytest.approx([float(v) for v in ZETA_NUM(z)], rel=1e-15)
    grad = [float(v) for v in GRAD(z, W)]
    assert sm.value_gradient(z, W) == pytest.approx(grad, rel=1e-13, abs=1e-13)
    jacobian = [[float(sp.diff(zeta, zi).subs(dict(zip(Z, z)))) for zi in Z] for zeta in ZETA]
    assert sm.basis_jacobian(z).ravel() == pytest.approx(np.ravel(jacobian), rel=1e-15)
    hess = [[float(v) for v in row] for row in HESSIAN(z, W)]
    assert [list(row) for row in sm.value_hessian(W)] == hess
    assert sm.hessian_phi_times(sm.weights_buffer(W), *z) == pytest.approx(np.array(hess)[:2] @ z, rel=1e-13)
    v = [0.3, -1.1, 2.0, 0.7]
    directional = [float(e) for e in DIRECTIONAL(z, v)]
    assert sm.basis_directional(z, v) == pytest.approx(directional, rel=1e-13, abs=1e-13)
    dinv = inverse_inertia(phi2, p)
    s, r = 0.6, (1.5, 2.0, 0.5, 3.0)
    K = sm.CriticConstants(s, r, (1.0,) * 4, (1.0, 1.0), (1.0, 1.0), True, True)
    got = sm.policy_arguments(K, *z, sm.weights_buffer(W), float(dinv[0, 0]), float(dinv[0, 1]), float(dinv[1, 1]))
    assert got == pytest.approx([float(x) for x in tanh_law(z, W, s, r, dinv)], rel=1e-12, abs=1e-12)


@pytest.mark.parametrize("seed", range(6))
def test_the_controllers_saturated_inputs_are_the_tanh_law_28(seed):
    """The SOTC's own outputs mu_hat = (chi_vd*, tau*) at its z, W and measured phi2, against (28) computed here."""
    rng = np.random.default_rng(seed)
    weights = {f"W0_{k}": float(w) for k, w in enumerate(rng.normal(size=10), start=1)}
    ctrl = SotcCore(**weights)
    y = [0.3 + rng.normal(), 1.2 + rng.normal(), rng.normal(), rng.normal()]
    ref = [0.3, 1.2, *rng.normal(size=4).tolist()]
    ctrl.evaluate(1.0, y, ref)  # t past the probing window
    names = ctrl.output_names()
    z = [ctrl.outputs[names.index(f"z{k}")] for k in range(1, 5)]
    mu = [ctrl.outputs[names.index(n)] for n in ("chi_vd_star1", "chi_vd_star2", "tau_star1", "tau_star2")]
    x = tanh_law(z, ctrl.W, ctrl.s, ctrl.r, inverse_inertia(y[1], ArmParameters()))
    expected = [float(-ctrl.s * mp.tanh(v)) for v in x]
    assert mu == pytest.approx(expected, rel=1e-12, abs=1e-15)


# --- the error dynamics (6)/(7), the critic's sample, the weight step's system, the probing signal ------------------


def zdot_of_6(z, mu, fe, dinv, lam1, lam2, backstepping: bool) -> list[float]:
    """Eq. (6) with F_bar_phi of the chosen reading of chi_vd^a: -Lambda1 z_phi (backstepping) or Lambda1 z_v
    (as printed in (4)); F_bar_v = F_v - Lambda2 z_v; g = diag(I, D^-1)."""
    zp, zv = z[:2], z[2:]
    f_phi = [-lam1[i] * zp[i] for i in range(2)] if backstepping else [lam1[i] * zv[i] for i in range(2)]
    tau = [dinv[0][0] * mu[2] + dinv[0][1] * mu[3], dinv[1][0] * mu[2] + dinv[1][1] * mu[3]]
    return [f_phi[0] + mu[0] + zv[0], f_phi[1] + mu[1] + zv[1],
            fe[0] - lam2[0] * zv[0] + tau[0] - zp[0], fe[1] - lam2[1] * zv[1] + tau[1] - zp[1]]


@pytest.mark.parametrize("backstepping", [True, False])
@pytest.mark.parametrize("coupled", [True, False])
def test_the_critics_sample_is_eta_of_zdot_and_the_reward_of_12(backstepping, coupled):
    rng = np.random.default_rng(30 + 2 * backstepping + coupled)
    s, r, theta = 0.6, (1.0, 2.0, 0.5, 3.0), (1.0, 0.5, 2.0, 4.0)
    lam1, lam2 = (1.5, 0.7), (2.0, 0.3)
    K = sm.CriticConstants(s, r, theta, lam1, lam2, backstepping, coupled)
    for _ in range(5):
        z, x, fe = rng.normal(size=4).tolist(), rng.normal(size=4).tolist(), rng.normal(size=2).tolist()
        t = [math.tanh(v) for v in x]
        mu = [-s * v for v in t]
        dinv = inverse_inertia(float(rng.uniform(-3, 3)), ArmParameters())
        d = [[float(dinv[0, 0]), float(dinv[0, 1])], [float(dinv[1, 0]), float(dinv[1, 1])]]
        zdot = zdot_of_6(z, mu, fe, d, lam1, lam2, backstepping)
        # eta = grad(zeta) zdot; without the coupling (F_bar of (7) as printed): zdot less +z_v and -z_phi
        v = zdot if coupled else [zdot[0] - z[2], zdot[1] - z[3], zdot[2] + z[0], zdot[3] + z[1]]
        eta = [float(e) for e in DIRECTIONAL(z, v)]
        omega = sum(float(2 * s * s * ri * (mp.mpf(xi) * mp.tanh(xi) - mp.log(mp.cosh(xi)))) for xi, ri in zip(x, r))
        reward = sum(th * zi * zi for th, zi in zip(theta, z)) + omega
        out = sm.buffer(sm.N_BASIS + 3)
        got = sm.critic_row(K, *z, *x, *t, *mu, *fe, d[0][0], d[0][1], d[1][1], out, 3)
        assert got == pytest.approx([*zdot, reward, omega], rel=1e-12, abs=1e-14)
        assert out.tolist()[3:] == pytest.approx(eta, rel=1e-12, abs=1e-14)
        assert sm.error_rate(K, *z, *mu, *fe, d[0][0], d[0][1], d[1][1]) == pytest.approx(zdot, rel=1e-13, abs=1e-14)


def test_the_weight_steps_linear_system():
    """(I + c Gamma) W+ = W + dt dW/dt + c Gamma W, Gamma = xi eta^T (+ M) with its lower triangle mirrored."""
    rng = np.random.default_rng(31)
    W, wdot, xi, eta = (rng.normal(size=10) for _ in range(4))
    M = rng.normal(size=(10, 10))
    dt, c = 0.01, 0.5
    for with_cl in (True, False):
        g = np.outer(xi, eta) + (M if with_cl else 0.0)
        gamma = np.tril(g) + np.tril(g, -1).T
        G, rhs = sm.buffer(100), sm.buffer(10)
        sm.implicit_system(*(sm.as_buffer(a.ravel().tolist()) for a in (W, wdot, xi, eta, M)), with_cl, dt, c, G, rhs)
        assert np.array(G).reshape(10, 10) == pytest.approx(np.eye(10) + c * gamma, rel=1e-14, abs=1e-15)
        assert np.array(rhs) == pytest.approx(W + dt * wdot + c * gamma @ W, rel=1e-12, abs=1e-13)


def test_weights_and_the_matrix_of_the_same_quadratic_form():
    rng = np.random.default_rng(32)
    W, z = rng.normal(size=10), rng.normal(size=4)
    S = sm.weights_to_matrix(W)
    assert (S == S.T).all()
    assert z @ S @ z == pytest.approx(float(sum(w * zeta.subs(dict(zip(Z, z))) for w, zeta in zip(W, ZETA))), rel=1e-13)
    assert sm.matrix_to_weights(S) == pytest.approx(W, rel=1e-15)
    assert sm.matrix_to_weights(S + np.triu(S, 1) - np.tril(S, -1)) == pytest.approx(W, rel=1e-15)  # symmetrised
    assert sm.normalisation(3.0) == 16.0 and sm.normalisation(0.0) == 1.0


@pytest.mark.parametrize("time", [0.0, 0.1, 0.37, 1.0, 2.5, 17.3, 80.0])
def test_the_probing_signal_of_section_4(time):
    T_ = mp.mpf(time)
    pe = (mp.sin(T_) ** 2 * mp.cos(T_) + mp.sin(2 * T_) ** 2 * mp.cos(T_ / 10) + mp.sin(1.2 * T_) ** 2 * mp.cos(T_ / 2)
          + mp.sin(T_) ** 5 + mp.sin(1.12 * T_) ** 2 + mp.cos(2.4 * T_) * mp.sin(2.4 * T_) ** 3)
    assert sm.probing_signal(time) == pytest.approx(float(0.5 * pe), rel=1e-13, abs=1e-15)
    assert sm.probing_signal(time, 2.0) == pytest.approx(float(2 * pe), rel=1e-13, abs=1e-15)


@pytest.mark.parametrize("s, r", [(0.0, (1.0,) * 4), (0.6, (1.0, 0.0, 1.0, 1.0)), (0.6, (1.0, 1.0, -2.0, 1.0)),
                                  (1e-162, (1e-162,) * 4), (math.nan, (1.0,) * 4)])
def test_critic_constants_refuse_a_policy_denominator_2_s_r_that_is_not_positive(s, r):
    """1e-162 * 1e-162 * 2 rounds to zero: the denominator itself is checked, not its factors."""
    with pytest.raises(ValueError, match=rf"^s = {s!r} and r = {re.escape(repr(tuple(r)))} must be positive"):
        sm.CriticConstants(s, r, (1.0,) * 4, (1.0, 1.0), (1.0, 1.0), False, True)
    with pytest.raises(ValueError, match="^W has 9 weights, the critic 10$"):
        sm.weights_buffer([1.0] * 9)


def test_the_integrand_of_13():
    for u, s, r in ((0.3, 0.6, 2.0), (-3.9, 4.0, 0.5), (0.0, 1.0, 1.0)):
        assert sm.omega_integrand(u, s, r) == pytest.approx(float(2 * s * r * mp.atanh(mp.mpf(u) / s)), rel=1e-14)


@pytest.mark.parametrize("x", [1.0, -1.0, 1.5, -1.9999999999999998, 0.9999999999999999, -0.5])
def test_each_form_of_ln_cosh_holds_on_its_own_side_of_one(x):
    """ln cosh x and x tanh x - ln cosh x switch form at |x| = 1 (docstrings): below it ln(1 + 2 sinh^2(x/2)),
    from it on |x| + ln(1 + e^-2|x|) - ln 2 and ln 2 - ln(1 + e) - 2|x| e / (1 + e). Both forms are accurate
    near 1, so the switch is pinned by the bits of the form each side must use, written out here."""
    from fmu_numerics.elementary import exp, log, log1p, sinh, tanh

    a = abs(x)
    if a < 1.0:
        h = sinh(0.5 * a)
        want_log_cosh = log1p(2.0 * h * h)
        want_rest = a * abs(tanh(x)) - want_log_cosh
    else:
        e = exp(-2.0 * a)
        want_log_cosh = a + log1p(e) - log(2.0)
        want_rest = log(2.0) - log1p(e) - 2.0 * a * e / (1.0 + e)
    assert sm.log_cosh(x).hex() == want_log_cosh.hex()
    assert sm._x_tanh_minus_log_cosh(x, tanh(x)).hex() == want_rest.hex()
    assert abs(sm.log_cosh(x) - float(mp.log(mp.cosh(mp.mpf(x))))) <= 4 * EPS * sm.log_cosh(x)


def test_the_basis_jacobian_is_float_for_integer_states():
    """d zeta / dz at an integer z (as an analysis script may pass) is a float64 array of sympy's derivative."""
    J = sm.basis_jacobian([1, 2, -3, 4])
    z = sp.symbols("z1:5")
    zeta = [z[i] * z[j] for i, j in sm.BASIS_PAIRS]
    exact = sp.Matrix(zeta).jacobian(sp.Matrix(z)).subs(dict(zip(z, (1, 2, -3, 4))))
    assert J.dtype == np.float64 and J.tolist() == [[float(v) for v in row] for row in exact.tolist()]
