"""The arm's equations of motion derived here, independently of ``fmu_plant.dynamics``: the Lagrangian of a
planar two-link arm with masses, lengths, centres of mass and inertias (sympy), its Euler-Lagrange equations
with the friction of eq. (46) as generalised forces, against every term the module computes at seeded random
states. The paper's varrho_1..3 are what the physical arm gives (``varrho``):

    varrho_1 = m1 lc1^2 + I1 + m2 (l1^2 + lc2^2) + I2,  varrho_2 = m2 lc2^2 + I2,  varrho_3 = m2 l1 lc2,

point masses at the link ends being lc_i = l_i, I_i = 0. The arm moves in a horizontal plane: gravity, along
-z, does no work on it, and eq. (46)'s G is the friction f_i tanh(dphi_i) (+ b_i dphi_i, the module's viscous
addition)."""
from __future__ import annotations

import functools

import numpy as np
import pytest

sp = pytest.importorskip("sympy")

from fmu_plant import dynamics as dyn  # noqa: E402

q1, q2, w1, w2, a1, a2, t = sp.symbols("q1 q2 w1 w2 a1 a2 t", real=True)
m1, m2, l1, l2, c1, c2, i1, i2, g, f1, f2, b1, b2 = sp.symbols("m1 m2 l1 l2 lc1 lc2 I1 I2 g f1 f2 b1 b2", real=True)
PHYSICAL = (m1, m2, l1, l2, c1, c2, i1, i2)
RTOL = 1e-12


def _derive():
    """(D, C, G_gravity, tau) as sympy expressions in q, w = dq/dt, a = d2q/dt2 and the arm's constants."""
    f = [sp.Function("p1")(t), sp.Function("p2")(t)]  # the joint angles as functions of time
    th1, th2 = f[0], f[0] + f[1]  # absolute angles of the links (phi2 is the elbow's relative angle)
    centres = [sp.Matrix([c1 * sp.cos(th1), c1 * sp.sin(th1), 0]),
               sp.Matrix([l1 * sp.cos(th1) + c2 * sp.cos(th2), l1 * sp.sin(th1) + c2 * sp.sin(th2), 0])]
    speeds = [r.diff(t) for r in centres]
    kinetic = (m1 * speeds[0].dot(speeds[0]) + i1 * th1.diff(t) ** 2
               + m2 * speeds[1].dot(speeds[1]) + i2 * th2.diff(t) ** 2) / 2
    potential = g * (m1 * centres[0][2] + m2 * centres[1][2])  # gravity along -z, the plane horizontal
    lagrangian = kinetic - potential
    q, w, a = (q1, q2), (w1, w2), (a1, a2)
    to_symbols = {f[i].diff(t, 2): a[i] for i in range(2)}
    to_symbols.update({f[i].diff(t): w[i] for i in range(2)})
    to_symbols.update({f[i]: q[i] for i in range(2)})

    def plain(e):
        return sp.expand(e.subs(to_symbols))

    friction = [f1 * sp.tanh(w1) + b1 * w1, f2 * sp.tanh(w2) + b2 * w2]  # eq. (46), each joint its own gains
    tau = [plain(lagrangian.diff(f[i].diff(t)).diff(t) - lagrangian.diff(f[i])) + friction[i] for i in range(2)]
    T = plain(kinetic)
    D = sp.Matrix(2, 2, lambda i, j: sp.trigsimp(T.diff(w[i]).diff(w[j])))
    gravity = sp.Matrix([plain(potential.diff(f[i])) for i in range(2)])
    # Christoffel form of the Coriolis matrix: C_kj = sum_i c_ijk w_i, c_ijk = (dD_kj/dq_i + dD_ki/dq_j - dD_ij/dq_k)/2
    C = sp.Matrix(2, 2, lambda k, j: sp.expand(sum(
        (D[k, j].diff(q[i]) + D[k, i].diff(q[j]) - D[i, j].diff(q[k])) * w[i] / 2 for i in range(2))))
    return D, C, gravity, sp.Matrix(tau)


@functools.cache
def derived():
    """``_derive``'s expressions, once per process (at the first test, not when every worker collects)."""
    return _derive()


@functools.cache
def numeric():
    """``derived`` as functions of (q1, q2, w1, w2, a1, a2, the physical constants, g, f1, f2, b1, b2)."""
    args = (q1, q2, w1, w2, a1, a2, *PHYSICAL, g, f1, f2, b1, b2)
    return tuple(sp.lambdify(args, e.tolist(), "math") for e in derived())


def varrho(m1, m2, l1, l2, lc1, lc2, I1, I2) -> tuple[float, float, float]:
    return m1 * lc1 ** 2 + I1 + m2 * (l1 ** 2 + lc2 ** 2) + I2, m2 * lc2 ** 2 + I2, m2 * l1 * lc2


def arms(seed: int, n: int):
    """n physical arms (half of them point masses at the link ends) with their ArmParameters, friction drawn
    apart for each joint; seeded, so every run draws the same."""
    rng = np.random.default_rng(seed)
    for k in range(n):
        mass, length = rng.uniform(0.5, 5.0, 2), rng.uniform(0.3, 1.5, 2)
        if k % 2:
            centre, inertia = length.copy(), np.zeros(2)
        else:
            centre, inertia = length * rng.uniform(0.2, 0.9, 2), rng.uniform(0.01, 0.5, 2)
        phys = (*mass, *length, *centre, *inertia)
        fr = rng.uniform(0.0, 10.0, 4)  # f1, f2, b1, b2, all different
        p1, p2, p3 = varrho(*phys)
        params = dyn.ArmParameters(p1=p1, p2=p2, p3=p3, f1=fr[0], f2=fr[1], b1=fr[2], b2=fr[3], l1=length[0],
                                   l2=length[1])
        yield phys, tuple(fr), params, rng.uniform(-4.0, 4.0, (8, 6))  # states (q1, q2, w1, w2, a1, a2)


CASES = [(phys, fr, p, s) for phys, fr, p, states in arms(54, 8) for s in states]


def reference(phys, fr, s, gravity=9.81):
    args = (*s, *phys, gravity, *fr)
    D, C, grav, tau = (np.array(f(*args), dtype=float) for f in numeric())
    return D, C, grav.ravel(), tau.ravel()


def test_the_physical_arm_gives_the_papers_matrices_in_varrho():
    """The derivation itself, symbolically: D and C of the Lagrangian are eq. (46)'s in varrho_1..3."""
    D_SYM, C_SYM, GRAVITY_SYM, _ = derived()
    v1, v2, v3 = varrho(*PHYSICAL)
    papers_d = sp.Matrix([[v1 + 2 * v3 * sp.cos(q2), v2 + v3 * sp.cos(q2)], [v2 + v3 * sp.cos(q2), v2]])
    papers_h = sp.Matrix([[-v3 * sp.sin(q2) * w2, -v3 * sp.sin(q2) * (w1 + w2)], [v3 * sp.sin(q2) * w1, 0]])
    assert sp.simplify(D_SYM - papers_d) == sp.zeros(2, 2)
    assert sp.simplify(C_SYM - papers_h) == sp.zeros(2, 2)
    assert sp.simplify(GRAVITY_SYM) == sp.zeros(2, 1)


@pytest.mark.parametrize("phys, fr, p, s", CASES[::4])
def test_inertia_coriolis_friction_and_gravity_terms(phys, fr, p, s):
    D, C, gravity, _ = reference(phys, fr, s)
    q1_, q2_, w1_, w2_ = s[:4]
    d11, d12, d22 = dyn.inertia_entries(q2_, p)
    np.testing.assert_allclose([[d11, d12], [d12, d22]], D, rtol=RTOL, atol=RTOL)
    np.testing.assert_allclose(dyn.inertia_matrix(q2_, p), D, rtol=RTOL, atol=RTOL)
    h11, h12, h21 = dyn.coriolis_entries(q2_, w1_, w2_, p)
    np.testing.assert_allclose([[h11, h12], [h21, 0.0]], C, rtol=RTOL, atol=RTOL * np.abs(C).max())
    np.testing.assert_allclose(dyn.coriolis_matrix(q2_, w1_, w2_, p), C, rtol=RTOL, atol=RTOL * np.abs(C).max())
    friction = [fr[0] * np.tanh(w1_) + fr[2] * w1_, fr[1] * np.tanh(w2_) + fr[3] * w2_]
    np.testing.assert_allclose(dyn.friction_torque(w1_, w2_, p), friction, rtol=RTOL)
    np.testing.assert_allclose(dyn.bias_torque(q2_, w1_, w2_, p), C @ [w1_, w2_] + gravity + friction,
                               rtol=RTOL, atol=RTOL * 10.0)
    assert dyn.kinetic_energy(q2_, w1_, w2_, p) == pytest.approx(0.5 * np.array([w1_, w2_]) @ D @ [w1_, w2_],
                                                                 rel=RTOL)


@pytest.mark.parametrize("phys, fr, p, s", CASES)
def test_inverse_and_forward_dynamics_are_the_euler_lagrange_equations(phys, fr, p, s):
    """tau of the Euler-Lagrange equations at (q, dq, ddq), and ddq back from that tau (eq. (1) both ways)."""
    *_, tau = reference(phys, fr, s)
    q1_, q2_, w1_, w2_, a1_, a2_ = s
    np.testing.assert_allclose(dyn.inverse_dynamics(q2_, w1_, w2_, a1_, a2_, p), tau, rtol=1e-11, atol=1e-11)
    np.testing.assert_allclose(dyn.forward_dynamics(q2_, w1_, w2_, *tau, p), (a1_, a2_), rtol=1e-9, atol=1e-9)


def test_the_plant_integrates_the_euler_lagrange_equations():
    """One RK4 step of the module against the Lagrangian's right-hand side integrated by scipy (DOP853, tight)."""
    from scipy.integrate import solve_ivp

    phys, fr, p, states = next(arms(7, 1))
    s, tau = states[0], (1.5, -0.7)

    def rhs(_, x):
        D, C, gravity, _ = reference(phys, fr, (*x, 0.0, 0.0))
        friction = [fr[0] * np.tanh(x[2]) + fr[2] * x[2], fr[1] * np.tanh(x[3]) + fr[3] * x[3]]
        return [x[2], x[3], *np.linalg.solve(D, np.array(tau) - C @ x[2:] - gravity - friction)]

    x0 = tuple(s[:4])
    exact = solve_ivp(rhs, (0.0, 0.01), x0, method="DOP853", rtol=1e-12, atol=1e-12).y[:, -1]
    np.testing.assert_allclose(dyn.rk4_step(x0, *tau, 0.01, 20, p), exact, rtol=1e-9, atol=1e-10)
