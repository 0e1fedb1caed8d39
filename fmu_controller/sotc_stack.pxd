# Declarations for the compiled cores (orchestration/fmu_build/compiled.py): C types for sotc_stack.py, which
# stays the one source of the loops and runs as it is wherever the cores are not compiled. The stack's rows
# and matrices are contiguous float64 buffers (array('d')), C arrays here; tanh is elementary.pxd's. CLStack is
# an extension type: C ints, doubles and flags, its buffers as C arrays (the Python-facing ones public), the
# per-sample paths (cl_terms, record, the swap trials) C methods; _swap_row stays cpdef so that a Python
# subclass can override it (orchestration/study/swap_margin.py).
cimport cython
from fmu_numerics.elementary cimport tanh
from fmu_numerics.fixed_linalg cimport cholesky, forward_substitute, smallest_eigenvalue, sturm_count, trace
from fmu_controller.sotc_math cimport CriticConstants, critic_row, normalisation, policy_arguments

@cython.locals(N=int, i=int, k=int, a=int, c=int, o=int, ee=double, xa=double)
cpdef void cl_matrix(int n, double[::1] E, double[::1] rew, double[::1] M, double[::1] b, double[::1] sc)
@cython.locals(N=int, a=int, c=int, acc=double)
cpdef void cl_rate(double[::1] M, double[::1] b, double[::1] W, double[::1] out)
@cython.locals(i=int, s=double, zp1=double, zp2=double, zv1=double, zv2=double, i11=double, i12=double, i22=double,
               x1=double, x2=double, x3=double, x4=double, t1=double, t2=double, t3=double, t4=double)
cpdef void replay_current(CriticConstants K, int n, double[::1] W, double[::1] z, double[::1] dinv, double[::1] fe,
                          double[::1] E, double[::1] rew)
@cython.locals(N=int, count=int, j=int, k=int, yy=double, within=bint)
cpdef int rows_within(double[::1] L, double[::1] E, double[::1] sc, int P, double[::1] y, double[::1] inside)
@cython.locals(N=int, o=int, a=int, c=int, xa=double, ya=double)
cpdef void trial_matrix(double[::1] M, double sc_j, double[::1] E, int j, double c_sc, double[::1] eta,
                        double[::1] out)

cdef class CLStack:
    cdef public int P, count, next_row, swaps
    cdef public object selection, replay_form, rows, rew, t
    cdef public CriticConstants constants
    cdef public double min_eig, margin
    cdef public double[::1] M, b, sc, E, rew_now
    cdef double[::1] _rate, _c, _d, _e, _v, _p, _y, _work, _A, _L, _inside, _found, _lams
    cdef double[::1] _eta, _z, _dinv, _fe, _rew, _t
    cdef bint _current, _stored, _fill, _fifo, _raw

    cpdef void clear(self) except *
    cdef void _bind(self) except *
    cpdef void refresh(self) except *
    cpdef double[::1] cl_terms(self, double[::1] W)
    @cython.locals(n=int, margin=double, lam=double, rank=int)
    cpdef (double, int, double) spectrum(self, double shift=*) except *
    @cython.locals(ready=bint, lam=double, rank=int, margin=double, row=int)
    cpdef bint record(self, double[::1] eta, double rew, double[::1] z, double[::1] dinv, double[::1] fe, double t,
                      bint terms_ready) except *
    cdef double _smallest(self, double[::1] M, int k=*) except *
    @cython.locals(N=int, k=int)
    cdef void _put(self, int row, double[::1] eta, double rew, double[::1] z, double[::1] dinv, double[::1] fe,
                   double t) except *
    @cython.locals(N=int, a=int, ee=double, c_sc=double, lam=double, rank=int, margin=double, k=int, low=double,
                   gain=double)
    cpdef int _swap_row(self, double[::1] eta, (double, int, double) spectrum, double shift=*) except *
    @cython.locals(j=int)
    cdef int _swap_raising(self, double c_sc, int k, double thr, double window) except *
    @cython.locals(N=int, a=int)
    cdef bint _may_pass(self, double c_sc, double thr) except *
    @cython.locals(j=int, row=int, best=double)
    cdef int _oldest_best(self, double window)
    @cython.locals(j=int, row=int, best=double, trial=double)
    cdef int _swap_raw(self, double c_sc, double lam) except *
