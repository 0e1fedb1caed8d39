# Declarations for the compiled cores (orchestration/fmu_build/compiled.py): C types for sotc_stack.py, which
# stays the one source of the loops and runs as it is wherever the cores are not compiled. The stack's rows
# and matrices are contiguous float64 buffers (array('d')), C arrays here; tanh is elementary.pxd's.
cimport cython
from fmu_controller.elementary cimport tanh
from fmu_controller.fixed_linalg cimport cholesky, forward_substitute, smallest_eigenvalue, sturm_count, trace
from fmu_controller.sotc_math cimport CriticConstants, critic_row, normalisation, policy_arguments

@cython.locals(N=int, i=int, k=int, a=int, c=int, o=int, ee=double, xa=double)
cpdef void cl_matrix(int n, double[::1] E, double[::1] rew, double[::1] M, double[::1] b, double[::1] sc)
@cython.locals(N=int, a=int, c=int, acc=double)
cpdef void cl_rate(double[::1] M, double[::1] b, double[::1] W, double[::1] out)
@cython.locals(i=int, s=double, zp1=double, zp2=double, zv1=double, zv2=double, i11=double, i12=double, i22=double,
               x1=double, x2=double, x3=double, x4=double)
cpdef void replay_current(CriticConstants K, int n, double[::1] W, double[::1] z, double[::1] dinv, double[::1] fe,
                          double[::1] E, double[::1] rew)
@cython.locals(N=int, count=int, j=int, k=int, yy=double, within=bint)
cpdef int rows_within(double[::1] L, double[::1] E, double[::1] sc, int P, double[::1] y, double[::1] inside)
@cython.locals(N=int, o=int, a=int, c=int, xa=double, ya=double)
cpdef void trial_matrix(double[::1] M, double sc_j, double[::1] E, int j, double c_sc, double[::1] eta,
                        double[::1] out)
