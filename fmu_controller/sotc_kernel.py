"""The per-sample arithmetic of the SOTC core (``sotc.SotcCore``) on typed state: steps 1-5 of ``sotc``'s
module docstring, eqs. (4)-(7) and (27)-(31) of Dien, Luy, Lai & Hai (2023).

``SotcCore`` keeps the parameters, their checks and the state's JSON form; its ``evaluate`` and ``advance``
are one call each into a ``SotcKernel``, which holds everything a sample reads and writes: scalars, the
critic weights, the eta/xi/dW/dt buffers of the last sample, the pending sample ``advance`` integrates, and
the outputs, written into one preallocated float64 buffer (``outputs``) in ``SotcCore.output_names()``
order. Compiled, ``sotc_kernel.pxd`` makes the kernel an extension type with C doubles and C arrays, so a
sample creates no Python object (the CL stack, ``sotc_stack.CLStack``, is one too, called as C); as
Python, the same code runs on floats and ``array('d')`` buffers. Every expression is the one the core
computed before it had a kernel, in the same order, so the bits are unchanged.
"""
from __future__ import annotations

import math
from array import array
from math import fsum, nan  # Python's own (math.f is C's libm f in the compiled kernel)
from typing import Any, Sequence

from fmu_numerics.elementary import INTERPRETED, hypot, tanh
from fmu_numerics.fixed_linalg import add_scaled, buffer, cholesky, cholesky_solve, dot, scale_into
from fmu_controller.saturation import JOINT, NONE, clip_box, limit_torque, limit_without_metric, saturate_norm
from fmu_controller.sotc_math import (N_BASIS, basis_into, critic_row, directional_into, gradient, hessian_phi_times,
                                      implicit_system, normalisation, policy_arguments, probing_signal)
from fmu_controller.sotc_zv import solve_zv
from fmu_plant.dynamics import bias_torque, forward_dynamics, inertia_entries



def exact_sum_loop(x: array, n: int, p: array) -> float:
    """sum x[0..n) correctly rounded, as ``math.fsum`` computes it (Shewchuk's exact partials, "Adaptive
    precision floating-point arithmetic", Discrete Comput. Geom. 18, 1997, then CPython's half-even fix-up
    across partials), for finite terms whose partial sums stay finite; otherwise it hands x to
    ``math.fsum`` itself, which returns inf or nan or raises as it always did. p: n scratch doubles."""
    m = 0
    for i in range(n):
        v = x[i]
        if not math.isfinite(v):
            return fsum(x[:n])
        j = 0
        for k in range(m):
            w = p[k]
            if abs(v) < abs(w):
                v, w = w, v
            hi = v + w
            lo = w - (hi - v)
            if lo != 0.0:
                p[j] = lo
                j += 1
            v = hi
        m = j
        if v != 0.0:
            if not math.isfinite(v):  # the partials overflowed: math.fsum raises OverflowError
                return fsum(x[:n])
            p[m] = v
            m += 1
    return _round_partials(p, m)


def _round_partials(p: array, m: int) -> float:
    """The correctly rounded sum of the m non-overlapping partials p[0..m), increasing in magnitude."""
    if m == 0:
        return 0.0
    m -= 1
    hi, lo = p[m], 0.0
    while m > 0:
        v = hi
        m -= 1
        w = p[m]
        hi = v + w
        lo = w - (hi - v)
        if lo != 0.0:
            break
    if m > 0 and ((lo < 0.0 and p[m - 1] < 0.0) or (lo > 0.0 and p[m - 1] > 0.0)):
        w = lo * 2.0
        v = hi + w
        if w == v - hi:  # the rest of the partials pushes a tie the other way: round away
            hi = v
    return hi


def exact_sum(x: array, n: int, p: array) -> float:
    """``exact_sum_loop`` in C; ``math.fsum`` itself in the interpreted kernel (the same bits, faster there)."""
    if INTERPRETED:
        return fsum(x[:n])
    return exact_sum_loop(x, n, p)


class SotcKernel:
    """What one SOTC sample reads and writes, typed (``sotc_kernel.pxd``); built from a ``SotcCore``'s
    settled parameters and sharing its critic constants, arm model and CL stack."""

    def __init__(self, core: Any, stack: Any, n_outputs: int) -> None:
        self.K, self.model, self.stack = core.constants, core.model, stack
        self.lam11, self.lam12 = core.lam1
        self.lam21, self.lam22 = core.lam2
        self.r1, self.r2 = core.r[0], core.r[1]
        self.alpha1, self.alpha2, self.rho, self.s, self.bound5 = core.alpha1, core.alpha2, core.rho, core.s, core.bound5
        self.pe_amplitude, self.pe_duration, self.pe_in_critic = core.pe_amplitude, core.pe_duration, core.pe_in_critic
        self.cl_enabled, self.cl_record_interval = core.cl_enabled, core.cl_record_interval
        self.cl_start_time = core.cl_start_time
        self.backstepping, self.fv_drift, self.implicit = core.backstepping, core.fv_drift, core.implicit
        self.limit_code, self.actuator_per_joint = core.limit_code, core.actuator_per_joint
        self.clip_joint, self.limit_none = core.limit_code == JOINT, core.limit_code == NONE
        self.chain, self.difference = core.chi_dot_form == "chain", core.chi_dot_form == "difference"
        N = N_BASIS
        # each buffer Python code reads has an object name beside its typed one (the same array as Python)
        self.weights, self.outputs = buffer(N), buffer(n_outputs)
        self.eta_array, self.z_array, self.dinv_array, self.fe_array = buffer(N), buffer(4), buffer(3), buffer(2)
        self.W, self.out, self.eta, self.z, self.dinv, self.fe = (self.weights, self.outputs, self.eta_array,
                                                                 self.z_array, self.dinv_array, self.fe_array)
        self.xi, self.wdot, self.gz, self.terms_zeta, self.partials = (buffer(N), buffer(N), buffer(N), buffer(N),
                                                                       buffer(N))
        self.G, self.L, self.rhs, self.Wn = buffer(N * N), buffer(N * N), buffer(N), buffer(N)  # the weight step
        self.ref, self.last_y, self.last_r = buffer(6), buffer(4), buffer(6)  # this sample's reference, last inputs
        self.reset()

    def reset(self) -> None:
        """Nothing pending, no previous chi_vd, no last inputs, the record clock at 0 (W is the core's)."""
        self.has_pending = self.has_prev = self.has_last = False
        self.next_record_t = 0.0
        self.pend_t = self.rew = self.chi1 = self.chi2 = self.prev_t = self.prev1 = self.prev2 = self.last_t = 0.0
        self.cl = False

    def pending(self) -> dict[str, Any] | None:
        """The sample ``advance`` would integrate (for tests and studies), as plain values."""
        if not self.has_pending:
            return None
        return {"t": self.pend_t, "wdot": array("d", self.wdot), "xi": array("d", self.xi),
                "eta": array("d", self.eta), "r": self.rew, "z": tuple(self.z), "dinv": tuple(self.dinv),
                "fe": tuple(self.fe), "cl": self.cl, "chi": (self.chi1, self.chi2)}

    # --- one sample -----------------------------------------------------------------------------------

    def evaluate(self, t: float, y: Sequence[float], r: Sequence[float]) -> None:
        """Steps 1-4 of ``sotc``'s module docstring at time t: the outputs, and the sample ``advance`` needs."""
        self.has_pending = False  # until this sample is complete
        phi1, phi2, dphi1, dphi2 = float(y[0]), float(y[1]), float(y[2]), float(y[3])
        ref = self.ref
        for k in range(6):
            ref[k] = float(r[k])
        s, z, dinv, fe = self.s, self.z, self.dinv, self.fe
        zp1, zp2, dzp1, dzp2, zv1, zv2, zv_res, ca1, ca2, chi_a_bounded = self._error(phi1, phi2, dphi1, dphi2)
        z[0], z[1], z[2], z[3] = zp1, zp2, zv1, zv2
        # g_phi = I, g_v = D^-1(phi) of eq. (2), nominal model
        d11, d12, d22 = inertia_entries(phi2, self.model)
        det = d11 * d22 - d12 * d12
        dinv[0], dinv[1], dinv[2] = d22 / det, -d12 / det, d11 / det
        x1, x2, x3, x4 = policy_arguments(self.K, zp1, zp2, zv1, zv2, self.W, dinv[0], dinv[1], dinv[2])  # eq. (28)
        t1, t2, t3, t4 = tanh(x1), tanh(x2), tanh(x3), tanh(x4)
        cs1, cs2 = -s * t1, -s * t2  # chi_vd*
        ts1, ts2 = -s * t3, -s * t4  # tau*
        # probing signal of section 4, added to both joint torques while t < pe_duration
        pe_active = t < self.pe_duration
        pe = probing_signal(t, self.pe_amplitude) if pe_active else 0.0
        fe[0] = fe[1] = 0.0
        if self.fv_drift:  # F_v(z_phi, z_v) of (4)/(6): the drift -D^-1 (H v + G) of (2) at the error coordinates
            fe[0], fe[1] = forward_dynamics(zp2, zv1, zv2, 0.0, 0.0, self.model)
        if self.pe_in_critic:
            zd1, zd2, zd3, zd4, rew, omega, e1, law31 = self._critic(t, cs1, cs2, ts1 + pe, ts2 + pe, x1, x2, x3, x4,
                                                                     t1, t2, t3, t4)
        else:
            zd1, zd2, zd3, zd4, rew, omega, e1, law31 = self._critic(t, cs1, cs2, ts1, ts2, x1, x2, x3, x4, t1, t2, t3,
                                                                     t4)
        self.chi1, self.chi2 = ca1 + cs1, ca2 + cs2
        dchi1, dchi2 = self._chi_dot(t, dzp1, dzp2, zd1, zd2, zd3, zd4, t1, t2, chi_a_bounded)
        ta1, ta2, tau_a_bounded, tr1, tr2 = self._feedforward(phi2, dphi1, dphi2, dchi1, dchi2, d11, d12, d22)
        tau1, tau2, tau_limited = self._actuator_limit(ts1 + ta1 + pe, ts2 + ta2 + pe)
        self.pend_t, self.rew, self.has_pending = t, rew, True
        self.last_t, self.has_last = t, True
        self.last_y[0], self.last_y[1], self.last_y[2], self.last_y[3] = phi1, phi2, dphi1, dphi2
        for k in range(6):
            self.last_r[k] = ref[k]
        self._write_outputs(tau1, tau2, ts1, ts2, ta1, ta2, cs1, cs2, ca1, ca2, e1, omega, law31, pe_active, pe,
                            tau_a_bounded, chi_a_bounded, tau_limited, tr1, tr2, dchi1, dchi2, zv_res)

    def _write_outputs(self, tau1: float, tau2: float, ts1: float, ts2: float, ta1: float, ta2: float, cs1: float,
                       cs2: float, ca1: float, ca2: float, e1: float, omega: float, law31: bool, pe_active: bool,
                       pe: float, tau_a_bounded: bool, chi_a_bounded: bool, tau_limited: bool, tr1: float,
                       tr2: float, dchi1: float, dchi2: float, zv_res: float) -> None:
        """The outputs in ``SotcCore.output_names()`` order; J_hat = W^T zeta(z) of (27) summed exactly."""
        o, W, z, N = self.out, self.W, self.z, N_BASIS
        o[0], o[1], o[2], o[3], o[4], o[5], o[6], o[7], o[8], o[9] = tau1, tau2, ts1, ts2, ta1, ta2, cs1, cs2, ca1, ca2
        o[10], o[11], o[12], o[13] = z[0], z[1], z[2], z[3]
        products = self.terms_zeta
        basis_into(products, z[0], z[1], z[2], z[3])
        for k in range(N):
            o[14 + k] = W[k]
            products[k] = W[k] * products[k]
        o[24] = exact_sum(products, N, self.partials)
        o[25], o[26], o[27], o[28] = e1, omega, self.rew, 31.0 if law31 else 30.0
        o[29], o[30], o[31], o[32] = float(self.stack.count), self.stack.min_eig, 1.0 if pe_active else 0.0, pe
        o[33], o[34], o[35] = float(tau_a_bounded), float(chi_a_bounded), float(tau_limited)
        o[36], o[37], o[38], o[39], o[40] = hypot(tau1, tau2), tr1, tr2, dchi1, dchi2
        o[41], o[42] = math.sqrt(dot(self.wdot, self.wdot, N)), zv_res

    def _error(self, phi1: float, phi2: float, dphi1: float, dphi2: float) -> tuple:
        """Step 1: z_phi, its measured rate, z_v (solved jointly with (28)) and chi_vd^a under (5)."""
        ref, W, code = self.ref, self.W, self.limit_code
        phi1_d, phi2_d, dphi1_d, dphi2_d = ref[0], ref[1], ref[2], ref[3]
        lam11, lam12 = self.lam11, self.lam12
        # the z_phi z_v block of Hess(J_hat) = 2 S(W) (sotc_math.value_hessian): W3, W4, W6, W7
        h13, h14, h23, h24 = W[2], W[3], W[5], W[6]
        # tracking error z_phi = chi_phi - chi_phi_d (section 2.1) and its measured rate
        zp1, zp2 = phi1 - phi1_d, phi2 - phi2_d
        dzp1, dzp2 = dphi1 - dphi1_d, dphi2 - dphi2_d
        # eq. (4), first line, with the bound (5); z_v = dphi - chi_vd* - chi_vd^a solved jointly with (28)
        if self.backstepping:  # chi_vd^a = dphi_d - Lambda1 z_phi, so F_bar_phi = -Lambda1 z_phi in (6)
            ca1, ca2, chi_a_bounded = limit_without_metric(dphi1_d - lam11 * zp1, dphi2_d - lam12 * zp2, self.bound5,
                                                           code)
            zv1, zv2, zv_res = solve_zv(self.K, zp1, zp2, dphi1 - ca1, dphi2 - ca2, 1.0, 1.0, W, h13, h14, h23, h24)
        else:  # as printed, chi_vd^a = dphi_d + Lambda1 z_v: (I + Lambda1) z_v = dphi - dphi_d - chi_vd*
            zv1, zv2, zv_res = solve_zv(self.K, zp1, zp2, dzp1, dzp2, 1.0 + lam11, 1.0 + lam12, W, h13, h14, h23, h24)
            ca1, ca2, chi_a_bounded = limit_without_metric(dphi1_d + lam11 * zv1, dphi2_d + lam12 * zv2, self.bound5,
                                                           code)
        return zp1, zp2, dzp1, dzp2, zv1, zv2, zv_res, ca1, ca2, chi_a_bounded

    def _critic(self, t: float, mu1: float, mu2: float, mu3: float, mu4: float, x1: float, x2: float, x3: float,
                x4: float, tx1: float, tx2: float, tx3: float, tx4: float) -> tuple:
        """Step 3, eqs. (6)/(7) and (29)-(31): zdot = F_bar(z) + g mu_hat (F_v(z_phi, z_v) = fe, the drift
        -D^-1 (H v + G) of (2) at the error coordinates), eta, the reward, the Bellman residual e1 and
        dW/dt (with the CL sum), every sum in a fixed order; eta, xi and dW/dt go to their buffers. tx = tanh(x)."""
        z, dinv, fe = self.z, self.dinv, self.fe
        zp1, zp2, zv1, zv2, i11, i12, i22 = z[0], z[1], z[2], z[3], dinv[0], dinv[1], dinv[2]
        N, W, K, eta, xi, wdot = N_BASIS, self.W, self.K, self.eta, self.xi, self.wdot
        # eq. (29): eta = grad(zeta) zdot, e1 = W^T eta + z^T Theta z + Omega(mu_hat), Omega of eq. (17)
        zd1, zd2, zd3, zd4, rew, omega = critic_row(K, zp1, zp2, zv1, zv2, x1, x2, x3, x4, tx1, tx2, tx3, tx4,
                                                    mu1, mu2, mu3, mu4, fe[0], fe[1], i11, i12, i22, eta, 0)
        e1 = dot(W, eta, N) + rew
        # eqs. (30)/(31): dW/dt = -alpha1 xi e1 - alpha1 sum_i xi_i (eta_i^T W + r_i) [+ alpha2/2 grad(zeta) G z],
        # xi = eta / (eta^T eta + 1)^2; the CL sum is M W + b (sotc_stack)
        scale_into(xi, 1.0 / normalisation(dot(eta, eta, N)), eta, N)
        scale_into(wdot, -self.alpha1 * e1, xi, N)
        self.cl = self.cl_enabled and self.stack.count > 0 and t >= self.cl_start_time
        if self.cl:
            add_scaled(wdot, -self.alpha1, self.stack.cl_terms(self.W), N)  # - alpha1 (M W + b)
        law31 = zp1 * zd1 + zp2 * zd2 + zv1 * zd3 + zv2 * zd4 >= 0.0  # z^T zdot >= 0: eq. (31)
        if law31:  # + alpha2/2 grad(zeta) G z with G = g R^-1 g^T = diag(R_phi^-1, D^-1 R_v^-1 D^-1)
            u1, u2 = (i11 * zv1 + i12 * zv2) / K.r3, (i12 * zv1 + i22 * zv2) / K.r4
            directional_into(self.gz, 0, zp1, zp2, zv1, zv2, zp1 / K.r1, zp2 / K.r2, i11 * u1 + i12 * u2,
                             i12 * u1 + i22 * u2)
            add_scaled(wdot, 0.5 * self.alpha2, self.gz, N)
        return zd1, zd2, zd3, zd4, rew, omega, e1, law31

    def _chi_dot(self, t: float, dzp1: float, dzp2: float, zd1: float, zd2: float, zd3: float, zd4: float,
                 t1: float, t2: float, chi_a_bounded: bool) -> tuple:
        """dchi_vd/dt for tau^a of (4), as ``chi_dot_form`` reads it."""
        z = self.z
        if self.backstepping:
            dca1, dca2 = self.ref[4] - self.lam11 * dzp1, self.ref[5] - self.lam12 * dzp2
        else:
            dca1, dca2 = self.ref[4] + self.lam11 * zd3, self.ref[5] + self.lam12 * zd4
        if chi_a_bounded:
            dca1 = dca2 = 0.0  # a bounded chi_vd^a is not differentiated (docs/paper-notes.md 2.5 lists where)
        if self.chain:
            # chi_vd* = -s tanh(x_phi), x_phi = grad_phi J_hat / (2 s r): the chain rule gives
            # dx_phi/dt = (Hess(J_hat) zdot + grad(zeta)^T dW/dt)_phi / (2 s r), zdot from (6)
            gd1, gd2, _, _ = gradient(z[0], z[1], z[2], z[3], self.wdot)
            hz1, hz2 = hessian_phi_times(self.W, zd1, zd2, zd3, zd4)
            return (dca1 - (1.0 - t1 * t1) * (hz1 + gd1) / (2.0 * self.r1),
                    dca2 - (1.0 - t2 * t2) * (hz2 + gd2) / (2.0 * self.r2))
        if self.difference and self.has_prev and t > self.prev_t:
            hstep = t - self.prev_t
            return (self.chi1 - self.prev1) / hstep, (self.chi2 - self.prev2) / hstep
        return dca1, dca2

    def _feedforward(self, phi2: float, dphi1: float, dphi2: float, dchi1: float, dchi2: float, d11: float,
                     d12: float, d22: float) -> tuple:
        """Step 4, eq. (4), second line, with g_v^-1 = D and -D F_v(phi, dphi) = H dphi + G:
        tau^a = D (F_v(z_phi, z_v) + dchi_vd/dt - z_phi - Lambda2 z_v) + H dphi + G, then the bound (5)."""
        z, fe = self.z, self.fe
        v1 = fe[0] + dchi1 - z[0] - self.lam21 * z[2]
        v2 = fe[1] + dchi2 - z[1] - self.lam22 * z[3]
        b1, b2 = bias_torque(phi2, dphi1, dphi2, self.model)
        tr1, tr2 = d11 * v1 + d12 * v2 + b1, d12 * v1 + d22 * v2 + b2
        if self.clip_joint:
            ta1, ta2, bounded = clip_box(tr1, tr2, self.bound5)
        else:
            ta1, ta2, bounded = limit_torque(self.limit_code, tr1, tr2, self.bound5, d11, d12, d22)
        return ta1, ta2, bounded, tr1, tr2

    def _actuator_limit(self, tau1: float, tau2: float) -> tuple:
        """Step 4: tau = tau* + tau^a (+ PE) under the actuator limit ||tau|| <= rho of eq. (1)."""
        if self.actuator_per_joint:
            return clip_box(tau1, tau2, self.rho)
        if not self.limit_none:
            tau1, tau2, _, limited = saturate_norm(tau1, tau2, self.rho)
            return tau1, tau2, limited
        return tau1, tau2, False

    # --- learning over [t, t + dt) ---------------------------------------------------------------------

    def advance(self, t: float, dt: float) -> None:
        """Step 5: (30)/(31) over [t, t + dt) from the pending sample of time t, then the CL record
        (``SotcCore.advance`` says how)."""
        if not self.has_pending or abs(self.pend_t - t) > 1e-9 * max(1.0, abs(t)):
            raise RuntimeError(f"advance({t}, {dt}) needs evaluate() at t = {t} first")
        if not (dt > 0.0 and math.isfinite(dt)):
            raise ValueError(f"advance: step size {dt} must be positive and finite")
        self._weight_step(dt)
        if self.difference:
            self.has_prev, self.prev_t, self.prev1, self.prev2 = True, t, self.chi1, self.chi2
        if self.cl_enabled and t >= self.next_record_t - 1e-9:
            self.next_record_t += self.cl_record_interval
            self.stack.record(self.eta, self.rew, self.z, self.dinv, self.fe, t, self.cl)
        self.has_pending = False

    def _weight_step(self, dt: float) -> None:
        """W after one step of (30)/(31), in place. (I + dt alpha1 Gamma) is symmetric positive definite,
        so a Cholesky solve in fixed order (``fixed_linalg``) gives W+."""
        N, W, wdot = N_BASIS, self.W, self.wdot
        if not self.implicit:
            for k in range(N):
                W[k] = W[k] + dt * wdot[k]
            return
        implicit_system(W, wdot, self.xi, self.eta, self.stack.M, self.cl, dt, dt * self.alpha1, self.G, self.rhs)
        if not cholesky(self.G, N, self.L):  # I + (symmetric >= 0) fails only on non-finite or overflowing
            for k in range(N):  # entries: non-finite weights, which the next sample's outputs report as such
                W[k] = nan
            return
        cholesky_solve(self.L, self.rhs, N, self.Wn)
        for k in range(N):
            W[k] = self.Wn[k]
