# Declarations for the compiled cores (orchestration/fmu_build/compiled.py): C types for fixed_linalg.py, which
# stays the one source of the loops and runs as it is wherever the cores are not compiled. Every vector and
# flat matrix is a contiguous float64 buffer (array('d')), a C array here.
cimport cython
from libc cimport math

@cython.locals(acc=double, k=int)
cpdef double dot(double[::1] a, double[::1] b, int n) noexcept
@cython.locals(acc=double, k=int)
cpdef double dot_sequence(object a, object b)
@cython.locals(k=int)
cpdef void scale_into(double[::1] out, double a, double[::1] x, int n) noexcept
@cython.locals(k=int)
cpdef void add_scaled(double[::1] out, double a, double[::1] x, int n) noexcept
@cython.locals(acc=double, k=int)
cpdef double trace(double[::1] A, int n) noexcept
@cython.locals(acc=double, djj=double, i=int, j=int, k=int)
cpdef bint cholesky(double[::1] A, int n, double[::1] L)
@cython.locals(acc=double, i=int, k=int)
cpdef void forward_substitute(double[::1] L, double[::1] b, int n, double[::1] y, int o=*)
@cython.locals(acc=double, i=int, k=int)
cpdef void cholesky_solve(double[::1] L, double[::1] b, int n, double[::1] x)
@cython.locals(m0=int, scale=double, x0=double, alpha=double, vv=double, acc=double, kk=double, i=int, j=int)
cdef double _reflect(double[::1] A, int n, int k, double[::1] v, double[::1] p)
@cython.locals(k=int)
cpdef void tridiagonalize(double[::1] M, int n, double[::1] d, double[::1] e, double[::1] A, double[::1] v,
                          double[::1] p)
@cython.locals(count=int, q=double, i=int)
cpdef int sturm_count(double[::1] d, double[::1] e, int n, double x)
@cython.locals(lo=double, hi=double, r=double, i=int)
cpdef (double, double) gershgorin(double[::1] d, double[::1] e, int n) noexcept
@cython.locals(k=int, span=double)
cpdef int halvings(double width, double resolution)
@cython.locals(lo=double, hi=double, mid=double, it=int)
cpdef double smallest_of_tridiagonal(double[::1] d, double[::1] e, int n, double resolution, int k=*)
cpdef double smallest_eigenvalue(double[::1] M, int n, double[::1] d, double[::1] e, double[::1] A, double[::1] v,
                                 double[::1] p, int k=*)
