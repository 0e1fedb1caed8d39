# Declarations for the compiled cores (orchestration/fmu_build/compiled.py): C types for sotc_stack.py, which
# stays the one source of the loops and runs as it is wherever the cores are not compiled. The stack's rows
# and matrices are contiguous float64 buffers (array('d')), C arrays here.
cimport cython
from fmu_controller.fixed_linalg cimport cholesky, forward_substitute, smallest_eigenvalue, sturm_count, trace
from fmu_controller.sotc_math cimport basis_directional, error_rate, policy_arguments, printed_rate, reward, tanh_law

@cython.locals(N=int, i=int, k=int, a=int, c=int, o=int, ee=double, xa=double)
cpdef void cl_matrix(int n, double[::1] E, double[::1] rew, double[::1] M, double[::1] b, double[::1] sc)
@cython.locals(N=int, a=int, c=int, acc=double)
cpdef void cl_rate(double[::1] M, double[::1] b, double[::1] W, double[::1] out)
@cython.locals(i=int, k=int, eta=list)
cpdef void replay_current(int n, object W, double[::1] z, double[::1] dinv, double[::1] fe, double s, tuple r,
                          tuple theta, tuple lam1, tuple lam2, bint backstepping, bint coupled, double[::1] E,
                          double[::1] rew)
@cython.locals(N=int, o=int, a=int, c=int, xa=double, ya=double)
cpdef void trial_matrix(double[::1] M, double sc_j, double[::1] E, int j, double c_sc, double[::1] eta,
                        double[::1] out)
