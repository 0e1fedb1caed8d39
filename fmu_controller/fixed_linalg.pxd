# Declarations for the compiled cores (orchestration/fmu_build/compiled.py): C types for fixed_linalg.py, which
# stays the one source of the loops and runs as it is wherever the cores are not compiled.
cimport cython


@cython.locals(acc=double, k=int)
cpdef double dot(list a, list b, int n)
@cython.locals(acc=double, k=int)
cpdef double trace(list A, int n)
@cython.locals(acc=double, djj=double, i=int, j=int, k=int)
cpdef bint cholesky(list A, int n, list L)
@cython.locals(acc=double, i=int, k=int)
cpdef void forward_substitute(list L, list b, int n, list y)
@cython.locals(acc=double, i=int, k=int)
cpdef void cholesky_solve(list L, list b, int n, list x)
@cython.locals(m0=int, scale=double, x0=double, alpha=double, vv=double, acc=double, kk=double, i=int, j=int)
cdef double _reflect(list A, int n, int k, list v, list p)
@cython.locals(A=list, v=list, p=list, k=int)
cpdef void tridiagonalize(list M, int n, list d, list e)
@cython.locals(count=int, q=double, i=int)
cpdef int sturm_count(list d, list e, int n, double x)
@cython.locals(lo=double, hi=double, r=double, i=int)
cpdef (double, double) gershgorin(list d, list e, int n)
@cython.locals(lo=double, hi=double, mid=double)
cpdef double smallest_of_tridiagonal(list d, list e, int n, double resolution)
cpdef double smallest_eigenvalue(list M, int n, list d, list e)
