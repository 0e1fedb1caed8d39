# Declarations for the compiled cores (orchestration/fmu_build/compiled.py): C types for sotc_math.py, which
# stays the one source of the formulas and runs as it is wherever the cores are not compiled. The elementary
# functions are elementary.pxd's C functions (``math`` is libc's, for inf only), the kernels take C doubles and
# buffers (double[::1], array('d')) and return C tuples: a sample creates no Python object.
cimport cython
from libc cimport math
from fmu_numerics.elementary cimport atanh, cos, exp, log, log1p, sin, sinh, tanh

cdef double LN2  # a C constant: no module lookup per sample

cdef class CriticConstants:  # read-only: s and r_i are checked once, in __init__
    cdef readonly double s, r1, r2, r3, r4, theta1, theta2, theta3, theta4, lam11, lam12, lam21, lam22
    cdef public bint backstepping, coupled

@cython.locals(a=double, h=double)
cpdef double log_cosh(double x) noexcept
@cython.locals(a=double, e=double)
cpdef double _x_tanh_minus_log_cosh(double x, double t) noexcept
cpdef double omega_term(double x, double t, double s, double r) noexcept
cpdef double omega_term_of_arg(double x, double s, double r) noexcept
cpdef double omega4(double x1, double x2, double x3, double x4, double t1, double t2, double t3, double t4, double s,
                    double r1, double r2, double r3, double r4) noexcept
cpdef double omega_of_arg(object x, double s, object r)
@cython.locals(omega=double)
cpdef (double, double) reward(CriticConstants K, double zp1, double zp2, double zv1, double zv2, double x1,
                              double x2, double x3, double x4, double t1, double t2, double t3, double t4) noexcept
cpdef void basis_into(double[::1] out, double a, double b, double c, double d) noexcept
cpdef list basis(object z)
cpdef (double, double) hessian_phi_times(double[::1] W, double v1, double v2, double v3, double v4) noexcept
cpdef void directional_into(double[::1] out, int o, double a, double b, double c, double d, double p, double q,
                            double u, double w) noexcept
cpdef (double, double, double, double) gradient(double a, double b, double c, double d, double[::1] W) noexcept
cpdef (double, double, double, double) value_gradient(object z, object W)
@cython.locals(s=double, g1=double, g2=double, g3=double, g4=double)
cpdef (double, double, double, double) policy_arguments(CriticConstants K, double zp1, double zp2, double zv1,
                                                        double zv2, double[::1] W, double i11, double i12,
                                                        double i22) noexcept
@cython.locals(zd1=double, zd2=double)
cpdef (double, double, double, double) error_rate(CriticConstants K, double zp1, double zp2, double zv1, double zv2,
                                                  double mu1, double mu2, double mu3, double mu4, double fe1,
                                                  double fe2, double i11, double i12, double i22) noexcept
@cython.locals(zd1=double, zd2=double, zd3=double, zd4=double, rew=double, omega=double)
cpdef (double, double, double, double, double, double) critic_row(
    CriticConstants K, double zp1, double zp2, double zv1, double zv2, double x1, double x2, double x3, double x4,
    double t1, double t2, double t3, double t4, double mu1, double mu2, double mu3, double mu4, double fe1,
    double fe2, double i11, double i12, double i22, double[::1] eta, int o) noexcept
cpdef double normalisation(double ee) noexcept
@cython.locals(s1=double, s2=double, s12=double, s112=double, s24=double)
cpdef double probing_signal(double t, double amplitude=*)
@cython.locals(N=int, a=int, k=int, g=double, acc=double)
cpdef void implicit_system(double[::1] W, double[::1] wdot, double[::1] xi, double[::1] eta, double[::1] M,
                           bint with_cl, double dt, double c, double[::1] G, double[::1] rhs)
