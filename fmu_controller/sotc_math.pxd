# Declarations for the compiled cores (orchestration/fmu_build/compiled.py): C types for sotc_math.py, which
# stays the one source of the formulas and runs as it is wherever the cores are not compiled.
cimport cython

@cython.locals(a=double, h=double)
cpdef double log_cosh(double x)
@cython.locals(a=double, e=double)
cpdef double _x_tanh_minus_log_cosh(double x)
cpdef double omega_term_of_arg(double x, double s, double r)
@cython.locals(a=double, b=double, c=double, d=double)
cpdef list basis(object z)
@cython.locals(a=double, b=double, c=double, d=double, p=double, q=double, u=double, w=double)
cpdef list basis_directional(object z, object v)
@cython.locals(a=double, b=double, c=double, d=double, w1=double, w2=double, w3=double, w4=double, w5=double,
               w6=double, w7=double, w8=double, w9=double, w10=double)
cpdef (double, double, double, double) value_gradient(object z, object W)
@cython.locals(s1=double, s2=double, s12=double, s112=double, s24=double)
cpdef double probing_signal(double t, double amplitude=*)
cpdef double omega_of_arg(object x, double s, object r)
@cython.locals(zp1=double, zp2=double, zv1=double, zv2=double, omega=double)
cpdef (double, double) reward(object z, object x, object theta, double s, object r)
@cython.locals(i11=double, i12=double, i22=double, g1=double, g2=double, g3=double, g4=double)
cpdef (double, double, double, double) policy_arguments(object z, object W, object dinv, double s, object r)
cpdef (double, double, double, double) tanh_law(object x, double s)
@cython.locals(zp1=double, zp2=double, zv1=double, zv2=double, i11=double, i12=double, i22=double, zd1=double,
               zd2=double)
cpdef (double, double, double, double) error_rate(object z, object mu, object fe, object dinv, object lam1,
                                                  object lam2, bint backstepping)
cpdef (double, double, double, double) printed_rate(object z, object zd)
@cython.locals(N=int, a=int, k=int, g=double, acc=double)
cpdef void implicit_system(list W, list wdot, list xi, list eta, double[::1] M, bint with_cl, double dt, double c,
                           double[::1] G, double[::1] rhs)
@cython.locals(acc=double, k=int)
cpdef double dot_sequence(object a, object b)
