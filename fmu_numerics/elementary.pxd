# Declarations for the compiled cores (orchestration/fmu_build/compiled.py): C types for elementary.py, which
# stays the one source of the algorithms and runs as it is wherever the cores are not compiled. ``math`` is
# libc's here: sqrt (correctly rounded by IEEE 754, as Python's), copysign and ldexp (exact), no Python call.
cimport cython
from libc cimport math

cdef double INF, NAN, SHIFT, TINY, P2_M1000, P2_M900, P2_M600, P2_M500, P2_M200, P2_M54, P2_60, P2_200, P2_500
cdef double P2_600, P2_900, SPLIT, SQRT2, SQRT_HALF, LN2_HI, LN2_LO, INV_LN2, PIO2_1, PIO2_2, PIO2_3, INV_PIO2
cdef double PI_HI, PI_LO, HALF_PI_HI, HALF_PI_LO, QUARTER_PI_HI, QUARTER_PI_LO, ATAN_HALF_HI, ATAN_HALF_LO
cdef double EXP_OVER, EXP_UNDER, SINH_OVER, TANH_POLY_MAX, SINH_POLY_MAX, COSH_HALF_MAX, MEDIUM
# C arrays (the .py's tuples, of these lengths)
cdef double EXP_POLY[12]
cdef double LOG_POLY[9]
cdef double TANH_POLY[12]
cdef double SINH_POLY[8]
cdef double SIN_POLY[7]
cdef double COS_POLY[7]
cdef double ATAN_POLY[13]
cdef double POW2_E[10]
cdef double POW2_UP[10]
cdef double POW2_DOWN[10]
cdef int POW2_N

cdef double _nearest(double v) noexcept
@cython.locals(e=int)
cdef double _pow2(double k) noexcept
cdef double _scale(double y, double k) noexcept
@cython.locals(i=int)
cdef (double, double) _normalize(double u) noexcept
@cython.locals(p=double, t=double, ah=double, al=double, bh=double, bl=double)
cdef (double, double) _two_prod(double a, double b) noexcept
@cython.locals(k=double, r=double, one_r=double, c="const double *", series=double, tail=double, hi=double)
cdef (double, double, double) _exp_parts(double x) noexcept
@cython.locals(k=double, hi=double, lo=double)
cpdef double exp(double x) noexcept
@cython.locals(s=double, z=double, hfsq=double, q="const double *", series=double)
cdef double _log_reduced(double k, double f, double c) noexcept
@cython.locals(k=double, m=double)
cpdef double log(double x) noexcept
cpdef double log1p(double x) noexcept
@cython.locals(u=double, err=double, k=double, m=double)
cdef double _log1p_parts(double x, double xl) noexcept
@cython.locals(z=double, zl=double, c="const double *", series=double, p=double, pl=double, t=double)
cdef double _tanh_poly(double x) noexcept
@cython.locals(z=double, c="const double *")
cdef double _sinh_poly(double x) noexcept
@cython.locals(a=double, t=double, k=double, hi=double, lo=double, scale=double, d=double, dl=double, q=double,
               ql=double, p=double, pl=double)
cpdef double tanh(double x) noexcept
@cython.locals(k=double, hi=double, lo=double, inv=double)
cdef double _exp_pair(double a, double sign) noexcept
@cython.locals(a=double, h=double)
cpdef double sinh(double x) noexcept
@cython.locals(a=double, h=double)
cpdef double cosh(double x) noexcept
@cython.locals(a=double, d=double, dl=double, y=double, p=double, pl=double, r=double)
cpdef double atanh(double x) noexcept
@cython.locals(z=double, c="const double *", series=double)
cdef double _sin_kernel(double hi, double lo) noexcept
@cython.locals(z=double, hz=double, w=double, c="const double *", series=double)
cdef double _cos_kernel(double hi, double lo) noexcept
@cython.locals(k=double, a=double, b=double, r=double, bv=double, err=double, tail=double, hi=double, q=double,
               n=double)
cdef (double, double, double) _reduce(double x)
@cython.locals(v=double)
cdef double _quadrant(double m, double hi, double lo) noexcept
@cython.locals(a=double, n=double, hi=double, lo=double)
cpdef double sin(double x)
@cython.locals(a=double, n=double, hi=double, lo=double)
cpdef double cos(double x)
@cython.locals(n=double, hi=double, lo=double)
cpdef (double, double) sincos(double x)
@cython.locals(b=double, s=double, bv=double, err=double)
cdef double _two_sum_plus(double a_hi, double a_lo, double sign, double b_hi, double b_lo) noexcept
@cython.locals(num=double, den=double, den_lo=double, c_hi=double, c_lo=double, r=double, p=double, pl=double,
               rl=double, z=double, q="const double *", series=double)
cdef (double, double) _atan_ratio(double n, double d, double extra) noexcept
@cython.locals(neg_x=bint, t=double)
cdef double _atan2_special(double y, double x) noexcept
@cython.locals(t=double)
cpdef double atan2(double y, double x) noexcept
@cython.locals(d=double, swap=bint, sign=double, c_hi=double, rest=double, scale=double)
cdef double _angle(double n, double x, double extra) noexcept
@cython.locals(a=double, al=double, b=double, bl=double, p=double, pl=double, y=double, sq=double, sql=double)
cpdef double acos(double x) noexcept
@cython.locals(a=double, b=double, scale=double, t=double, tl=double)
cpdef double hypot(double x, double y) noexcept
@cython.locals(p=double, pl=double, q=double, ql=double, t=double)
cdef (double, double) _sum_of_squares(double a, double b) noexcept
@cython.locals(sq=double, sql=double)
cdef double _corrected_root(double h, double t, double tl) noexcept
