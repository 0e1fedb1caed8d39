# Declarations for the compiled cores (orchestration/fmu_build/compiled.py): C types for sotc_stack.py, which
# stays the one source of the loops and runs as it is wherever the cores are not compiled.
cimport cython
from fmu_controller.fixed_linalg cimport cholesky, forward_substitute, smallest_eigenvalue, sturm_count, trace
from fmu_controller.sotc_math cimport basis_directional, error_rate, policy_arguments, printed_rate, reward, tanh_law

@cython.locals(N=int, i=int, k=int, a=int, c=int, o=int, ee=double, xa=double)
cpdef void cl_matrix(int n, list E, list rew, list M, list b, list sc)
@cython.locals(i=int, k=int, eta=list)
cpdef void replay_current(int n, list W, list z, list dinv, list fe, double s, tuple r, tuple theta, tuple lam1,
                          tuple lam2, bint backstepping, bint coupled, list E, list rew)
@cython.locals(N=int, o=int, a=int, c=int, xa=double, ya=double)
cpdef void trial_matrix(list M, double sc_j, list E, int j, double c_sc, list eta, list out)
