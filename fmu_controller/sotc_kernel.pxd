# Declarations for the compiled cores (orchestration/fmu_build/compiled.py): C types for sotc_kernel.py, which
# stays the one source of the SOTC sample and runs as it is wherever the cores are not compiled. SotcKernel is
# an extension type: C doubles and flags, float64 buffers as C arrays (each buffer Python reads also kept as its
# array object), its sample as C methods returning C tuples; ``math`` is libc's (sqrt, isfinite); fsum and nan
# are Python's, imported by name (the rare paths); hypot and tanh elementary.pxd's.
cimport cython
from libc cimport math
from fmu_numerics.elementary cimport hypot, tanh
from fmu_controller.saturation cimport clip_box, limit_torque, limit_without_metric, saturate_norm
from fmu_numerics.fixed_linalg cimport add_scaled, cholesky, cholesky_solve, dot, scale_into
from fmu_controller.sotc_math cimport (CriticConstants, basis_into, critic_row, directional_into, gradient,
                                       hessian_phi_times, implicit_system, normalisation, policy_arguments,
                                       probing_signal)
from fmu_controller.sotc_stack cimport CLStack
from fmu_controller.sotc_zv cimport solve_zv
from fmu_plant.dynamics cimport bias_torque, forward_dynamics, inertia_entries

cdef bint INTERPRETED

@cython.locals(m=int, i=int, j=int, k=int, v=double, w=double, hi=double, lo=double)
cpdef double exact_sum_loop(double[::1] x, int n, double[::1] p)
@cython.locals(v=double, w=double, hi=double, lo=double)
cdef double _round_partials(double[::1] p, int m)
cpdef double exact_sum(double[::1] x, int n, double[::1] p)

cdef class SotcKernel:
    cdef public CriticConstants K
    cdef public object model
    cdef public CLStack stack
    cdef public double lam11, lam12, lam21, lam22, r1, r2, alpha1, alpha2, rho, s, bound5
    cdef public double pe_amplitude, pe_duration, cl_record_interval, cl_start_time, next_record_t
    cdef public bint pe_in_critic, cl_enabled, backstepping, fv_drift, implicit, actuator_per_joint
    cdef public bint clip_joint, limit_none, chain, difference
    cdef public int limit_code
    cdef public object weights, outputs, eta_array, z_array, dinv_array, fe_array
    cdef double[::1] W, out, eta, z, dinv, fe, xi, wdot, gz, terms_zeta, partials, G, L, rhs, Wn, ref
    cdef public double[::1] last_y, last_r
    cdef public bint has_pending, has_prev, has_last, cl
    cdef public double pend_t, rew, chi1, chi2, prev_t, prev1, prev2, last_t

    @cython.locals(phi1=double, phi2=double, dphi1=double, dphi2=double, k=int, s=double, zp1=double, zp2=double,
                   dzp1=double, dzp2=double, zv1=double, zv2=double, zv_res=double, ca1=double, ca2=double,
                   chi_a_bounded=bint, d11=double, d12=double, d22=double, det=double, x1=double, x2=double,
                   x3=double, x4=double, t1=double, t2=double, t3=double, t4=double, cs1=double, cs2=double,
                   ts1=double, ts2=double, pe_active=bint, pe=double, zd1=double, zd2=double, zd3=double,
                   zd4=double, rew=double, omega=double, e1=double, law31=bint, dchi1=double, dchi2=double,
                   ta1=double, ta2=double, tau_a_bounded=bint, tr1=double, tr2=double, tau1=double, tau2=double,
                   tau_limited=bint)
    cpdef void evaluate(self, double t, object y, object r) except *
    @cython.locals(k=int, N=int)
    cdef void _write_outputs(self, double tau1, double tau2, double ts1, double ts2, double ta1, double ta2,
                             double cs1, double cs2, double ca1, double ca2, double e1, double omega, bint law31,
                             bint pe_active, double pe, bint tau_a_bounded, bint chi_a_bounded, bint tau_limited,
                             double tr1, double tr2, double dchi1, double dchi2, double zv_res) except *
    @cython.locals(code=int, phi1_d=double, phi2_d=double, dphi1_d=double, dphi2_d=double, lam11=double,
                   lam12=double, h13=double, h14=double, h23=double, h24=double, zp1=double, zp2=double,
                   dzp1=double, dzp2=double, zv1=double, zv2=double, zv_res=double, ca1=double, ca2=double,
                   chi_a_bounded=bint)
    cdef (double, double, double, double, double, double, double, double, double, bint) _error(
        self, double phi1, double phi2, double dphi1, double dphi2) except *
    @cython.locals(N=int, zp1=double, zp2=double, zv1=double, zv2=double, i11=double, i12=double, i22=double,
                   zd1=double, zd2=double, zd3=double, zd4=double, rew=double, omega=double, e1=double,
                   law31=bint, u1=double, u2=double)
    cdef (double, double, double, double, double, double, double, bint) _critic(
        self, double t, double mu1, double mu2, double mu3, double mu4, double x1, double x2, double x3,
        double x4, double tx1, double tx2, double tx3, double tx4) except *
    @cython.locals(dca1=double, dca2=double, gd1=double, gd2=double, hz1=double, hz2=double, hstep=double)
    cdef (double, double) _chi_dot(self, double t, double dzp1, double dzp2, double zd1, double zd2, double zd3,
                                   double zd4, double t1, double t2, bint chi_a_bounded) except *
    @cython.locals(v1=double, v2=double, b1=double, b2=double, tr1=double, tr2=double, ta1=double, ta2=double,
                   bounded=bint)
    cdef (double, double, bint, double, double) _feedforward(self, double phi2, double dphi1, double dphi2,
                                                             double dchi1, double dchi2, double d11, double d12,
                                                             double d22) except *
    @cython.locals(limited=bint)
    cdef (double, double, bint) _actuator_limit(self, double tau1, double tau2) except *
    cpdef void advance(self, double t, double dt) except *
    @cython.locals(N=int, k=int)
    cdef void _weight_step(self, double dt) except *
