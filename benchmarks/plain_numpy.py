"""The paper's section 4 experiment as a competent numpy user would write it instead of sotc-cosim.

One file, numpy only, no project code imported: the two-link arm of eq. (46) integrated by classic
RK4 with 4 substeps per sampling period T = 0.01 s (torque held), the reference of eqs. (47)/(48)
with its rates from the kinematic Jacobian, the SOTC feedforward (4) under the bound (5), the
saturated law (28) with the quadratic basis of section 4, and the tuning laws (30)/(31) with
concurrent learning (P = 20 records, 0.02 s apart, replayed with the current weights) after 0.4 s
of probing (PE) on both torques; rho = 4, sigma = 0.6, Lambda_1 = Lambda_2 = Theta = R = I,
alpha_1 = 50, alpha_2 = 0.01, 100 s. The readings the paper leaves open follow docs/paper-notes.md
where they decide the result (chi_vd^a = dphi_d - Lambda_1 z_phi, the literal F_v(z), the implicit
z_v solved by Newton, tau^a bounded by the acceleration-closest point of the disc), and take the
simple option where the notes measure under 1 % (d(chi_vd^a)/dt only, first P records kept,
explicit Euler for W).

    python benchmarks/plain_numpy.py        # prints MSE_1, MSE_2 (eq. (50)) and max ||tau||
"""
import numpy as np

T, STOP, SUBSTEPS = 0.01, 100.0, 4
P1, P2, P3, F1, F2 = 3.473, 0.196, 0.242, 8.45, 2.35  # eq. (46)
RHO, SIGMA, ALPHA1, ALPHA2 = 4.0, 0.6, 50.0, 0.01
BOUND = RHO - SIGMA * np.tanh(1.0)  # eq. (5)
P_STACK, RECORD_EVERY, PE_END = 20, 2, 0.4
PAIRS = [(i, j) for i in range(4) for j in range(i, 4)]  # the quadratic basis of section 4, eq. (27)
GRAD_I = np.array([i for i, _ in PAIRS])
GRAD_J = np.array([j for _, j in PAIRS])


def reference(t):
    """phi_d, dphi_d, ddphi_d (each n x 2) of eqs. (47)/(48) for all sample times at once."""
    a = 0.5 * t + np.pi / 2
    x, y = 1 + 0.5 * np.sin(a), 1 + 0.5 * np.cos(a)
    dx, dy = 0.25 * np.cos(a), -0.25 * np.sin(a)
    ddx, ddy = -0.125 * np.sin(a), -0.125 * np.cos(a)
    q2 = np.arccos((x * x + y * y - 2.0) / 2.0)
    q1 = np.arctan2(y, x) - np.arctan2(np.sin(q2), 1 + np.cos(q2))
    s1, c1, s12, c12 = np.sin(q1), np.cos(q1), np.sin(q1 + q2), np.cos(q1 + q2)
    jac = np.array([[-s1 - s12, -s12], [c1 + c12, c12]]).transpose(2, 0, 1)
    dq = np.linalg.solve(jac, np.stack([dx, dy], 1)[..., None])[..., 0]
    w1, w12 = dq[:, 0], dq[:, 0] + dq[:, 1]
    jdot_dq = np.stack([-c1 * w1 * w1 - c12 * w12 * w12, -s1 * w1 * w1 - s12 * w12 * w12], 1)
    ddq = np.linalg.solve(jac, (np.stack([ddx, ddy], 1) - jdot_dq)[..., None])[..., 0]
    return np.stack([q1, q2], 1), dq, ddq


def inertia(q2):
    c = np.cos(q2)
    return np.array([[P1 + 2 * P3 * c, P2 + P3 * c], [P2 + P3 * c, P2]])


def drift(q2, v):
    """F_v = -D^-1 (H v + G) of eq. (2), and D^-1."""
    s = P3 * np.sin(q2)
    hv = np.array([-s * v[1] * v[0] - s * (v[0] + v[1]) * v[1], s * v[0] * v[0]])
    c = P3 * np.cos(q2)
    d11, d12 = P1 + 2 * c, P2 + c
    d_inv = np.array([[P2, -d12], [-d12, d11]]) / (d11 * P2 - d12 * d12)  # the 2 x 2 inverse in closed form
    return -d_inv @ (hv + np.array([F1 * np.tanh(v[0]), F2 * np.tanh(v[1])])), d_inv


def rk4(x, tau):
    """One sampling period of eq. (1) with the torque held: RK4, SUBSTEPS substeps."""
    def f(s):
        acc, d_inv = drift(s[1], s[2:])
        return np.concatenate([s[2:], acc + d_inv @ tau])
    h = T / SUBSTEPS
    for _ in range(SUBSTEPS):
        k1 = f(x)
        k2 = f(x + 0.5 * h * k1)
        k3 = f(x + 0.5 * h * k2)
        k4 = f(x + h * k3)
        x = x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return x


def grad_basis(z):
    """d zeta / dz (10 x 4) of the quadratic basis; works on one z (4,) or a stack (P, 4)."""
    z = np.atleast_2d(z)
    g = np.zeros((len(z), len(PAIRS), 4))
    rows = np.arange(len(PAIRS))
    g[:, rows, GRAD_I] += z[:, GRAD_J]
    g[:, rows, GRAD_J] += z[:, GRAD_I]
    return g


def policy(grad, w, d_inv):
    """mu_hat of eq. (28) at level sigma, its tanh arguments x and Omega(mu_hat) of eq. (17)."""
    dj = np.einsum("pkj,k->pj", grad, w)  # grad J_hat, P x 4
    x = np.concatenate([dj[:, :2], np.einsum("pji,pj->pi", d_inv, dj[:, 2:])], 1) / (2 * SIGMA)
    omega = 2 * SIGMA ** 2 * np.sum(x * np.tanh(x) - np.logaddexp(x, -x) + np.log(2), 1)
    return -SIGMA * np.tanh(x), omega


def error_rate(z, mu, fv_z, d_inv):
    """dz/dt of eq. (6) with the coupling terms (the design dynamics, Lambda = I)."""
    return np.concatenate([-z[:, :2] + mu[:, :2] + z[:, 2:],
                           fv_z - z[:, 2:] + np.einsum("pij,pj->pi", d_inv, mu[:, 2:]) - z[:, :2]], 1)


def critic_terms(z, fv_z, d_inv, w):
    """eta and the Bellman residual (29) for each row, and mu_hat."""
    grad = grad_basis(z)
    mu, omega = policy(grad, w, d_inv)
    zdot = error_rate(z, mu, fv_z, d_inv)
    eta = np.einsum("pkj,pj->pk", grad, zdot)
    return eta, eta @ w + np.sum(z * z, 1) + omega, mu, zdot, grad


def normalised(eta, residual):
    return np.sum(eta * (residual / (np.sum(eta * eta, 1) + 1) ** 2)[:, None], 0)


def solve_zv(z_phi, base, w):
    """z_v + chi_vd*(z_phi, z_v) = base (chi_vd* depends on z_v through the basis): Newton on 2 x 2."""
    z_v = base.copy()
    for _ in range(20):
        z = np.concatenate([z_phi, z_v])
        grad = grad_basis(z)[0]
        arg = (w @ grad)[:2] / (2 * SIGMA)
        residual = z_v - SIGMA * np.tanh(arg) - base
        hess = np.einsum("k,kij->ij", w, HESS)[:2, 2:] / (2 * SIGMA)
        step = np.linalg.solve(np.eye(2) - SIGMA * (1 - np.tanh(arg) ** 2)[:, None] * hess, residual)
        z_v -= step
        if np.max(np.abs(step)) < 1e-14:
            break
    return z_v


HESS = np.zeros((len(PAIRS), 4, 4))  # second derivatives of the basis (constant)
for _k, (_i, _j) in enumerate(PAIRS):
    HESS[_k, _i, _j] += 1
    HESS[_k, _j, _i] += 1


def accel_projection(tau, d):
    """argmin (u - tau)^T D^-2 (u - tau) subject to ||u|| <= BOUND (the bound (5), acceleration-closest)."""
    if tau @ tau <= BOUND * BOUND:
        return tau
    lam, vec = np.linalg.eigh(d)
    s = vec.T @ tau
    mu = 0.0
    for _ in range(100):  # Newton on ||u(mu)||^2 = BOUND^2, u_i = s_i / (1 + mu lam_i^2)
        u = s / (1 + mu * lam ** 2)
        g = u @ u - BOUND * BOUND
        if abs(g) < 1e-15:
            break
        mu -= g / (-2 * np.sum(u * u * lam ** 2 / (1 + mu * lam ** 2)))
    return vec @ (s / (1 + mu * lam ** 2))


def probing(t):
    return 0.5 * (np.sin(t) ** 2 * np.cos(t) + np.sin(2 * t) ** 2 * np.cos(0.1 * t) + np.sin(1.2 * t) ** 2
                  * np.cos(0.5 * t) + np.sin(t) ** 5 + np.sin(1.12 * t) ** 2 + np.cos(2.4 * t) * np.sin(2.4 * t) ** 3)


def run():
    n = int(round(STOP / T))
    t = np.arange(n + 1) * T
    q_d, dq_d, ddq_d = reference(t)
    x = np.array([0.5, -0.5, 0.0, 0.0])
    w = np.zeros(len(PAIRS))
    stack_z, stack_fv, stack_dinv = np.zeros((P_STACK, 4)), np.zeros((P_STACK, 2)), np.zeros((P_STACK, 2, 2))
    filled = 0
    err = np.empty((n + 1, 2))
    tau_norm = 0.0
    for k in range(n + 1):
        q, v = x[:2], x[2:]
        err[k] = q - q_d[k]
        if k == n:
            break
        z_phi = err[k]
        chi_a = dq_d[k] - z_phi  # eq. (4), backstepping reading
        norm = np.hypot(*chi_a)
        chi_a = chi_a * min(1.0, BOUND / norm) if norm > 0 else chi_a  # bound (5)
        fv, d_inv = drift(q[1], v)
        z_v = solve_zv(z_phi, v - chi_a, w)
        z = np.concatenate([z_phi, z_v])[None]
        fv_z, _ = drift(z_phi[1], z_v)
        eta, residual, mu, zdot, grad = critic_terms(z, fv_z[None], d_inv[None], w)
        dchi = ddq_d[k] - (v - dq_d[k])  # d(chi_vd^a)/dt
        d = inertia(q[1])
        tau_a = accel_projection(d @ (fv_z + dchi - fv - z_phi - z_v), d)  # eq. (4) under (5)
        tau = mu[0, 2:] + tau_a + (probing(t[k]) if t[k] < PE_END else 0.0)
        tau *= min(1.0, RHO / np.hypot(*tau))  # ||tau|| <= rho
        tau_norm = max(tau_norm, np.hypot(*tau))
        w_dot = -ALPHA1 * normalised(eta, residual)  # eq. (30)
        if filled:  # concurrent learning: the stored points replayed with the current weights
            eta_i, res_i, *_ = critic_terms(stack_z[:filled], stack_fv[:filled], stack_dinv[:filled], w)
            w_dot -= ALPHA1 * normalised(eta_i, res_i)
        if z[0] @ zdot[0] >= 0:  # eq. (31)
            g = np.zeros((4, 4))
            g[:2, :2], g[2:, 2:] = np.eye(2), d_inv @ d_inv.T
            w_dot += ALPHA2 * 0.5 * grad[0] @ g @ z[0]
        w = w + T * w_dot
        if filled < P_STACK and k % RECORD_EVERY == 0:
            stack_z[filled], stack_fv[filled], stack_dinv[filled] = z[0], fv_z, d_inv
            filled += 1
        x = rk4(x, tau)
    return np.mean(err ** 2, 0), tau_norm, w


if __name__ == "__main__":
    mse, tau_max, weights = run()
    print(f"MSE_1 {mse[0]:.6g}  MSE_2 {mse[1]:.6g}  max||tau|| {tau_max:.4g}  W {np.round(weights, 4).tolist()}")
